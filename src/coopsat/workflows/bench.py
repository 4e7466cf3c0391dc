"""Engine throughput benchmark: spacecraft-steps per second, compile time apart.

Three cases per formation size N: a torque-free rigid body (N independent bodies); law (3)
on an undirected ring with the controller evaluated every tick (the costliest rate) and an
ideal torque actuator; and the same over a network that delays every message by 2 s (a ring
buffer of 201 periods of outboxes). Then batches of runs of N = 5 (a Monte Carlo campaign's
shape). One "spacecraft-step" is one spacecraft advanced by one RK4 tick. When JAX runs on a
GPU, a GPU section follows (:func:`gpu_section`): formations of 1e5 and 1e6 spacecraft and
batches of 1e4 and 1e5 runs.

Each consensus row is also quoted as a fraction of the *ceiling*: the same arithmetic (law (3)
on the ring, clip, RK4, renormalisation) as one fused, vectorised numba loop over
component-major rows (``benchmarks/ceiling.py``; needs numba and a source checkout), measured
in the same sitting on one thread and on two. A batch of B runs of N = 5 is compared with the
ceiling's ring of B·5 spacecraft (the same work per spacecraft-step: two neighbours each).

Orbit rows: N free spacecraft spread along one 500 km orbit, 10 s ticks, under J2 only and
under every perturbation of a real low orbit (EGM2008 to degree and order 20, Harris–Priester
drag, the Sun and the Moon, radiation pressure with the conical shadow), each quoted as a
multiple of the J2 row's time per tick (docs/leo.md).

Every row prints the time to build what it runs (the system, or a batch: one system with each
run's random draws stacked, :func:`~coopsat.sim.synthetic.bench_batch`; an
orbit row's scenario built and designed) beside the compile and the run.
Prints numbers; asserts nothing (timings are not tests).
"""

import time

import numpy as np


STATE_SHARE = 0.25
"""A row runs only when its loop state fits in this share of the machine's memory: the scan
keeps the state twice (carry in and out) beside the record and XLA's temporaries."""


def too_big(n, controller, delayed=False):
    """Why a single run of this row would not fit in memory (one line), or None.

    The delayed network holds every message for 201 periods: at N = 1e6 that is 11.5 GB of
    state, which a 24 GB machine cannot hold twice."""
    import os

    from coopsat.sim.engine import state_bytes
    from coopsat.sim.synthetic import DELAY_PERIODS, bench_system

    need = state_bytes(bench_system(n, controller, record_ticks=1, delayed=delayed))
    memory = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    if need <= STATE_SHARE * memory:
        return None
    held = f" (the delay line holds {DELAY_PERIODS + 1} periods of every message)" if delayed else ""
    return (f"skipped: its loop state is {need / 1e9:.1f} GB{held}, more than {STATE_SHARE:.0%} of this machine's "
            f"{memory / 1e9:.0f} GB")


def measure(n, controller, ticks, batch=None, repeats=3, delayed=False, native=True):
    """(build s, compile s, best run s, spacecraft-steps/s) for ``ticks`` ticks of ``n``
    spacecraft; build: making the system (and stacking a batch) in Python, before any compile.

    With ``batch``, that many independent runs (different random formations) go through one
    ``vmap``-ed loop, as a Monte Carlo campaign does; the rate counts every run's spacecraft.
    """
    from coopsat.sim.engine import simulate
    from coopsat.sim.synthetic import bench_batch, bench_system

    record_ticks = min(1000, ticks)
    n_records = ticks // record_ticks
    start = time.perf_counter()
    if batch is None:
        system = bench_system(n, controller, record_ticks=record_ticks, delayed=delayed, native=native)
    else:
        system = bench_batch(n, controller, batch, record_ticks=record_ticks, delayed=delayed, native=native)
    build_s = time.perf_counter() - start
    kwargs = {"batched": batch is not None}
    first = simulate(system, n_records, record_ticks * 0.01, **kwargs)
    best = min(simulate(system, n_records, record_ticks * 0.01, **kwargs).run_s for _ in range(repeats))
    return build_s, first.compile_s, best, (batch or 1) * n * n_records * record_ticks / best


