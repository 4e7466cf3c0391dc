"""What decides the bits of a campaign's batch: recorded where the batch ran, compared when a
run of it is replayed.

A run's result is the same bit for bit only where the same code runs the same way: the same
coopsat, jax and jaxlib (XLA generates the loop's code), numpy and scipy (the design), the same
CPU family (XLA compiles for the host's instruction set), the same device kind, the same XLA
options, and the same path through the loop — the native CPU kernels or XLA's code
(:mod:`coopsat.sim.native.capability`), which a process decides for itself (the switch
``COOPSAT_NATIVE``, the platform, a verdict kept beside JAX's persistent cache). A Dask worker
started by hand need not decide as the replaying process does, so each batch records what its
worker had (:func:`batch_provenance`, run on the worker) in its Parquet file's key-value
metadata (:data:`KEY`), and :func:`compare` says which of it differs in the replaying process.
"""

import json
import os
import platform
import re
from importlib import metadata

KEY = b"coopsat.provenance"
"""Key of the batch's provenance (JSON) in its Parquet file's key-value metadata: one record per
batch, which every row shares, so it goes beside the rows rather than into a column of each
(the rows, the report's input, stay as they were)."""

CODE_FIELDS = ("coopsat", "jax", "jaxlib")
"""Fields whose difference changes the code that runs: no agreement is promised."""

ROUNDING_FIELDS = ("numpy", "scipy", "machine", "os", "cpu", "device_kind", "native", "xla_flags")
"""Fields whose difference changes the order or kind of roundings, the code being the same."""

ISA_FLAGS = ("sse4_2", "avx", "avx2", "fma", "avx512f", "asimd", "sve")
"""Instruction-set flags of ``/proc/cpuinfo`` that name a CPU family for XLA's code generator
(x86-64 and AArch64): the vector width and fused multiply-add change roundings."""

DEVICE_COUNT_FLAG = re.compile(r"--xla_force_host_platform_device_count=\S*")

TOLERANCE_CODE = "no agreement is expected (another {field} generates other code)"

TOLERANCE_ROUNDING = ("agreement within relative 1e-12 is expected for a design without solver (\"direct\"; 1e-9 a "
                      "matrix-equation design, 1e-4 an LMI one), none in a chaotic run (rounding grows)")


def cpu_family(cpuinfo, machine):
    """The CPU family that decides XLA's code: ``/proc/cpuinfo``'s first model name
    (``machine`` where it has none, as on most ARM kernels) and the :data:`ISA_FLAGS` its first
    ``flags`` (x86) or ``Features`` (ARM) line lists, e.g. ``Intel(R) Xeon(R) Processor [avx
    avx2 avx512f fma sse4_2]``."""
    fields = {}
    for line in cpuinfo.splitlines():
        name, sep, value = line.partition(":")
        if sep:
            fields.setdefault(name.strip().lower(), value.strip())
    model = fields.get("model name") or machine
    flags = set((fields.get("flags") or fields.get("features") or "").split())
    return f"{model} [{' '.join(sorted(f for f in ISA_FLAGS if f in flags))}]"


def _read_cpuinfo():
    """``/proc/cpuinfo``'s text, or "" where there is none (not Linux)."""
    try:
        with open("/proc/cpuinfo") as f:
            return f.read()
    except OSError:
        return ""


def comparable_xla_flags(flags):
    """``XLA_FLAGS`` as compared: sorted, without the CPU device count, which does not decide a
    campaign's bits (every batch runs on one device: ``simulate_runs(every_core=False)``) and
    differs between local workers (one device each) and a replaying command (one per core)."""
    return " ".join(sorted(DEVICE_COUNT_FLAG.sub("", flags or "").split()))


def native_choice(builds, native=None):
    """Whether this process runs the native kernels for a batch's built runs, and why not.

    The engine decides per call (:func:`coopsat.sim.engine.with_native_decided`): until the
    process has a verdict, a call too small for the probe (a batch counted whole) takes XLA's
    path, and the first one large enough runs the probe that decides every later one. So every
    run is decided once, as part of the whole batch (any probe runs now), then again: that
    second answer is the one every group of the batch gets when it is simulated next.

    Returns
    -------
    (native, reason)
        ``native``: True, False, or None when no run is simulated; ``reason``: why they are
        off (None when on).
    """
    from coopsat.sim.engine import with_native_decided

    # Counted as the engine counts a batch: all the batch's runs together.
    for b in builds:
        with_native_decided(b.system, b.n_records, native, len(builds))
    used = {with_native_decided(b.system, b.n_records, native, len(builds)).structure.native for b in builds}
    if not used:
        return None, "no run of the batch was simulated"
    on = used == {True}
    return on, None if on else _native_off_reason(native)


