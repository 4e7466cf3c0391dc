"""The closed-loop engine: integer ticks, zero-order hold, RK4, one compiled scan per chunk.

:func:`simulate` runs a :class:`~coopsat.sim.system.System` (or a batch of them) in stages:
the chunk size; for a batch, its preparation (:mod:`coopsat.sim.batching`: shared time base,
bucket size, groups, padding); the compiled programs, made once per structure, shapes and
chunk and kept in a thread-safe cache (:mod:`coopsat.sim.program_cache`); the chunks, each
one jitted ``lax.scan`` over record intervals (:mod:`coopsat.sim.programs`), with a finiteness
check, progress and the caller's ``cancel`` hook between them; and the samples, assembled in
the interface layout. :func:`run_samples` is the same loop as one differentiable function.

The loop itself: a control period (:mod:`coopsat.sim.period`: sense, deliver, control,
actuate, integrate, account), a base tick (:mod:`coopsat.sim.tick`: RK4, piecewise between
pulse switches, native kernels where they apply), and the array layouts inside it
(:mod:`coopsat.sim.layout`). Design decisions and the measurements behind them:
docs/engine-notes.md.
"""

import functools
import math
import time
from dataclasses import dataclass, replace

from coopsat.core.errors import SimulationError
from coopsat.core import runtime
from coopsat.core.progress import progress_bar

import jax
import jax.numpy as jnp
import numpy as np

from coopsat.dynamics.plant import STATE_QUANTITIES
from coopsat.sim.batching import CARRY_AXES, bucket_runs, prepare_batch
from coopsat.sim.compiler_options import compile_program
from coopsat.sim.memory import runs_per_call
from coopsat.sim.program_cache import ProgramCache
from coopsat.sim.programs import _final_sample, _initial_carry, _run_chunk, _run_chunk_batched, _run_records
from coopsat.sim.tick import _quantities

__all__ = ["MAX_CHUNK", "NonFiniteStateError", "RunOutput", "bucket_runs", "output_shapes", "output_specs", "state_bytes",
           "run_output", "run_samples", "simulate", "with_native_decided"]


class NonFiniteStateError(SimulationError):
    """The state became NaN or infinite, or diverged beyond :data:`DIVERGED`, during a run."""


def output_specs(system):
    """How each recorded output appears in the dataset: the plant's, then every part's.

    Returns
    -------
    dict of str -> coopsat.core.parts.OutputSpec
    """
    from coopsat.sim.outputs import measured_output_spec, state_output_specs

    specs = state_output_specs(_quantities(system))
    # A sensor of a derived quantity describes its own reading (in its output_specs).
    specs.update({f"measured_{s.quantity}": measured_output_spec(s.quantity) for s in system.sensors if s.quantity in STATE_QUANTITIES})
    for p in (system.controller, system.network, *system.sensors, *system.actuators, *system.disturbances):
        specs.update(p.output_specs())
    return specs


def output_shapes(system):
    """Shape of each recorded output of one sample, interface layout, without compiling.

    Returns
    -------
    dict of str -> tuple
        ``(n_spacecraft, k…)`` per spacecraft output, ``(k…,)`` for the others.
    """
    shapes = jax.eval_shape(lambda s: _final_sample(s, _initial_carry(s)), system)
    specs = output_specs(system)
    return {k: (v.shape[-1], *v.shape[:-1]) if specs[k].per_spacecraft else v.shape for k, v in shapes.items()}


def state_bytes(system):
    """Bytes of the loop's state (plant, parts, the network's message history) of one run, from
    its shapes alone (nothing is allocated): what a run holds besides its record."""
    carry = jax.eval_shape(_initial_carry, system)
    return sum(math.prod(leaf.shape) * leaf.dtype.itemsize for leaf in jax.tree_util.tree_leaves(carry))