PERTURBATIONS = [
    {"kind": "gravity-field", "degree": 20},
    {"kind": "drag", "area_m2": 0.1, "density": "harris-priester", "f107": 150.0},
    {"kind": "third-body"},
    {"kind": "solar-radiation-pressure", "area_m2": 0.1, "reflectivity": 0.3},
]
"""The orbit rows' "all perturbations" case."""


def orbit_scenario(n, perturbed, ticks, dt_s=10.0):
    """N free spacecraft evenly spread in mean anomaly on one 500 km orbit (a Scenario)."""
    from coopsat.scenarios.document import Scenario

    spacecraft = [
        {"elements": {"a_m": 6878137.0, "e": 0.001, "i_deg": 51.6, "raan_deg": 0.0, "argp_deg": 0.0,
                      "mean_anomaly_deg": 360.0 * k / n}}
        for k in range(n)
    ]
    return Scenario.from_dict({
        "name": f"bench-orbit-{n}",
        "sim": {"t_final_s": dt_s * ticks, "dt_s": dt_s, "record_interval_s": dt_s * ticks},
        "orbit": {"gravity": "two-body" if perturbed else "j2", "epoch_utc": "2024-03-20T00:00:00"},
        "spacecraft_defaults": {"inertia_kgm2": [1.0, 1.0, 1.0], "mass_kg": 10.0},
        "spacecraft": spacecraft,
        "disturbances": PERTURBATIONS if perturbed else [],
    })


def measure_orbit(n, perturbed, ticks, repeats=3):
    """(build s, compile s, best run s) for ``ticks`` ticks of :func:`orbit_scenario` (build:
    the scenario's validation and build, design included)."""
    import warnings

    from coopsat.scenarios.build import DesignWarning, build
    from coopsat.sim.engine import simulate

    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DesignWarning)  # the free orbits' design checks say nothing here
        built = build(orbit_scenario(n, perturbed, ticks).model)
    build_s = time.perf_counter() - start
    first = simulate(built.system, built.n_records, built.record_interval_s)
    best = min(simulate(built.system, built.n_records, built.record_interval_s).run_s for _ in range(repeats))
    return build_s, first.compile_s, best


