"""Sun sensor and magnetometer: the truth against the Sun and the tilted dipole written out
here (body axes by SciPy), and the noise against its stated statistics over many draws."""

import jax
import jax.numpy as jnp
import numpy as np

from coopsat.astro.earth_orientation import z_rotation
from coopsat.astro.earth import OMEGA_EARTH_RAD_S, WGS84_A_M, gmst_rad, julian_date_utc
from coopsat.astro.sun import sun_position_eci_m
from coopsat.dynamics.plant import PlantState
from coopsat.sensors.environment_sensors import Magnetometer, SunSensor
from earth_reference import hand_dipole_eci, random_quats, to_body

JD0 = julian_date_utc("2018-07-12T03:00:00")
GMST0 = gmst_rad(JD0)
EARTH = z_rotation(GMST0, 86400.0)  # the papers' Earth: θ = GMST0 + ω_E t
N_DRAWS = 40_000  # 4 keys × 10 000 spacecraft (each its own stream)


def _state(q, r):
    q, r = np.atleast_2d(q), np.atleast_2d(r)
    zeros = jnp.zeros((3, q.shape[0]))
    return PlantState(jnp.asarray(q.T), zeros, zeros, jnp.asarray(r.T), zeros, zeros)


def _draws(part, truth_value, keys=4):
    """``part.measure`` of one truth column repeated, over several keys: (k, keys × columns)."""
    out = [np.asarray(part.measure(truth_value, None, (), jax.random.PRNGKey(seed))[0]) for seed in range(keys)]
    assert not np.array_equal(out[0], out[1])  # another key, other noise
    return np.concatenate(out, axis=1)


# --- sun sensor ------------------------------------------------------------------------------

T_S = 7200.0
RADIUS = WGS84_A_M + 500e3


def _sun_positions():
    r_sun = np.asarray(sun_position_eci_m(JD0 + T_S / 86400.0))
    s_hat = r_sun / np.linalg.norm(r_sun)
    side = np.cross(s_hat, [0.0, 0.0, 1.0])
    side /= np.linalg.norm(side)
    # Day side; beside the Earth (lit); behind the Earth (shadow).
    return r_sun, np.array([RADIUS * s_hat, RADIUS * side, -RADIUS * s_hat])


def test_sun_sensor_truth_is_the_body_direction_to_the_sun_from_the_spacecraft():
    part = SunSensor(jnp.full(3, 1e-3), jnp.asarray(JD0))
    r_sun, r = _sun_positions()
    q = random_quats(3, 21)
    truth = np.asarray(part.truth(None, _state(q, r), T_S))
    assert truth.shape == (4, 3)
    np.testing.assert_array_equal(truth[3], [1.0, 1.0, 0.0])
    np.testing.assert_array_equal(truth[:3, 2], 0.0)
    for i in (0, 1):
        to_sun = r_sun - r[i]
        expected = to_body(q[i], to_sun / np.linalg.norm(to_sun))
        np.testing.assert_allclose(truth[:3, i], expected, rtol=0, atol=1e-14)
    # The parallax |r|/AU ≈ 4.6e-5 rad is in: beside the Earth the geocentric direction is off by it.
    geocentric = to_body(q[1], r_sun / np.linalg.norm(r_sun))
    assert np.linalg.norm(truth[:3, 1] - geocentric) > 4e-5


def test_sun_sensor_without_noise_reads_the_truth_and_nothing_in_shadow():
    part = SunSensor(jnp.zeros(3), jnp.asarray(JD0))
    _, r = _sun_positions()
    x = _state(random_quats(3, 22), r)
    truth = part.truth(None, x, T_S)
    measured = np.asarray(part.measure(truth, x, (), jax.random.PRNGKey(0))[0])
    assert np.isfinite(measured).all()  # in shadow too, where the vector is zero
    np.testing.assert_allclose(measured, np.asarray(truth), rtol=0, atol=1e-15)
    np.testing.assert_array_equal(measured[:, 2], 0.0)


def test_sun_sensor_noise_in_shadow_stays_zero_and_invalid():
    part = SunSensor(jnp.full(3, 1e-2), jnp.asarray(JD0))
    _, r = _sun_positions()
    x = _state(random_quats(3, 23), r)
    measured = np.asarray(part.measure(part.truth(None, x, T_S), x, (), jax.random.PRNGKey(1))[0])
    np.testing.assert_array_equal(measured[:, 2], 0.0)
    np.testing.assert_array_equal(measured[3], [1.0, 1.0, 0.0])
    np.testing.assert_allclose(np.linalg.norm(measured[:3, :2], axis=0), 1.0, rtol=1e-15)