@dataclass
class RunOutput:
    """Recorded samples of one run (or a batch) as NumPy arrays.

    Attributes
    ----------
    t_s : ndarray (n_samples,)
        Sample times, s.
    samples : dict of ndarray
        Each ``([batch,] n_samples, n_spacecraft, ...)`` except reference quantities
        (``q_ref``: ``([batch,] n_samples, 4)``).
    compile_s, run_s : float
        Wall time spent compiling (first call of a structure in this process, cache misses
        included) and running, s.
    """

    t_s: np.ndarray
    samples: dict
    compile_s: float
    run_s: float


_COMPILED = ProgramCache(max_size=8)
"""Compiled programs of this process (initial carry, chunk: it takes the final sample too), by
system structure, leaf shapes, chunk and batching (:mod:`coopsat.sim.program_cache`: safe under
threads). Eight: a large program holds 100–300 MB of generated code, and a campaign, a sweep or
a pair runs one to a few structures; a structure evicted and run again is traced and loaded from
the persistent cache (about a second), not rebuilt from nothing."""

MAX_CHUNK = 4096
"""Most record intervals per compiled call: bounds the padding of the last chunk (memory)."""


DIVERGED = 1e100
"""Largest magnitude of a recorded state entry of a run still going, SI: no spacecraft's
state comes near it, and the analysis squares states (1e200 still fits a float64)."""


def _check_finite(samples, t_s, offset, batched, names=None):
    """Raise :class:`NonFiniteStateError` naming the first sample, spacecraft and field that
    is non-finite or diverged beyond :data:`DIVERGED`."""
    for name, (_, label) in STATE_QUANTITIES.items():
        if name not in samples:
            continue
        a = np.asarray(samples[name])
        bad = ~(np.abs(a) <= DIVERGED)  # NaN compares False: caught with the rest
        if bad.any():
            idx = np.argwhere(bad)[0]  # ([run,] record, component, spacecraft)
            k = idx[1] if batched else idx[0]
            sc = idx[-1]
            run = f"run {idx[0]}, " if batched else ""
            who = names[sc] if names is not None else f"spacecraft index {sc}"
            what = "became non-finite" if not np.isfinite(a[tuple(idx)]) else f"diverged past {DIVERGED:g} (on its way to non-finite)"
            raise NonFiniteStateError(
                f"state {what}: {run}{label} of {who} at t = {t_s[offset + k]:g} s "
                "(check gains, control period and step size)"
            )


def _chunk_size(n_records):
    """Record intervals per compiled call: a power of two near 1/50 of the run, at most
    :data:`MAX_CHUNK`.

    Powers of two, so that runs of different lengths share compiled programs (the padded
    record intervals of the last chunk are skipped, not simulated). About 1/50 of the run per
    call: a progress bar moves, and an interrupt (which Python handles between calls) ends the
    run promptly."""
    return min(2 ** math.ceil(math.log2(max(1, n_records / 50))), MAX_CHUNK)


def _program_key(system, chunk, batch):
    """Key of a run's programs: the system's structure and leaf shapes, the chunk, and for a
    batch its groups and devices."""
    groups, devices = (batch.groups, batch.devices) if batch is not None else (1, 1)
    leaves = tuple(jax.ShapeDtypeStruct(jnp.shape(v), jnp.result_type(v)) for v in jax.tree_util.tree_leaves(system))
    return (jax.tree_util.tree_structure(system), leaves, chunk, batch is not None, groups, devices)


def _fresh(jitted):
    """A new function object that calls ``jitted``'s Python function, for one compile.

    JAX keeps what it traced and lowered in caches keyed by the function: for a module-level
    function they live as long as the process, several hundred MB a large program (a test
    process that ran every bundled scenario reached 7.7 GB). A fresh function's entries go
    with it, so the bounded :data:`_COMPILED` is the only holder of a compiled program. The
    name is kept: the persistent compilation cache keys on the lowered module, named for it.
    """
    fn = getattr(jitted, "__wrapped__", jitted)
    return functools.wraps(fn)(lambda *args, **kwargs: fn(*args, **kwargs))


