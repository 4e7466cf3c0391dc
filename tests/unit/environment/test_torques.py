"""Disturbance plug-ins: the random torque's statistics, its effect on the body, replay by seed."""

import jax
import numpy as np

from coopsat.environment.torques import RandomTorque
from coopsat.workflows.pipeline import prepare, simulate_built
from coopsat.scenarios.load import load_scenario


def test_random_torque_has_the_stated_standard_deviation_per_axis():
    sigma = np.array([[1e-6], [2e-5], [3e-4]])
    part = RandomTorque(jax.numpy.asarray(sigma))
    n = 100_000
    draws = np.asarray(part.update(0.0, None, part.init(n), jax.random.PRNGKey(3)))
    # Sample std of N normal draws: relative standard error 1/sqrt(2N); allow 5 of them.
    np.testing.assert_allclose(draws.std(axis=1), sigma[:, 0], rtol=5 / np.sqrt(2 * n))
    assert np.all(np.abs(draws.mean(axis=1)) < 5 * sigma[:, 0] / np.sqrt(n))
    # Axes and spacecraft are uncorrelated.
    assert abs(np.corrcoef(draws)[0, 1]) < 5 / np.sqrt(n)
    # Spacecraft i's draw does not depend on the formation size.
    small = np.asarray(part.update(0.0, None, part.init(3), jax.random.PRNGKey(3)))
    np.testing.assert_array_equal(small, draws[:, :3])


def _run(seed, *extra):
    overrides = [
        f"seed={seed}", "sim.t_final_s=2.0", "sim.dt_s=0.01", "sim.record_interval_s=0.01",
        "spacecraft.0.inertia_kgm2=[2.0, 2.0, 2.0]", "spacecraft.0.omega_b_rad_s=[0.0, 0.0, 0.0]",
        'disturbances=[{kind = "random-torque", sigma_nm = [1e-3, 2e-3, 3e-3]}]', *extra,
    ]
    ds, _ = simulate_built(prepare(load_scenario("rigid-body-free", overrides)))
    return ds


def test_the_body_feels_the_recorded_torque_and_the_seed_replays():
    ds = _run(5)
    torque = ds.random_torque.values[:, 0]  # (T, 3), constant over each 0.01 s period
    # A spherical body has no gyroscopic term: ω(t_k) = Σ_{m<k} τ_m T / J exactly (to rounding).
    expected = np.concatenate([np.zeros((1, 3)), np.cumsum(torque[:-1] * 0.01 / 2.0, axis=0)])
    np.testing.assert_allclose(ds.omega.values[:, 0], expected, rtol=0, atol=1e-15)
    assert np.abs(torque).max() > 1e-4
    again = _run(5)
    for name in ds.data_vars:
        np.testing.assert_array_equal(ds[name].values, again[name].values)
    other = _run(6)
    assert not np.allclose(other.random_torque.values, torque)
