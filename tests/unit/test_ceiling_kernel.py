"""The ceiling kernel of ``coopsat bench`` (benchmarks/ceiling.py) runs the same closed loop as
the engine's "consensus" case: law (3) on the ring, the ideal actuator's clip, RK4 and the
renormalisation, to float64 rounding."""

import dataclasses
import importlib.util
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("numba")

from coopsat.sim.synthetic import bench_system  # noqa: E402
from coopsat.sim.engine import simulate  # noqa: E402

TICKS = 300
RECORD_TICKS = 100
TOL = 1e-12
"""Engine and kernel do the same float64 arithmetic, but XLA fuses some products and sums into
FMAs and computes the renormalisation's rsqrt by a hardware estimate and two Newton steps: ulp
differences, a few 1e-15 after 300 ticks."""


def _load_ceiling():
    path = Path(__file__).resolve().parents[2] / "benchmarks" / "ceiling.py"
    spec = importlib.util.spec_from_file_location("coopsat_ceiling", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


ceiling = _load_ceiling()


def _engine_and_ceiling(n, threads=1, omega_scale=None):
    """Final (q, ω) of the engine and of the ceiling after TICKS ticks, and the engine's run."""
    system = bench_system(n, "consensus-sync", record_ticks=RECORD_TICKS)
    if omega_scale is not None:
        x0 = system.x0._replace(omega_b=system.x0.omega_b * omega_scale)
        system = dataclasses.replace(system, x0=x0)
    out = simulate(system, TICKS // RECORD_TICKS, RECORD_TICKS * 0.01)
    q, w = ceiling.ceiling_run(
        np.asarray(system.x0.q_bi), np.asarray(system.x0.omega_b), np.asarray(system.plant.inertia_kgm2), TICKS,
        threads=threads,
    )
    return (out.samples["q"][-1], out.samples["omega"][-1]), (q, w), out


def _max_diff(ref, got):
    return max(float(np.abs(a - b).max()) for a, b in zip(ref, got))


@pytest.mark.parametrize("n", [1, 2, 5, 37])
def test_matches_engine(n):
    ref, got, _ = _engine_and_ceiling(n)
    assert got[0].shape == (n, 4) and got[1].shape == (n, 3)
    assert _max_diff(ref, got) < TOL
    q0, omega0, _ = _interface_state(n)
    assert _max_diff((q0, omega0), got) > 1e-3  # the formation moved


def test_matches_engine_with_saturation():
    """Rates 30× the benchmark's (about 3 rad/s): the commands exceed the 0.05 N·m limit, so the
    clip decides the torque for most of the run."""
    ref, got, out = _engine_and_ceiling(5, omega_scale=30.0)
    command = out.samples["torque_command"]
    assert np.mean(np.abs(command) > 0.05) > 0.5
    assert _max_diff(ref, got) < TOL


def test_parallel_matches_engine_and_serial():
    """Two threads (blocks over the spacecraft axis) and one thread: the same numbers."""
    if ceiling.numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("one CPU: no second thread")
    n = ceiling.PARALLEL_MIN + 52  # several blocks, not a multiple of the block
    ref, got2, _ = _engine_and_ceiling(n, threads=2)
    got1 = ceiling.ceiling_run(*_interface_state(n), TICKS, threads=1)
    assert _max_diff(ref, got2) < TOL
    assert all(np.array_equal(a, b) for a, b in zip(got1, got2))


def _interface_state(n):
    q, principal, omega = ceiling.bench_formation(n)
    return q, omega, principal


def test_kernels_agree_bitwise():
    """The scalar kernel of small rings and the vectorised one (with its wrap-around ends done
    apart) compute the same numbers, operation for operation."""
    q, w, inertia, inv = ceiling._component_major(*_interface_state(37))
    args = (q, w, inertia, inv, 50, 0.01, 1.0, 2.0, 0.05)
    small = ceiling._run_small(*args)
    vector = ceiling._run_serial(*args)
    assert all(np.array_equal(a, b) for a, b in zip(small, vector))


def test_bench_formation_is_bench_systems():
    """ceiling_rate times the very formation bench_system builds."""
    system = bench_system(7, "consensus-sync")
    q, principal, omega = ceiling.bench_formation(7)
    assert np.array_equal(q, np.asarray(system.x0.q_bi))
    assert np.array_equal(omega, np.asarray(system.x0.omega_b))
    assert np.array_equal(principal, np.asarray(system.plant.inertia_kgm2))


def test_rate_reports_best_time():
    best, rate = ceiling.ceiling_rate(5, 100, repeats=1)
    assert best > 0 and rate == pytest.approx(5 * 100 / best)
