"""Statistical and reproducibility tests of coopsat.sensors.noise.

Bounds come from the sampling distribution of N independent draws: the sample mean of N(0, σ²)
has standard error σ/√N, the sample standard deviation a relative standard error ≈ 1/√(2N),
and the sample correlation of two independent streams a standard error ≈ 1/√N. Every statistical
assertion allows 5 of those standard errors (a false failure about once in 1.7 million).
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from coopsat.core.parts import per_spacecraft_normal
from coopsat.geometry.quaternion import quat_error, quat_vector
from coopsat.sensors.noise import (
    ARCSEC_RAD,
    gyro_bias_step,
    gyro_measure,
    star_tracker_measure,
    white_noise,
)

N = 100_000
KEY = jax.random.key(20240611)


def _assert_mean(x, sigma, axis=None):
    se = np.asarray(sigma) / np.sqrt(np.shape(x)[-1] if axis == 1 else np.size(x))
    assert np.all(np.abs(np.mean(x, axis=axis)) < 5.0 * se)


def _assert_std(x, sigma, axis=None):
    n = np.shape(x)[-1] if axis == 1 else np.size(x)
    rel = np.std(x, axis=axis, ddof=1) / np.asarray(sigma) - 1.0
    assert np.all(np.abs(rel) < 5.0 / np.sqrt(2.0 * n)), rel


def _random_quats(n, seed=0):
    q = np.random.default_rng(seed).normal(size=(4, n))
    return q / np.linalg.norm(q, axis=0)


# --- per_spacecraft_normal -------------------------------------------------------------------


def test_per_spacecraft_normal_is_standard_normal():
    x = np.asarray(per_spacecraft_normal(KEY, 2, N // 2))
    assert x.shape == (2, N // 2) and x.dtype == np.float64
    _assert_mean(x, 1.0)
    _assert_std(x, 1.0)


def test_spacecraft_stream_does_not_depend_on_formation_size():
    big = np.asarray(per_spacecraft_normal(KEY, 3, 50))
    for i in (0, 1, 6, 49):
        np.testing.assert_array_equal(np.asarray(per_spacecraft_normal(KEY, 3, i + 1))[:, i], big[:, i])
        # The documented stream of spacecraft i.
        np.testing.assert_array_equal(np.asarray(jax.random.normal(jax.random.fold_in(KEY, i), (3,))), big[:, i])


def test_spacecraft_streams_are_uncorrelated():
    x = np.asarray(per_spacecraft_normal(KEY, N, 3))
    c = np.corrcoef(x.T)
    # Standard error of a sample correlation of independent streams ≈ 1/√N.
    assert np.all(np.abs(c[np.triu_indices(3, 1)]) < 5.0 / np.sqrt(N))


def test_same_key_replays_and_other_key_differs():
    a = np.asarray(per_spacecraft_normal(KEY, 3, 1000))
    np.testing.assert_array_equal(np.asarray(per_spacecraft_normal(KEY, 3, 1000)), a)
    b = np.asarray(per_spacecraft_normal(jax.random.key(1), 3, 1000))
    assert not np.any(a == b)


# --- white_noise --------------------------------------------------------------------------------


def test_white_noise_per_component_sigma():
    sigma = np.array([1e-3, 2.0, 50.0])
    value = np.array([[1.0], [-3.0], [7.0]]) * np.ones((3, N))
    x = np.asarray(white_noise(value, KEY, sigma))
    _assert_mean(x - value, sigma, axis=1)
    _assert_std(x - value, sigma, axis=1)


def test_white_noise_sigma_shapes_agree():
    value = np.zeros((3, 10))
    ref = np.asarray(white_noise(value, KEY, np.full((3, 10), 2.0)))
    np.testing.assert_array_equal(np.asarray(white_noise(value, KEY, 2.0)), ref)
    np.testing.assert_array_equal(np.asarray(white_noise(value, KEY, np.full(3, 2.0))), ref)
    np.testing.assert_array_equal(np.asarray(white_noise(value, KEY, np.zeros(3))), value)


# --- star tracker --------------------------------------------------------------------------------

SIGMA_ST = np.array([5.0, 5.0, 40.0]) * ARCSEC_RAD  # cross-axis, cross-axis, boresight


def test_arcsec():
    assert 10.0 * ARCSEC_RAD == pytest.approx(4.848e-5, rel=1e-4)


def test_star_tracker_error_is_body_frame_with_sigma_per_axis():
    q = _random_quats(N)
    q_meas = np.asarray(star_tracker_measure(q, KEY, SIGMA_ST))
    # Rotation vector of q_true* ⊗ q_meas, 2·vec for small angles (relative error θ²/24 < 1e-10).
    # Anisotropic sigma with random attitudes: an error applied in the inertial frame would mix
    # the axes and fail the per-axis check.
    dtheta = 2.0 * np.asarray(quat_vector(quat_error(q_meas, q, axis=0), axis=0))
    _assert_mean(dtheta, SIGMA_ST, axis=1)
    _assert_std(dtheta, SIGMA_ST, axis=1)


def test_star_tracker_output_unit_and_on_truth_hemisphere():
    q = _random_quats(N, seed=1)
    # 2 rad per axis: many error rotations exceed π, where q ⊗ δq leaves the hemisphere.
    for sigma in (SIGMA_ST, 2.0):
        q_meas = np.asarray(star_tracker_measure(q, KEY, sigma))
        np.testing.assert_allclose(np.linalg.norm(q_meas, axis=0), 1.0, rtol=0, atol=1e-14)
        assert np.all(np.sum(q_meas * q, axis=0) >= 0.0)


def test_star_tracker_zero_sigma_returns_truth():
    q = _random_quats(100, seed=2)
    np.testing.assert_allclose(np.asarray(star_tracker_measure(q, KEY, 0.0)), q, rtol=0, atol=1e-15)


# --- gyro -----------------------------------------------------------------------------------------


def test_gyro_measure_noise_sigma():
    rng = np.random.default_rng(3)
    omega, bias = rng.normal(0, 0.1, (3, N)), rng.normal(0, 1e-4, (3, N))
    sigma = np.array([1e-4, 3e-4, 1e-3])
    noise = np.asarray(gyro_measure(omega, bias, KEY, sigma)) - omega - bias
    _assert_mean(noise, sigma, axis=1)
    _assert_std(noise, sigma, axis=1)


def test_gyro_bias_random_walk_spreads_as_sqrt_time():
    sigma_rw, dt, m = 2e-5, 0.5, 40

    def step(j, b):
        return gyro_bias_step(b, jax.random.fold_in(KEY, j), sigma_rw, dt)

    bias = np.asarray(jax.lax.fori_loop(0, m, step, jnp.zeros((3, N // 3))))
    # Independent increments: variance m·σ²·dt (a reused draw would give m²·σ²·dt).
    _assert_mean(bias, sigma_rw * np.sqrt(m * dt))
    _assert_std(bias, sigma_rw * np.sqrt(m * dt))


def test_noise_terms_draw_distinct_streams():
    n = N // 3
    zeros = jnp.zeros((3, n))
    streams = {
        "white": white_noise(zeros, KEY, 1.0),
        "gyro": gyro_measure(zeros, zeros, KEY, 1.0),
        "bias": gyro_bias_step(zeros, KEY, 1.0, 1.0),
        # Unit-sigma rotation vector recovered from a tiny error rotation.
        "star": 2.0 * quat_vector(star_tracker_measure(jnp.zeros((4, n)).at[0].set(1.0), KEY, 1e-6), axis=0) / 1e-6,
    }
    flat = np.stack([np.asarray(v).ravel() for v in streams.values()])
    c = np.corrcoef(flat)
    assert np.all(np.abs(c[np.triu_indices(len(streams), 1)]) < 5.0 / np.sqrt(flat.shape[1])), c


# --- jit ---------------------------------------------------------------------------------------------


def test_functions_run_under_jit():
    q, w, b = _random_quats(7, seed=4), np.full((3, 7), 0.01), np.full((3, 7), 1e-4)
    sigma = np.array([1.0, 2.0, 3.0]) * 1e-4
    cases = [
        (per_spacecraft_normal, (KEY, 3, 7), dict(static_argnums=(1, 2))),
        (white_noise, (w, KEY, sigma), {}),
        (star_tracker_measure, (q, KEY, SIGMA_ST), {}),
        (gyro_measure, (w, b, KEY, sigma), {}),
        (gyro_bias_step, (b, KEY, sigma, 0.1), {}),
    ]
    for f, args, kw in cases:
        eager = np.asarray(f(*args))
        # XLA fuses the jitted arithmetic differently: agreement to rounding, not bit for bit.
        np.testing.assert_allclose(np.asarray(jax.jit(f, **kw)(*args)), eager, rtol=0, atol=1e-14 * np.max(np.abs(eager)))
