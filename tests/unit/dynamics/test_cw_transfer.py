"""The JAX Clohessy–Wiltshire STM and two-impulse transfer against expm, integration and invariants."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm

from coopsat.astro.constants import MU_EARTH_M3_S2, R_EARTH_M
from coopsat.dynamics.cw import cw_matrices, cw_stm, cw_two_impulse, transfer_impulse_l1

N = np.sqrt(MU_EARTH_M3_S2 / (R_EARTH_M + 500e3) ** 3)  # 500 km chief
PERIOD = 2 * np.pi / N
A = np.asarray(cw_matrices(N)[0])

# A deputy on the SPEC §2 circle (ρ = 1.5 m) and a target a few millimetres off it.
X0 = np.array([1.5, 0.3, -0.17, 1.2e-4, 1.1e-3, -6.0e-4])
XF = np.array([-0.4, 1.25, -0.72, -1.5e-3, -3.0e-4, 1.7e-4])


@pytest.mark.parametrize("t", [0.0, 1.0, 600.0, 0.5 * PERIOD, 5677.0, 3e4])
def test_stm_equals_the_matrix_exponential(t):
    phi = np.asarray(cw_stm(N, t))
    np.testing.assert_allclose(phi, expm(A * t), rtol=1e-10, atol=1e-10 * max(1.0, N * t))


def test_stm_broadcasts_over_time_and_composes():
    t = np.array([[10.0, 700.0, 4000.0], [0.0, 2500.0, 9000.0]])
    phi = np.asarray(cw_stm(N, t))
    assert phi.shape == (2, 3, 6, 6)
    np.testing.assert_array_equal(phi[1, 1], np.asarray(cw_stm(N, 2500.0)))
    t1, t2 = 1234.5, 3210.0
    np.testing.assert_allclose(
        np.asarray(cw_stm(N, t1 + t2)), np.asarray(cw_stm(N, t1) @ cw_stm(N, t2)), rtol=1e-12, atol=1e-12
    )


def test_stm_jits_vmaps_and_differentiates():
    t = jnp.linspace(0.0, 2 * PERIOD, 7)
    batched = jax.jit(jax.vmap(lambda s: cw_stm(N, s)))(t)
    # Compiled code may fuse multiply-adds: equal to rounding, not bit for bit.
    np.testing.assert_allclose(np.asarray(batched), np.asarray(cw_stm(N, t)), rtol=1e-14, atol=1e-14)
    # dΦ/dt = A Φ: the closed form is differentiable in time and satisfies the ODE.
    dphi = jax.jacfwd(lambda s: cw_stm(N, s))(1500.0)
    np.testing.assert_allclose(np.asarray(dphi), A @ np.asarray(cw_stm(N, 1500.0)), rtol=1e-12, atol=1e-18)


def _propagate_stm(x0, dv1, dv2, tof):
    """Apply dv1, coast tof with the STM, apply dv2."""
    x = np.asarray(x0, dtype=float).copy()
    x[3:] += dv1
    x = np.asarray(cw_stm(N, tof)) @ x
    x[3:] += dv2
    return x


@pytest.mark.parametrize("tof", [60.0, 900.0, 0.3 * PERIOD, 0.45 * PERIOD, 0.8 * PERIOD])
def test_two_impulse_transfer_lands_on_the_target(tof):
    dv1, dv2 = (np.asarray(v) for v in cw_two_impulse(X0, XF, N, tof))
    assert dv1.shape == dv2.shape == (3,)
    x_end = _propagate_stm(X0, dv1, dv2, tof)
    np.testing.assert_allclose(x_end[:3], XF[:3], rtol=0, atol=1e-9)
    np.testing.assert_allclose(x_end[3:], XF[3:], rtol=0, atol=1e-12)
    # Independent of the STM: integrate the CW equations themselves.
    x_start = X0.copy()
    x_start[3:] += dv1
    sol = solve_ivp(lambda _, x: A @ x, (0.0, tof), x_start, method="DOP853", rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(sol.y[:3, -1], XF[:3], rtol=0, atol=1e-7)
    np.testing.assert_allclose(sol.y[3:, -1] + dv2, XF[3:], rtol=0, atol=1e-10)


def test_two_impulse_transfer_batches_over_states_and_times():
    rng = np.random.default_rng(3)
    x0 = X0 + rng.normal(scale=[0.01] * 3 + [1e-5] * 3, size=(4, 2, 6))
    xf = XF  # broadcast against the batch
    tof = np.array([300.0, 1100.0])  # broadcast against the last batch axis
    dv1, dv2 = cw_two_impulse(x0, xf, N, tof)
    assert dv1.shape == dv2.shape == (4, 2, 3)
    for i in range(4):
        for j in range(2):
            one = cw_two_impulse(x0[i, j], xf, N, tof[j])
            np.testing.assert_allclose(np.asarray(dv1[i, j]), np.asarray(one[0]), rtol=1e-12, atol=1e-18)
            np.testing.assert_allclose(np.asarray(dv2[i, j]), np.asarray(one[1]), rtol=1e-12, atol=1e-18)
    jitted = jax.jit(jax.vmap(lambda a: cw_two_impulse(a, xf, N, tof)))(x0)
    np.testing.assert_allclose(np.asarray(jitted[0]), np.asarray(dv1), rtol=1e-12, atol=1e-18)


def test_staying_on_a_natural_trajectory_costs_nothing():
    tof = 1000.0
    xf = np.asarray(cw_stm(N, tof)) @ X0
    dv1, dv2 = cw_two_impulse(X0, xf, N, tof)
    assert np.abs(np.asarray(dv1)).max() < 1e-15 and np.abs(np.asarray(dv2)).max() < 1e-15


@pytest.mark.parametrize("orbits", [0.5, 1.0])
def test_transfer_is_ill_conditioned_near_the_singular_times(orbits):
    """Φrv is singular every half orbit (out of plane) and every orbit (in plane)."""
    good = transfer_impulse_l1(X0, XF, N, 0.3 * PERIOD, 1.0)
    near = transfer_impulse_l1(X0, XF, N, orbits * PERIOD * (1 - 1e-6), 1.0)
    assert float(near) > 1e4 * float(good)
    phi_rv = np.asarray(cw_stm(N, orbits * PERIOD * (1 - 1e-6)))[:3, 3:]
    assert np.linalg.cond(phi_rv) > 1e5


def test_impulse_is_the_l1_norm_times_mass_and_has_a_finite_gradient():
    dv1, dv2 = (np.asarray(v) for v in cw_two_impulse(X0, XF, N, 900.0))
    j = transfer_impulse_l1(X0, XF, N, 900.0, 1.3)
    assert float(j) == pytest.approx(1.3 * (np.abs(dv1).sum() + np.abs(dv2).sum()), rel=1e-14)
    grad = jax.grad(lambda z: transfer_impulse_l1(jnp.asarray(X0).at[2].set(z), XF, N, 900.0, 1.3))(X0[2])
    assert np.isfinite(float(grad)) and float(grad) != 0.0
    # Against a central difference (the L1 cost is smooth away from a zero Δv component).
    h = 1e-6
    fd = (
        transfer_impulse_l1(np.where(np.arange(6) == 2, X0 + h, X0), XF, N, 900.0, 1.3)
        - transfer_impulse_l1(np.where(np.arange(6) == 2, X0 - h, X0), XF, N, 900.0, 1.3)
    ) / (2 * h)
    assert float(grad) == pytest.approx(float(fd), rel=1e-6)