def _native_off_reason(native):
    """Why the kernels are off in this process for a run that asks ``native``."""
    from coopsat.sim.native import capability

    if native is False:
        return "native=False (the path the replayed batch took)"
    if capability.requested(native) == "0":
        return f"{capability.ENV}=0"
    verdict = capability.known_verdict()  # the capability module's own, read without probing
    if verdict is None:
        return (f"no verdict in this process (none kept beside a persistent JAX cache) and its batch is below the "
                f"probe's {capability.PROBE_WORTH_SC_STEPS:.0e} spacecraft-steps")
    return verdict.reason


def batch_provenance(builds, run_ids, native=None, build=""):
    """What decides the bits of a batch, in the process that runs it (a Dask worker): the
    versions, the platform and CPU family, JAX's devices, ``XLA_FLAGS``, the native kernels'
    choice (:func:`native_choice`, made now, before the batch is simulated), and the batch's
    runs in order (a run's position in its batch is its index in ``run_ids``); with ``build``,
    how its runs were built (one line, :func:`coopsat.workflows.sweep.build_runs`: the same
    bits either way, so it is not compared). The runner adds ``seconds``, where the batch's time
    went (not compared either).

    Raises
    ------
    NativeUnavailableError
        ``native`` is True and the kernels cannot run here.
    """
    import jax

    import coopsat

    on, reason = native_choice(builds, native)
    devices = jax.devices()
    return {
        "coopsat": coopsat.__version__,
        **{name: metadata.version(name) for name in ("jax", "jaxlib", "numpy", "scipy")},
        "machine": platform.machine(),
        "os": platform.system(),
        "cpu": cpu_family(_read_cpuinfo(), platform.machine()),
        "device_kind": devices[0].device_kind,
        "device_count": len(devices),
        "native": on,
        "native_reason": reason,
        "xla_flags": os.environ.get("XLA_FLAGS", ""),
        "batch_size": len(run_ids),
        "run_ids": list(run_ids),
        "build": build,
    }


def to_metadata(provenance):
    """The Parquet key-value metadata holding ``provenance`` (:data:`KEY`)."""
    return {KEY: json.dumps(provenance, sort_keys=True).encode()}


def read_provenance(path):
    """The provenance stored in a batch's Parquet file, or None (a batch written before it was
    recorded)."""
    import pyarrow.parquet as pq

    stored = (pq.read_schema(path).metadata or {}).get(KEY)
    return json.loads(stored) if stored is not None else None


def _comparable(provenance, field):
    """A provenance's ``field`` as compared (:func:`comparable_xla_flags` for ``xla_flags``)."""
    value = provenance.get(field)
    return comparable_xla_flags(value) if field == "xla_flags" else value


def compare(stored, here):
    """The fields deciding bits that differ between a batch's ``stored`` provenance and the
    replaying process's (``here``), each as ``field (stored …, here …)``, and the agreement that
    then applies (None when none differs: bit for bit).

    The tolerance is the weakest that any differing field implies: none for another coopsat,
    jax or jaxlib (:data:`TOLERANCE_CODE`), else tests/data/README.md's cross-platform rows
    (:data:`TOLERANCE_ROUNDING`)."""
    fields = [f for f in (*CODE_FIELDS, *ROUNDING_FIELDS) if _comparable(stored, f) != _comparable(here, f)]
    differences = tuple(f"{f} (stored {_comparable(stored, f)!r}, here {_comparable(here, f)!r})" for f in fields)
    code = [f for f in fields if f in CODE_FIELDS]
    if code:
        return differences, TOLERANCE_CODE.format(field=code[0])
    return differences, TOLERANCE_ROUNDING if fields else None


def summary_line(stored, differences, tolerance):
    """One line on the provenance of a replay: none recorded, as stored, or what differs and the
    agreement that applies."""
    if stored is None:
        return "provenance: no provenance recorded (a batch written before it was); replayed with this process's choices"
    if not differences:
        native = "on" if stored["native"] else f"off: {stored['native_reason']}"
        return (f"provenance: replayed as the batch ran (jax {stored['jax']}, jaxlib {stored['jaxlib']}, {stored['os']} "
                f"{stored['machine']}, {stored['cpu']}, native kernels {native}): bit for bit expected")
    return f"provenance: differs in {'; '.join(differences)}: {tolerance}"