def test_sun_sensor_angle_error_has_the_stated_sigma_per_transverse_axis():
    """Sun along body +z: the error is σ_x ν_x, σ_y ν_y across the line of sight, and σ_z along
    it does not turn the direction (to first order)."""
    sigma = np.array([1e-3, 2e-3, 3e-3])
    part = SunSensor(jnp.asarray(sigma), jnp.asarray(JD0))
    truth = jnp.asarray(np.tile([[0.0], [0.0], [1.0], [1.0]], (1, N_DRAWS // 4)))
    m = _draws(part, truth)
    np.testing.assert_array_equal(m[3], 1.0)
    np.testing.assert_allclose(np.linalg.norm(m[:3], axis=0), 1.0, rtol=1e-15)
    n = m.shape[1]
    # Sample std of N normal draws: relative standard error 1/√(2N); allow 5 of them.
    np.testing.assert_allclose(m[:2].std(axis=1), sigma[:2], rtol=5 / np.sqrt(2 * n))
    assert np.all(np.abs(m[:2].mean(axis=1)) < 5 * sigma[:2] / np.sqrt(n))
    angle = np.arctan2(np.linalg.norm(m[:2], axis=0), m[2])
    # angle² = σx² νx² + σy² νy²: mean σx² + σy², standard deviation √(2σx⁴ + 2σy⁴).
    mean_square = sigma[0] ** 2 + sigma[1] ** 2
    spread = np.sqrt(2 * sigma[0] ** 4 + 2 * sigma[1] ** 4)
    assert abs(np.mean(angle**2) - mean_square) < 5 * spread / np.sqrt(n)


def test_sun_sensor_isotropic_error_is_two_sigma_squared_in_any_direction():
    sigma = 2e-3
    part = SunSensor(jnp.full(3, sigma), jnp.asarray(JD0))
    s = np.array([0.48, -0.6, 0.64])
    truth = jnp.asarray(np.tile(np.append(s, 1.0)[:, None], (1, N_DRAWS // 4)))
    m = _draws(part, truth)
    angle = np.arctan2(np.linalg.norm(np.cross(m[:3].T, s), axis=1), m[:3].T @ s)
    n = m.shape[1]
    # angle² ≈ σ² χ²₂: mean 2σ², standard deviation 2σ².
    assert abs(np.mean(angle**2) - 2 * sigma**2) < 5 * 2 * sigma**2 / np.sqrt(n)
    # The error is across the line of sight only: the mean direction is the truth.
    mean = m[:3].mean(axis=1)
    assert np.linalg.norm(mean / np.linalg.norm(mean) - s) < 5 * sigma / np.sqrt(n)


# --- magnetometer ------------------------------------------------------------------------------


def test_magnetometer_truth_is_the_body_field_of_the_turning_earth():
    part = Magnetometer(jnp.full(3, 3e-10), jnp.zeros(3), EARTH)
    q = random_quats(2, 24)
    r = np.array([[RADIUS, 0.0, 0.0], [2.0e6, -4.0e6, 5.3e6]])
    t = 900.0
    truth = np.asarray(part.truth(None, _state(q, r), t))
    assert truth.shape == (3, 2)
    for i in range(2):
        expected = to_body(q[i], hand_dipole_eci(r[i], GMST0 + OMEGA_EARTH_RAD_S * t))
        np.testing.assert_allclose(truth[:, i], expected, rtol=1e-12)
        assert 1e-5 < np.linalg.norm(expected) < 6e-5


def test_magnetometer_noise_and_bias_have_the_stated_statistics():
    sigma = np.array([1e-9, 2e-9, 5e-10])
    bias = np.array([1e-7, -2e-7, 3e-8])
    part = Magnetometer(jnp.asarray(sigma), jnp.asarray(bias), EARTH)
    b = np.array([2.1e-5, -0.7e-5, 3.3e-5])
    m = _draws(part, jnp.asarray(np.tile(b[:, None], (1, N_DRAWS // 4))))
    n = m.shape[1]
    error = m - b[:, None]
    np.testing.assert_allclose(error.std(axis=1), sigma, rtol=5 / np.sqrt(2 * n))
    assert np.all(np.abs(error.mean(axis=1) - bias) < 5 * sigma / np.sqrt(n))
    assert abs(np.corrcoef(error)[0, 1]) < 5 / np.sqrt(n)
    # Without noise: the truth plus the bias, exactly.
    quiet = Magnetometer(jnp.zeros(3), jnp.asarray(bias), EARTH)
    got = np.asarray(quiet.measure(jnp.asarray(b[:, None]), None, (), jax.random.PRNGKey(5))[0])
    np.testing.assert_array_equal(got[:, 0], b + bias)


def test_sensors_trace_under_jit():
    sun = SunSensor(jnp.full(3, 1e-3), jnp.asarray(JD0))
    mag = Magnetometer(jnp.full(3, 3e-10), jnp.zeros(3), EARTH)
    _, r = _sun_positions()
    x = _state(random_quats(3, 25), r)
    key = jax.random.PRNGKey(7)
    for part in (sun, mag):
        truth = part.truth(None, x, T_S)
        eager = np.asarray(part.measure(truth, x, (), key)[0])
        jitted = np.asarray(jax.jit(lambda x, key, part=part: part.measure(part.truth(None, x, T_S), x, (), key)[0])(x, key))
        np.testing.assert_allclose(jitted, eager, rtol=1e-9, atol=1e-15 * np.abs(eager).max())
