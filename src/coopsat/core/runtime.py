"""JAX set-up: what coopsat's compiled code needs from JAX, done on request, never at import.

Importing any coopsat module changes nothing in the process: no environment variable, no JAX
configuration value, no lowering rule (tests/meta/test_import_side_effects.py checks it in a
fresh interpreter). Two functions describe what changes, each documented where it is public
(docs/api.md, "What coopsat changes in your process"):

* :func:`enable` — the one change a library user gets: the first run, batch or design call
  that builds a scenario turns on ``jax_enable_x64`` (the closed loop integrates attitude to
  1e-12 and float32 cannot) and lowers small Threefry hashes unrolled on the CPU (the same
  bits, 2–3× faster runs with per-period random draws). Both are process-wide; call
  :func:`coopsat.configure` first to choose.
* :func:`process_environment` — the environment of a process coopsat owns: XLA's CPU options
  (one device per core, YNNPACK fusions off) and the persistent compilation cache. Only the
  command line writes it into its own process (``coopsat.cli.configure_process``) and into the
  Dask workers it starts; this module writes nothing.
"""

import os
import re
import threading
from importlib.metadata import version
from pathlib import Path

UNROLLED_THREEFRY_MAX = 16
"""Largest Threefry hash (output elements) lowered unrolled on the CPU (:func:`_unroll_small_threefry`)."""

OWNED_PROCESS_VARIABLE = "COOPSAT_OWNED_PROCESS"
"""Set to 1 in the environment of the processes coopsat owns (the ``coopsat`` command and the
workers it starts, :func:`process_environment`): there the small-Threefry lowering is on unless
declined; in a library user's process it is on only when :func:`set_choices` asks for it."""

_enabled = False
_choices = {"float64": True, "unrolled_threefry": None}  # None: on only in a process coopsat owns
_applied = {}  # what enable() did, once it ran


def set_choices(float64=True, unrolled_threefry=False):
    """Record what :func:`enable` will do (``coopsat.configure``).

    Raises
    ------
    coopsat.core.errors.InputError
        JAX code already ran in this process with other choices: float64 and the lowering are
        set at the first build or run and stay (programs compiled under them are cached).
    """
    wanted = {"float64": bool(float64), "unrolled_threefry": bool(unrolled_threefry)}
    if _enabled and wanted != _applied:
        from coopsat.core.errors import InputError

        raise InputError(
            f"coopsat.configure({', '.join(f'{k}={v}' for k, v in wanted.items())}) is too late: the first build or run "
            f"of this process already applied {', '.join(f'{k}={v}' for k, v in _applied.items())}; call configure "
            "before anything builds or runs a scenario"
        )
    _choices.update(wanted)


_enable_lock = threading.Lock()


def enable():
    """Turn on float64 and, where chosen, the unrolled small Threefry lowering, once.

    Called by every coopsat entry that runs JAX code (scenario build, the engine, the public
    API); idempotent and cheap after the first call.
    """
    global _enabled
    if _enabled:
        return
    with _enable_lock:  # a second thread's first run waits until float64 is on, not just asked for
        if _enabled:
            return
        import jax

        unrolled = _choices["unrolled_threefry"]
        if unrolled is None:
            unrolled = os.environ.get(OWNED_PROCESS_VARIABLE) == "1"
        if _choices["float64"]:
            jax.config.update("jax_enable_x64", True)
        if unrolled:
            _unroll_small_threefry()
        _applied.update(float64=_choices["float64"], unrolled_threefry=unrolled)
        _enabled = True


def _cpu_devices():
    """How many CPU devices XLA presents: one per core this process may use, so that the
    groups of a large batch run on every core (``sim.programs._run_chunk_batched``); a single
    run stays on one. ``$COOPSAT_CPU_DEVICES`` overrides."""
    wanted = os.environ.get("COOPSAT_CPU_DEVICES")
    if wanted:
        return max(1, int(wanted))
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


YNN_FUSION_TYPES = ""
"""XLA:CPU's ``xla_cpu_experimental_ynn_fusion_type`` as coopsat chooses it: no fusion handed to
YNNPACK. Set in ``XLA_FLAGS`` for the processes coopsat owns (:func:`_xla_cpu_flags`) and, in
any process, as a compiler option of the engine's own programs (:mod:`coopsat.sim.compiler_options`)."""


