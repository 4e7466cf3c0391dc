"""Clohessy–Wiltshire design model (SPEC §2) against closed forms and invariants."""

import numpy as np
import pytest
from scipy.linalg import expm

from coopsat.astro.constants import MU_EARTH_M3_S2, R_EARTH_M
from coopsat.design.cw import cartwheel_state, cw_matrices, cw_stm, deputy_phases
from coopsat.design.riccati import discretize, lqr

N = np.sqrt(MU_EARTH_M3_S2 / (R_EARTH_M + 500e3) ** 3)  # 500 km chief


def test_matrices_are_the_spec_equations():
    a, b = cw_matrices(N)
    x = np.random.default_rng(0).normal(size=6)
    acc = (a @ x)[3:]
    np.testing.assert_allclose(acc, [2 * N * x[5], -N**2 * x[1], -2 * N * x[3] + 3 * N**2 * x[2]], rtol=1e-15)
    np.testing.assert_array_equal(b[3:], np.eye(3))


@pytest.mark.parametrize("t", [0.0, 1.0, 600.0, 5677.0, 3e4])
def test_closed_form_stm_equals_the_matrix_exponential(t):
    a, _ = cw_matrices(N)
    phi = cw_stm(N, t)
    np.testing.assert_allclose(phi, expm(a * t), rtol=1e-9, atol=1e-9 * max(1.0, N * t))


def test_cartwheel_is_an_exact_bounded_circle():
    a, _ = cw_matrices(N)
    t = np.linspace(0.0, 3 * 2 * np.pi / N, 301)
    phases = deputy_phases(np.deg2rad(10.0))
    x = cartwheel_state(1.5, N, t[:, None], phases)  # (T, 3, 6)
    np.testing.assert_allclose(np.linalg.norm(x[..., :3], axis=-1), 1.5, rtol=1e-15)
    # ẋ = A x at every instant: the velocity is the state's derivative (finite-free check).
    theta = N * t[:, None] + phases
    rate = 1.5 * N**2 * np.stack([-np.cos(theta), -np.sqrt(3) / 2 * np.sin(theta), 0.5 * np.sin(theta)], axis=-1)
    residual = np.einsum("ij,tkj->tki", a, x) - np.concatenate([x[..., 3:], rate], axis=-1)
    assert np.abs(residual).max() < 1e-15 * 1.5 * N**2 * 10
    # The STM carries the circle into itself.
    x0 = cartwheel_state(1.5, N, 0.0, phases)
    np.testing.assert_allclose((cw_stm(N, t[-1]) @ x0.T).T, x[-1], atol=1e-12)


def test_deputies_are_evenly_spaced_and_the_circle_plane_is_tilted_30_degrees():
    phases = deputy_phases(0.3)
    np.testing.assert_allclose(np.diff(phases), 2 * np.pi / 3)
    pos = cartwheel_state(1.5, N, 0.0, phases)[:, :3]
    normal = np.cross(pos[1] - pos[0], pos[2] - pos[0])
    normal /= np.linalg.norm(normal)
    # The local horizontal x–y plane has normal z: the circle's plane is 30° from it.
    assert np.degrees(np.arccos(abs(normal[2]))) == pytest.approx(30.0, abs=1e-9)


def test_discrete_lqr_stabilises_and_satisfies_the_riccati_equation():
    q, r = np.diag([1e4] * 3 + [1e6] * 3), np.eye(3) * 1e8
    res = lqr(*cw_matrices(N), q, r, discrete_dt_s=10.0)
    k, p = res.K, res.P
    phi, gam = discretize(*cw_matrices(N), 10.0)
    assert np.abs(np.linalg.eigvals(phi - gam @ k)).max() < 1.0
    riccati = phi.T @ p @ phi - phi.T @ p @ gam @ np.linalg.solve(r + gam.T @ p @ gam, gam.T @ p @ phi) + q - p
    assert np.abs(riccati).max() < 1e-8 * np.abs(p).max()
