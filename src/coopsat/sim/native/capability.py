"""Whether the native CPU kernels run in this process: decided once, with the XLA path as the
fallback that is always correct.

The kernels read XLA's FFI call frame as raw words (:mod:`coopsat.sim.native.ffi`), so they are
trusted only where that reading was tested. At the first run that could use them, in order:

1. the switch: ``native=`` of :func:`coopsat.run` / :func:`coopsat.sim.engine.simulate`, else
   the environment variable :data:`ENV` (``0``, ``1`` or ``auto``, the default);
2. the platform and architecture (:data:`PLATFORMS`: 64-bit Linux; elsewhere they were never
   run), JAX's default device the CPU (on a GPU the whole loop runs there, in XLA), and the
   process in float64 (``jax_enable_x64``: the kernels read float64 arrays);
3. jax and jaxlib lie in :data:`TESTED_JAX`, the range the test suite runs on (CI's newest
   and lowest-versions jobs), and numba, llvmlite and ``jax.ffi`` import;
4. a probe: a small synthetic formation (:mod:`coopsat.sim.synthetic`) that goes through each
   native target — the rigid-body tick, the pulsed (piecewise) tick, the consensus law, and
   XLA's thread pool — run once with the kernels and once without, the two compared.

The probe compiles six small loops: about 7 s with JAX's persistent cache warm and 25 s with
it empty (the 2-core machine), more than a short run takes on the XLA path. So its verdict is
kept on disk where the process keeps JAX's persistent compilation cache (the command line
always; a library user who turned that cache on), keyed by everything it depends on
(:func:`install_key`), and a process with no verdict yet runs the probe only for a run of at
least :data:`PROBE_WORTH_SC_STEPS`: a smaller one takes the XLA path and leaves the verdict
open (the plant kernels give XLA's bits; the law kernel, used from 128 spacecraft, rounds
differently by about 1e-16).

``auto`` takes the XLA path when a step fails, with one :class:`NativeFallbackWarning` per
process naming the reason (the command line prints it as one line); ``1`` makes the failure an
error (:class:`NativeUnavailableError`), for a test or a benchmark that must measure the
kernels. The verdict is kept for the process, so every run of a process — alone, in a batch, in
a campaign's replay — takes the same path and gives the same bits.
"""

import hashlib
import json
import os
import platform
import sys
import threading
import warnings
from importlib import metadata
from pathlib import Path
from typing import NamedTuple

from coopsat.core.errors import CoopsatWarning, PlatformError

ENV = "COOPSAT_NATIVE"
"""Environment variable of the switch: ``0`` (XLA only), ``1`` (kernels, or an error), ``auto``."""

MODES = ("0", "1", "auto")

PLATFORMS = {("linux", "x86_64"), ("linux", "aarch64")}
"""(``sys.platform``, ``platform.machine()``) where the kernels were built and run."""

TESTED_JAX = ((0, 9, 1), (0, 11, 0))
"""jax and jaxlib versions the kernels are tested on, the first included, the second excluded
(CI's lowest-versions job runs the first). jaxlib 0.9.1 is the first whose XLA FFI is API
version 0.3, the handlers' (earlier ones refuse them at registration); the next minor may change
the FFI: raise the bound once tested. pyproject.toml admits newer jax (0.11, 0.12), on which the
whole loop runs in XLA (the auto choice falls back with one notice)."""

PROBE_RTOL = 1e-12
"""Largest difference between the probe's runs, relative to each output's scale. The plant
kernels are bit-identical to XLA; the law kernel rounds differently (≈ 1e-16 relative)."""


PROBE_WORTH_SC_STEPS = 2e7
"""Smallest run, in spacecraft × integration steps, for which a process with no verdict runs
the probe: about 10 s of the XLA loop at the consensus benchmark's 2e6 spacecraft-steps/s,
the probe's own cost with empty caches."""


class NativeFallbackWarning(CoopsatWarning):
    """The native kernels are off in this process and the XLA path runs (results unchanged)."""


class NativeUnavailableError(PlatformError):
    """The native kernels were required (``COOPSAT_NATIVE=1`` or ``native=True``) but cannot
    run here; or the switch has a value it does not know."""


class Verdict(NamedTuple):
    """Whether the kernels may run, and why not (None when they may)."""

    native: bool
    reason: str | None