def _xla_cpu_flags(cpu_devices=None):
    """XLA_FLAGS with ``cpu_devices`` CPU devices (default :func:`_cpu_devices`) and YNNPACK
    fusions off on the CPU, unless the user chose otherwise.

    XLA:CPU (jaxlib ≥ 0.10) hands small reductions, such as the per-receiver sum of a
    consensus law over a padded in-neighbour table, to YNNPACK as opaque kernels that also
    stop the surrounding elementwise code from fusing: off, the consensus loop runs 1.2× faster
    at N = 1000 and 1.5× for a batch of 256 runs of N = 5 (`coopsat bench`, docs/architecture.md
    §"Engine speed"). Older jaxlibs do not know the flag (and abort on unknown flags).
    """
    flags = os.environ.get("XLA_FLAGS", "")
    if cpu_devices is not None or os.environ.get("COOPSAT_CPU_DEVICES"):
        # Explicit, so it wins over a count inherited from a parent process's XLA_FLAGS (a
        # campaign's workers inherit the driver's).
        flags = re.sub(r"\s*--xla_force_host_platform_device_count=\S*", "", flags)
    if "xla_force_host_platform_device_count" not in flags:
        flags = f"{flags} --xla_force_host_platform_device_count={cpu_devices or _cpu_devices()}".strip()
    try:
        major, minor = (int(v) for v in version("jaxlib").split(".")[:2])
    except (ValueError, ImportError):
        return flags
    if (major, minor) < (0, 10) or "xla_cpu_experimental_ynn_fusion_type" in flags:
        return flags
    return f"{flags} --xla_cpu_experimental_ynn_fusion_type={YNN_FUSION_TYPES}".strip()


CACHE_SETTINGS = {
    # Cache every compiled program, not only slow ones: the closed loop compiles in about a
    # second, below JAX's default threshold but still most of a short run's wall time.
    "jax_persistent_cache_min_compile_time_secs": 0.0,
    "jax_persistent_cache_min_entry_size_bytes": 0,
}


def cache_settings():
    """JAX's persistent-cache options as coopsat's own processes use them (name -> value):
    ``$COOPSAT_JAX_CACHE`` or ``~/.cache/coopsat/jax``, every program cached."""
    cache_dir = os.environ.get("COOPSAT_JAX_CACHE") or str(Path.home() / ".cache" / "coopsat" / "jax")
    return {"jax_compilation_cache_dir": cache_dir, **CACHE_SETTINGS}


def persistent_cache_dir(kind):
    """Folder ``coopsat-<kind>`` inside JAX's persistent compilation cache, where coopsat keeps
    what is worth keeping between processes (the native kernels' verdict, design results);
    None when this process has no such cache (a library user who did not opt in)."""
    import sys

    jax = sys.modules.get("jax")
    cache_dir = jax.config.jax_compilation_cache_dir if jax is not None else os.environ.get("JAX_COMPILATION_CACHE_DIR")
    return Path(cache_dir) / f"coopsat-{kind}" if cache_dir else None


def keep_in_cache(path, data):
    """Write ``data`` (bytes) to ``path`` in the persistent cache atomically (a temporary
    sibling renamed into place: a reader never meets half a file); a cache that cannot be
    written is skipped, since it only saves time."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_bytes(data)
        os.replace(tmp, path)
    except OSError:
        pass


def process_environment(cpu_devices=None, cache=True):
    """Environment variables of a process coopsat starts itself (a campaign's Dask worker):
    ``XLA_FLAGS`` (:func:`_xla_cpu_flags`) and, with ``cache``, the ``JAX_*`` variables of
    :func:`cache_settings` (JAX reads them when it is imported); :data:`OWNED_PROCESS_VARIABLE`
    marks it as coopsat's own."""
    env = {"XLA_FLAGS": _xla_cpu_flags(cpu_devices), OWNED_PROCESS_VARIABLE: "1"}
    if cache:
        env.update({name.upper(): str(value) for name, value in cache_settings().items()})
    return env


def _unroll_small_threefry():
    """On the CPU, lower small Threefry hashes (a key's ``fold_in``, a few spacecraft's noise)
    as straight-line code instead of JAX's rolled loop.

    JAX lowers Threefry on the CPU as a ``fori_loop`` of five rounds (to keep compilation
    small), and inside the closed loop, where XLA cannot hoist that loop, each hash is a
    while loop of five iterations of kernel launches: a ``fold_in`` cost 630 ns against
    35 ns unrolled (measured in a loop), and a period does one per part that draws. Unrolled
    up to :data:`UNROLLED_THREEFRY_MAX` elements: ``observation-cooperative`` 1.19 → 0.86 s,
    ``observation-independent`` 0.93 → 0.60 s, ``delay-classic`` 0.092 → 0.027 s; larger
    hashes keep the rolled loop (unrolled, the PSO's draws made ``cartwheel-keeping-pso``
    3× slower). The hash is the same integer arithmetic either way, so every random number
    is unchanged. JAX's private module may move (it is ``jax._src.prng`` before jax 0.10.2):
    where neither holds the lowering rules, nothing is changed."""
    from math import prod

    try:
        from jax.interpreters import mlir

        try:
            from jax._src.random import threefry2x32 as threefry
        except ImportError:
            from jax._src import prng as threefry

        rolled, unrolled = threefry._threefry2x32_cpu_lowering_rule, threefry._threefry2x32_lowering_rule
        primitive = threefry.threefry2x32_p
    except (ImportError, AttributeError):
        return

    def lowering(ctx, *args):
        small = prod(ctx.avals_out[0].shape) <= UNROLLED_THREEFRY_MAX
        return (unrolled if small else rolled)(ctx, *args)

    mlir.register_lowering(primitive, lowering, platform="cpu")