def load_ceiling():
    """The ceiling kernel module (``benchmarks/ceiling.py`` of a source checkout), or the
    reason it cannot be loaded."""
    import importlib.util
    import sys
    from pathlib import Path

    path = Path(__file__).resolve().parents[3] / "benchmarks" / "ceiling.py"  # src/coopsat/workflows/
    if not path.is_file():
        return None, "no benchmarks/ceiling.py beside this installation (run from a source checkout)"
    spec = importlib.util.spec_from_file_location("coopsat_ceiling", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # numba's on-disk cache finds its functions by module name
    try:
        spec.loader.exec_module(module)
    except ImportError as err:
        return None, str(err)
    return module, None


GPU_SIZES = (100_000, 1_000_000)
"""Formation sizes of the GPU section's single runs (:func:`gpu_section`)."""

GPU_BATCHES = (10_000, 100_000)
"""Runs of N = 5 in the GPU section's batches."""


def gpu_section(row, device):
    """The rows a GPU is for, printed after the others when JAX runs on one: consensus and
    torque-free formations of :data:`GPU_SIZES` and consensus batches of :data:`GPU_BATCHES`
    runs of N = 5 (a batch larger than the device holds runs in parts, :mod:`coopsat.sim.memory`).
    ``row(label, n, controller, batch)`` prints one row (:func:`run_benchmarks`'s)."""
    from coopsat.sim.memory import device_memory_bytes

    print(f"GPU section: {getattr(device, 'device_kind', device.platform)}, {device_memory_bytes(device) / 2**30:.0f} GiB",
          flush=True)
    for n in GPU_SIZES:
        for controller, label in (("none", "torque-free"), ("consensus-sync", "consensus")):
            row(label, n, controller, None)
    for b in GPU_BATCHES:
        row("consensus", 5, "consensus-sync", b)


def run_benchmarks(sizes=(1, 5, 1000, 10000), steps=None, batch=1000, native=True, orbit_sizes=(100, 1000)):
    """Print a throughput table for each case and size, then the batched (campaign) lines, with
    each consensus row's fraction of the ceiling measured alongside. ``native=False``: the
    whole loop in XLA (no native kernel), for before/after comparisons in one sitting.
    ``orbit_sizes``: formation sizes of the orbit rows (empty: none)."""
    from coopsat.core import runtime

    runtime.enable()  # float64 before the cases' arrays are made (they are built here, not by a scenario)
    import jax

    from coopsat.sim.native.capability import use_native
    from coopsat.sim.native.pool import PARALLEL_MIN

    if native:
        use_native()  # decided before the first row: the small rows would otherwise take XLA until a large one probes
    platform = jax.devices()[0].platform
    # The ceiling is a numba loop on this machine's cores: no bound for a GPU's rows, and at the
    # GPU section's sizes it would take minutes of the CPU per row.
    ceiling, why = load_ceiling() if platform == "cpu" else (None, f"the ceiling is a CPU loop; JAX runs on {platform}")
    print(f"coopsat engine benchmark: JAX {jax.__version__} on {platform}, float64, RK4, "
          f"{'native kernels where they apply' if native else 'XLA only (--no-native)'}")
    if ceiling is None:
        print(f"(no ceiling column: {why})")
    print(f"{'case':<14}{'N':>8}{'batch':>7}{'ticks':>10}{'build s':>9}{'compile s':>11}{'run s':>9}{'M sc-steps/s':>14}"
          f"{'ceiling 1T':>12}{'2T':>8}{'of ceiling':>11}")
    cores = len(jax.devices()) if platform == "cpu" else 1

    def row(label, n, controller, b, delayed=False):
        total = n * (b or 1)
        ticks = steps or int(np.clip(2e7 / total, 2_000, 1_000_000) // 1000 * 1000)
        skip = None if b else too_big(n, controller, delayed)
        if skip:
            print(f"{label:<14}{n:>8}{1:>7}{ticks:>10}   {skip}", flush=True)
            return
        build_s, compile_s, run_s, rate = measure(n, controller, ticks, batch=b, delayed=delayed, native=native)
        line = f"{label:<14}{n:>8}{b or 1:>7}{ticks:>10}{build_s:>9.2f}{compile_s:>11.2f}{run_s:>9.3f}{rate / 1e6:>14.2f}"
        if ceiling is not None and controller != "none" and not delayed and total > 1:
            one = ceiling.ceiling_rate(total, ticks, threads=1)[1]
            two = ceiling.ceiling_rate(total, ticks, threads=2)[1]
            # On as many cores as the row used: every CPU device for a batch; for a single run
            # one, or all when its native kernels split it over XLA's thread pool.
            both = cores > 1 and (b or (native and total >= PARALLEL_MIN))
            line += f"{one / 1e6:>12.2f}{two / 1e6:>8.2f}{rate / (two if both else one):>11.2f}"
        print(line, flush=True)

    if ceiling is not None:
        print(f"(of ceiling: on as many cores as the row used: {cores} for a batch and, with native kernels, for a "
              f"single run of {PARALLEL_MIN} spacecraft or more; else one)")
    for controller, label in (("none", "torque-free"), ("consensus-sync", "consensus")):
        for n in sizes:
            row(label, n, controller, None)
    for n in sizes:
        if n > 1:
            row("cons. 2s delay", n, "consensus-sync", None, delayed=True)
    if batch:
        for controller, label in (("none", "torque-free"), ("consensus-sync", "consensus")):
            row(label, 5, controller, batch)
    if platform != "cpu":
        gpu_section(row, jax.devices()[0])
    for n in orbit_sizes:
        ticks = steps or 200
        times = {}
        for perturbed, label in ((False, "orbit J2"), (True, "orbit all")):
            build_s, compile_s, run_s = measure_orbit(n, perturbed, ticks)
            times[perturbed] = run_s
            line = (f"{label:<14}{n:>8}{1:>7}{ticks:>10}{build_s:>9.2f}{compile_s:>11.2f}{run_s:>9.3f}"
                    f"{n * ticks / run_s / 1e6:>14.2f}")
            if perturbed:
                line += f"   {run_s / times[False]:.1f}× the J2 tick"
            print(line, flush=True)