def _compile(system, n_records, chunk, batch):
    """The run's two programs, compiled: (initial carry, chunk); the chunks take the final
    sample too (:func:`~coopsat.sim.programs._scan_records`).

    The first sample is compiled too, not run op by op: op by op it dispatches (and, for each
    new batch size, compiles) hundreds of small programs (docs/engine-notes.md, "Compiled first
    and last samples")."""
    init = _fresh(_initial_carry)
    if batch is not None:
        init = jax.vmap(init, in_axes=(batch.axes,), out_axes=CARRY_AXES)
    carry = jax.eval_shape(init, system)
    init = compile_program(jax.jit(init).lower(system))
    lowered = (jax.jit(_fresh(_run_chunk_batched), static_argnames=("chunk", "groups", "devices")).lower(
                   system, carry, 0, n_records, chunk, batch.groups, batch.devices)
               if batch is not None else
               jax.jit(_fresh(_run_chunk), static_argnames=("chunk",)).lower(system, carry, 0, n_records, chunk))
    return init, compile_program(lowered)


def _programs(system, n_records, chunk, batch):
    """The run's programs from this process's cache, compiled on a miss.

    Compiled apart from running, so that the two can be reported separately; once per process
    for each structure, shape and chunk (then JAX's persistent cache serves new processes)."""
    return _COMPILED.get_or_make(_program_key(system, chunk, batch),
                                 lambda: _compile(system, n_records, chunk, batch))


def _progress_bar(n_records):
    """Progress over the record intervals (a bar on a terminal, a line per tenth in a log); it
    appears only once a run has taken 2 s."""
    return progress_bar(n_records, "simulating", "records", delay=2.0, leave=False)


def _run_chunks(programs, system, n_records, chunk, t_s, *, batched, names, cancel, bar):
    """Run the compiled chunks up to and with the final sample, checking each for non-finite
    states.

    Returns the chunks' samples as NumPy arrays, loop layout, cut to their ``n_records + 1``
    rows (the last chunk's padding rows dropped)."""
    init, run_chunk = programs
    axis = 1 if batched else 0
    chunks = []
    carry = init(system)
    for c in range(math.ceil((n_records + 1) / chunk)):
        carry, out = run_chunk(system, carry, c * chunk, n_records)
        rows = min(chunk, n_records + 1 - c * chunk)
        out = jax.tree_util.tree_map(lambda a: np.asarray(a)[(slice(None),) * axis + (slice(0, rows),)], out)
        _check_finite(out, t_s, c * chunk, batched, names)
        chunks.append(out)
        if cancel is not None:
            cancel()
        if bar is not None:
            bar.update(max(0, min(chunk, n_records - c * chunk)))
    return chunks


def _assemble(system, chunks, batch):
    """The samples in the interface layout: the chunks' rows (each chunk's samples, loop
    layout, cut to its rows) one after the other; per-spacecraft arrays back to (spacecraft,
    component); a batch's padding runs dropped."""
    axis = 0 if batch is None else 1
    samples = {k: np.concatenate([ch[k] for ch in chunks], axis=axis) for k in chunks[0]}
    specs = output_specs(system)
    samples = {k: np.moveaxis(v, -1, axis + 1) if specs[k].per_spacecraft else v for k, v in samples.items()}
    if batch is not None:
        samples = {k: v[:batch.n_runs] for k, v in samples.items()}  # without the padding runs
    return samples


def run_output(system, samples, last, t_s, *, compile_s, run_s, names=None):
    """The :class:`RunOutput` of one run stepped period by period outside the compiled chunks
    (software in the loop, :mod:`coopsat.sim.stepping`), checked and assembled as
    :func:`simulate` checks and assembles its own.

    Parameters
    ----------
    system : System
        The run's system (interface layout).
    samples : dict of str -> ndarray
        Every record interval's sample (:func:`~coopsat.sim.programs.sample`) stacked,
        ``(n_records, k…, n)`` per spacecraft (the loop's layout).
    last : dict of str -> ndarray
        The final sample (:func:`~coopsat.sim.programs.final_sample`), ``(k…, n)``.
    t_s : ndarray (n_records + 1,)
        Sample times, s.
    compile_s, run_s : float
        Wall time compiling and running, s.
    names : sequence of str, optional
        Spacecraft names, for error messages.

    Raises
    ------
    NonFiniteStateError
        As :func:`simulate_as_built`.
    """
    n_records = len(t_s) - 1
    _check_finite(samples, t_s, 0, False, names)
    _check_finite({k: np.expand_dims(v, 0) for k, v in last.items()}, t_s, n_records, False, names)
    rows = {k: np.concatenate([samples[k], np.expand_dims(last[k], 0)]) for k in last}
    return RunOutput(t_s=t_s, samples=_assemble(system, [rows], None), compile_s=compile_s, run_s=run_s)


