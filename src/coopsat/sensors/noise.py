"""Sensor noise drawn from explicit JAX random keys, component-major ``(k, n)``.

Arrays follow the compiled loop's layout (docs/conventions.md, "Arrays"): component first,
spacecraft last, so ``q_bi`` is ``(4, n)`` and body vectors are ``(3, n)``. Quaternions are
scalar-first, Hamilton, and ``q_bi`` takes body components to inertial components.

Reproducibility: spacecraft i draws from ``jax.random.fold_in(key, i)``
(:func:`coopsat.core.parts.per_spacecraft_normal`), so its noise does not depend on the formation size, and every
noise term folds its own fixed tag into the key first, so the star tracker, the gyro rate noise
and the gyro bias walk never draw the same numbers from one key.
"""


import math

import jax
import jax.numpy as jnp

from coopsat.core.parts import per_spacecraft_normal
from coopsat.geometry.quaternion import dot, quat_exp_rate, quat_multiply, quat_normalize

ARCSEC_RAD = math.pi / 648000.0
"""One arcsecond in radians (10 arcsec = 4.848e-5 rad)."""

# Tags folded into the caller's key, one per noise term.
_STAR_TRACKER = 1
_GYRO_RATE = 2
_GYRO_BIAS = 3


def white_noise(value, key, sigma):
    """``value`` plus zero-mean Gaussian noise of standard deviation ``sigma``.

    Parameters
    ----------
    value : array_like, shape (k, n)
        Noise-free value, component-major.
    key : jax.Array
        PRNG key; spacecraft i draws from ``fold_in(key, i)`` (:func:`coopsat.core.parts.per_spacecraft_normal`).
    sigma : array_like, shape (), (k,) or (k, n)
        Standard deviation in the units of ``value``: one for all, one per component, or one per
        component and spacecraft.

    Returns
    -------
    jax.Array, shape (k, n)
    """
    value = jnp.asarray(value)
    sigma = jnp.asarray(sigma)
    # () -> (1, 1), (k,) -> (k, 1), (k, n) unchanged: broadcast over spacecraft.
    sigma = jnp.reshape(sigma, sigma.shape + (1,) * (2 - sigma.ndim))
    return value + sigma * per_spacecraft_normal(key, *value.shape)


def star_tracker_measure(q_bi, key, sigma_rad):
    """Star-tracker attitude measurement ``q_bi ⊗ δq`` with a small body-frame error.

    Parameters
    ----------
    q_bi : array_like, shape (4, n)
        True unit attitude quaternions (scalar-first, body to inertial).
    key : jax.Array
        PRNG key (the term's tag is folded in here).
    sigma_rad : array_like, shape () or (3,)
        Standard deviation of the error rotation about each body axis, rad
        (10 arcsec = ``10 * ARCSEC_RAD`` = 4.848e-5 rad).

    Returns
    -------
    jax.Array, shape (4, n)
        Unit measured quaternions, on the same hemisphere as ``q_bi`` (non-negative dot product).

    Notes
    -----
    The error rotation vector ``δθ ~ N(0, diag(σ²))`` is in the body (sensor) frame, where a star
    tracker's cross-axis and boresight errors live, and ``δq = exp(½ [0, δθ])``: the error
    quaternion ``q_bi* ⊗ q_meas`` is ``δq`` (``≈ [1, ½ δθ]``).
    """
    q_bi = jnp.asarray(q_bi)
    dtheta_b = white_noise(jnp.zeros((3, q_bi.shape[1])), jax.random.fold_in(key, _STAR_TRACKER), sigma_rad)
    dq = quat_exp_rate(dtheta_b.T, 1.0).T
    q_meas = quat_normalize(quat_multiply(q_bi, dq, axis=0), axis=0)
    return jnp.where(dot(q_meas, q_bi, axis=0) < 0.0, -q_meas, q_meas)


def gyro_measure(omega_b, bias_b, key, sigma_rad_s):
    """Rate-gyro measurement: true rate plus bias plus white noise.

    Parameters
    ----------
    omega_b : array_like, shape (3, n)
        True body angular rate, rad/s, body frame.
    bias_b : array_like, shape (3, n)
        Gyro bias, rad/s, body frame (propagated by :func:`gyro_bias_step`).
    key : jax.Array
        PRNG key (the term's tag is folded in here).
    sigma_rad_s : array_like, shape (), (3,) or (3, n)
        Standard deviation of the rate noise of one sample, rad/s.

    Returns
    -------
    jax.Array, shape (3, n)
        Measured body rate, rad/s.
    """
    return white_noise(jnp.asarray(omega_b) + bias_b, jax.random.fold_in(key, _GYRO_RATE), sigma_rad_s)


def gyro_bias_step(bias_b, key, sigma_rw_rad_s2, dt_s):
    """One step of the gyro bias random walk: ``b + σ_rw √dt ν``, ``ν ~ N(0, 1)``.

    Parameters
    ----------
    bias_b : array_like, shape (3, n)
        Bias at the start of the step, rad/s, body frame.
    key : jax.Array
        PRNG key of this step (the term's tag is folded in here); use a new one every step.
    sigma_rw_rad_s2 : array_like, shape (), (3,) or (3, n)
        Rate random walk σ_rw, rad/s/√s (rad·s^-3/2): after time t the bias has spread
        ``σ_rw √t``.
    dt_s : scalar
        Step length, s.

    Returns
    -------
    jax.Array, shape (3, n)
        Bias at the end of the step, rad/s.
    """
    return white_noise(bias_b, jax.random.fold_in(key, _GYRO_BIAS), jnp.asarray(sigma_rw_rad_s2) * jnp.sqrt(dt_s))