def requested(native=None):
    """The mode asked for: ``native`` (True → ``"1"``, False → ``"0"``) when given, else the
    environment variable :data:`ENV` (default ``"auto"``).

    Raises
    ------
    NativeUnavailableError
        When :data:`ENV` holds another value.
    """
    if native is not None:
        return "1" if native else "0"
    value = os.environ.get(ENV, "auto").strip().lower() or "auto"
    if value not in MODES:
        raise NativeUnavailableError(f"{ENV}={os.environ[ENV]!r}: expected 0, 1 or auto")
    return value


def platform_problem(system=None, machine=None):
    """Why the kernels cannot run on this platform (None when they can). ``system``,
    ``machine``: ``sys.platform`` and ``platform.machine()`` unless given."""
    system = sys.platform if system is None else system
    machine = (platform.machine() if machine is None else machine).lower()
    machine = {"amd64": "x86_64", "arm64": "aarch64"}.get(machine, machine)
    if (system, machine) not in PLATFORMS:
        return f"the native kernels are built and tested on 64-bit Linux only, not on {system} {machine}"
    return None


def device_problem(backend=None):
    """Why the CPU kernels do not apply to JAX's default device (None when it is the CPU): on a
    GPU the whole loop runs there, in XLA. ``backend``: ``jax.default_backend()`` unless given."""
    if backend is None:
        import jax

        backend = jax.default_backend()
    if backend != "cpu":
        return f"JAX runs on the {backend} here, so the whole loop runs there in XLA"
    return None


def precision_problem(x64=None):
    """Why the kernels cannot run at this process's precision (None when they can): they read
    float64 arrays, and a process that declined ``jax_enable_x64`` (``coopsat.configure(
    float64=False)``) makes float32 ones. Decided before the probe, so that such a process
    neither probes nor keeps a negative verdict on disk where a float64 process of the same
    install would read it. ``x64``: ``jax_enable_x64`` unless given."""
    if x64 is None:
        import jax

        from coopsat.core import runtime

        runtime.enable()  # the process's choice applied first, as every run applies it
        x64 = jax.config.jax_enable_x64
    if not x64:
        return "jax_enable_x64 is off in this process and the kernels read float64 arrays"
    return None


def _release(version):
    """(major, minor, micro) of a version string such as ``0.10.2``, ``0.9`` or ``0.5.0.dev1``."""
    parts = [int("".join(c for c in part if c.isdigit()) or 0) for part in version.split(".")[:3]]
    return tuple(parts + [0] * (3 - len(parts)))


def version_problem(versions=None):
    """Why the installed jax/jaxlib cannot run the kernels (None when they can). ``versions``:
    ``{"jax": "0.10.2", "jaxlib": "0.10.2"}`` unless given (installed metadata)."""
    if versions is None:
        versions = {name: metadata.version(name) for name in ("jax", "jaxlib")}
    low, high = TESTED_JAX
    for name, version in versions.items():
        if not low <= _release(version) < high:
            return (f"{name} {version} is outside >={'.'.join(map(str, low))},<{'.'.join(map(str, high))}, the range the "
                    "native kernels are tested on")
    return None


def import_problem():
    """Why the kernels' libraries cannot be used (None when they can): numba, llvmlite and
    ``jax.ffi``."""
    try:
        import llvmlite  # noqa: F401
        import numba  # noqa: F401
    except ImportError as err:
        return f"{err.name or 'numba'} cannot be imported ({err}); it is a dependency of coopsat: reinstall coopsat"
    import jax

    if not hasattr(jax, "ffi"):
        return f"jax {jax.__version__} has no jax.ffi"
    return None


def probe_problem():
    """Why the probe runs disagree or fail (None when they agree): each native target once with
    the kernels and once without, on a synthetic formation (:func:`coopsat.sim.synthetic.
    probe_systems`)."""
    import numpy as np

    from coopsat.sim.engine import simulate_as_built
    from coopsat.sim.synthetic import probe_systems

    for what, (native, xla, n_records, record_s) in probe_systems().items():
        try:
            a = simulate_as_built(native, n_records, record_s).samples
            b = simulate_as_built(xla, n_records, record_s).samples
        except Exception as err:  # any failure of the kernels is a reason to fall back
            line = str(err).strip().splitlines()[0] if str(err).strip() else ""
            return f"the probe run ({what}) failed: {type(err).__name__}: {line}"[:300]
        for key in b:
            scale = max(float(np.max(np.abs(b[key]), initial=0.0)), 1e-300)
            if a[key].shape != b[key].shape or not np.all(np.abs(a[key] - b[key]) <= PROBE_RTOL * scale):
                return f"the probe run ({what}) differs from the XLA path in '{key}'"
    return None