def simulate(system, n_records, record_interval_s, *, native=None, **options):
    """Run the closed loop for ``n_records`` record intervals, with the native CPU kernels
    where ``system`` allows them and this process runs them.

    ``native``: True requires the kernels (:class:`~coopsat.sim.native.capability.
    NativeUnavailableError` where they cannot run), False keeps the whole loop in XLA, None
    follows ``COOPSAT_NATIVE`` (default ``auto``: the kernels where the process's check passes,
    else XLA with one :class:`~coopsat.sim.native.capability.NativeFallbackWarning`). The
    check is made once per process (:mod:`coopsat.sim.native.capability`), so every run of a
    process, alone or in a batch, takes the same path; until it is made, a call too small to pay
    for the probe (a run, or a batch counted whole) takes the XLA path. The other arguments are
    :func:`simulate_as_built`'s.
    """
    runs = int(np.shape(system.key)[0]) if options.get("batched") else 1
    return simulate_as_built(with_native_decided(system, n_records, native, runs), n_records, record_interval_s,
                             **options)


def with_native_decided(system, n_records, native=None, runs=1):
    """``system`` with ``structure.native`` False where this process will not run the native
    kernels for ``runs`` runs of ``n_records`` record intervals simulated together (``native``
    as :func:`simulate`).

    A batch is counted whole: a campaign's runs are each too small to pay for the probe, but
    its batches are not, and a worker left on the XLA path ran them 1.5× slower."""
    from coopsat.sim.native.capability import use_native

    s = system.structure
    sc_steps = runs * n_records * s.periods_per_record * s.ticks_per_period * s.substeps * s.n_spacecraft
    if s.native and not use_native(native, sc_steps):
        system = replace(system, structure=replace(system.structure, native=False))
    return system


def simulate_as_built(system, n_records, record_interval_s, *, batched=False, progress=False, chunk=None, names=None,
                      every_core=True, bucket=None, cancel=None):
    """Run the closed loop for ``n_records`` record intervals, with native kernels exactly as
    ``system.structure.native`` says (no process check: :func:`simulate` makes it; the native
    kernels' probe runs this).

    Parameters
    ----------
    system : System
        Single run, or a batch from :func:`~coopsat.sim.system.stack_systems` with
        ``batched=True``.
    n_records : int
        Record intervals; the run ends at ``n_records · record_interval_s`` and
        ``n_records + 1`` samples are returned (both ends included).
    record_interval_s : float
        Time between samples, s (a whole number of control periods).
    batched : bool
        ``vmap`` over the leading axis of every data leaf of ``system``; a batch larger than the
        device holds (:func:`coopsat.sim.memory.runs_per_call`) runs in parts of as many runs.
    progress : bool
        Show progress on stderr: a bar on a terminal, a line per tenth otherwise
        (:func:`coopsat.core.progress.progress_bar`); it appears only once a run has taken 2 s.
    names : sequence of str, optional
        Spacecraft names, for error messages.
    every_core : bool
        Share a batch's groups among every device (one per CPU core, ``coopsat.core.runtime``). False
        runs it on one device, so that its results do not depend on the machine's core count
        (grouping can change a result in the last bit).
    chunk : int, optional
        Record intervals per compiled call. Default: a power of two (so that runs of similar
        length reuse the compiled program) near 1/50 of the run, at most :data:`MAX_CHUNK`.
    bucket : int, optional
        Pad a batch to :func:`bucket_runs` (``n_runs``, ``bucket``) runs (copies of its last
        run, dropped from the results), so that batches of nearby sizes share one compiled
        program (a campaign: its batch size).
    cancel : callable, optional
        Called with no argument at the run's safe points (after compiling, after each compiled
        chunk); it stops the run by raising. The command line passes
        :func:`coopsat.workflows.interrupt.check`, so that a signal ends a run promptly.

    Returns
    -------
    RunOutput

    Raises
    ------
    NonFiniteStateError
        When the state becomes NaN or infinite or diverges beyond :data:`DIVERGED`; the run
        stops at the chunk where it happened.

    """
    runtime.enable()
    if chunk is None:
        chunk = _chunk_size(n_records)
    if batched and np.shape(system.key)[0] > (per_call := runs_per_call(system, chunk)):
        return _simulate_in_parts(system, n_records, record_interval_s, per_call, progress=progress, chunk=chunk,
                                  names=names, every_core=every_core, cancel=cancel)
    batch = prepare_batch(system, every_core, bucket) if batched else None
    if batch is not None:
        system = batch.system
    t_s = np.arange(n_records + 1) * record_interval_s

    t0 = time.perf_counter()
    programs = _programs(system, n_records, chunk, batch)
    compile_s = time.perf_counter() - t0
    if cancel is not None:
        cancel()

    bar = _progress_bar(n_records) if progress else None
    t0 = time.perf_counter()
    try:
        chunks = _run_chunks(programs, system, n_records, chunk, t_s, batched=batched, names=names,
                             cancel=cancel, bar=bar)
    finally:
        if bar is not None:
            bar.close()
    run_s = time.perf_counter() - t0
    samples = _assemble(system, chunks, batch)
    return RunOutput(t_s=t_s, samples=samples, compile_s=compile_s, run_s=run_s)


def _simulate_in_parts(system, n_records, record_interval_s, per_call, **options):
    """A batch larger than the device holds (:func:`~coopsat.sim.memory.runs_per_call`) run
    ``per_call`` runs at a time (the last part padded to the same size, so one program serves
    every part), as one :class:`RunOutput`."""
    n_runs = int(np.shape(system.key)[0])
    parts = [
        simulate_as_built(jax.tree_util.tree_map(lambda leaf, a=a: leaf[a:a + per_call], system), n_records,
                          record_interval_s, batched=True, bucket=per_call, **options)
        for a in range(0, n_runs, per_call)
    ]
    return RunOutput(t_s=parts[0].t_s, samples={k: np.concatenate([p.samples[k] for p in parts]) for k in parts[0].samples},
                     compile_s=sum(p.compile_s for p in parts), run_s=sum(p.run_s for p in parts))


def run_samples(system, n_records):
    """Every sample of one run as a pure function of ``system``: differentiable end to end.

    The same closed loop as :func:`simulate` (one ``lax.scan`` over all ``n_records`` record
    intervals, then the final sample), without chunks, progress or NumPy conversion, so that
    ``jax.grad``/``jax.jvp`` of a metric of the samples with respect to any data leaf of
    ``system`` (a gain, a weight) goes through the whole run. Used by ``coopsat tune``.

    Parameters
    ----------
    system : System
        One run (not a batch; ``jax.vmap`` this function to batch).
    n_records : int
        Record intervals (static).

    Returns
    -------
    dict of str -> jax.Array
        Each ``(n_records + 1, n_spacecraft, k…)`` for per-spacecraft outputs (interface
        layout, as :class:`RunOutput` samples), ``(n_records + 1, k…)`` for the others.
    """
    carry, out = _run_records(system, _initial_carry(system), n_records)
    last = _final_sample(system, carry)
    specs = output_specs(system)
    samples = {k: jnp.concatenate([out[k], last[k][None]], axis=0) for k in last}
    return {k: jnp.moveaxis(v, -1, 1) if specs[k].per_spacecraft else v for k, v in samples.items()}