def install_key():
    """What the probe's verdict depends on, hashed: the versions of Python, coopsat, jax,
    jaxlib, numba, llvmlite and numpy, the machine, and the engine's source (every module of
    ``coopsat.sim``, kernels included), so that any change re-runs the probe."""
    import coopsat

    sim = Path(__file__).resolve().parents[1]
    digest = hashlib.sha256()
    for path in sorted(sim.rglob("*.py")):
        digest.update(path.relative_to(sim).as_posix().encode() + b"\0" + path.read_bytes())
    versions = {name: metadata.version(name) for name in ("jax", "jaxlib", "numba", "llvmlite", "numpy")}
    text = json.dumps([sys.version, platform.machine(), coopsat.__version__, versions, digest.hexdigest()])
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def verdict_path():
    """Where this install's verdict is kept: beside JAX's persistent compilation cache, or None
    when the process has none."""
    from coopsat.core.runtime import persistent_cache_dir

    folder = persistent_cache_dir("native")
    return folder / f"{install_key()}.json" if folder is not None else None


def _load_verdict(path):
    """The verdict kept at ``path``, or None (none, unreadable or not one)."""
    try:
        data = json.loads(path.read_text())
        return Verdict(bool(data["native"]), data["reason"] if data["reason"] is None else str(data["reason"]))
    except (OSError, ValueError, KeyError, TypeError):
        return None


def _keep_verdict(path, verdict):
    """Write ``verdict`` to ``path`` (:func:`coopsat.core.runtime.keep_in_cache`)."""
    from coopsat.core.runtime import keep_in_cache

    keep_in_cache(path, json.dumps(verdict._asdict()).encode())


_lock = threading.Lock()
_verdict = []
_warned = []
_static = []  # the platform, device, precision and version check's reason (None: passed), made once


def _checked(worth_probing=True):
    """The process's verdict: the first failing check's reason, or None (cached); None, with
    nothing decided, when only the probe could tell and the run is not ``worth_probing``."""
    with _lock:
        if not _verdict:
            # Kept apart from the verdict: a process that has none yet (its runs too small to
            # probe) asks again for every run, and reading the packages' metadata costs 1.5 ms.
            if not _static:
                _static.append(platform_problem() or device_problem() or precision_problem() or version_problem())
            reason = _static[0]
            path = verdict_path() if reason is None else None
            kept = _load_verdict(path) if path is not None else None
            if kept is None and reason is None:
                if not worth_probing:
                    return None
                reason = import_problem() or probe_problem()  # numba's import alone is 0.5 s
                if path is not None:
                    _keep_verdict(path, Verdict(reason is None, reason))
            _verdict.append(kept or Verdict(reason is None, reason))
        return _verdict[0]


def known_verdict():
    """The process's verdict when it is known without running the probe (a cached or kept one,
    or a platform or version problem), else None: for reporting which path a run took."""
    return _checked(worth_probing=False)


def use_native(native=None, sc_steps=None):
    """Whether this process runs the native kernels for a run that asks ``native`` (True,
    False, or None: :data:`ENV`). ``sc_steps``: the call's size (spacecraft × integration
    steps, a batch's runs together); in ``auto`` mode a process with no verdict yet runs the
    probe only when it is at least :data:`PROBE_WORTH_SC_STEPS` (or unknown).

    Raises
    ------
    NativeUnavailableError
        The kernels were required and cannot run, or :data:`ENV` is not 0, 1 or auto.
    """
    mode = requested(native)
    if mode == "0":
        return False
    verdict = _checked(mode == "1" or sc_steps is None or sc_steps >= PROBE_WORTH_SC_STEPS)
    if verdict is None:
        return False
    if verdict.native:
        return True
    if mode == "1":
        raise NativeUnavailableError(f"native kernels required ({ENV}=1 or native=True) but {verdict.reason}")
    if not _warned:
        _warned.append(True)
        warnings.warn(f"native CPU kernels off: {verdict.reason}; running the XLA path (same results, slower)",
                      NativeFallbackWarning, stacklevel=3)
    return False


def reset():
    """Forget the verdict and the notice (tests)."""
    with _lock:
        _verdict.clear()
        _warned.clear()
        _static.clear()
