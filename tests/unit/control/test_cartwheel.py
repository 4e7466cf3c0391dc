"""Cartwheel keeping software (SPEC §2): the ring target estimation of eqs. 7–11 (Table 2)
against closed forms, the delay compensation, and the decentralisation of the flight software."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from coopsat.control.cartwheel import compensate_delay, neighbour_candidate, plane_rotation, weighted_target
from coopsat.design.cw import cw_matrices, deputy_phases
from coopsat.dynamics.cw import PLANE_AXES_LVLH
from coopsat.dynamics.cw import cartwheel_state as circle_state

N = 1.1067834463349404e-3  # 500 km circular orbit, rad/s
RHO = 1.5
PHASES = deputy_phases(0.0)


def test_plane_axes_are_orthonormal_and_the_circle_turns_about_e3():
    e = np.asarray(PLANE_AXES_LVLH)
    np.testing.assert_allclose(e.T @ e, np.eye(3), atol=1e-15)
    np.testing.assert_allclose(np.cross(e[:, 0], e[:, 1]), e[:, 2], atol=1e-15)
    x = np.asarray(circle_state(RHO, N, 123.0, 0.4))
    np.testing.assert_allclose(np.cross(N * e[:, 2], x[:3]), x[3:], atol=1e-15)  # v = ω × R (eq. 9)


@pytest.mark.parametrize("delta", [2 * np.pi / 3, -2 * np.pi / 3, 0.3])
def test_a_neighbour_on_the_circle_gives_the_exact_target(delta):
    t = 777.0
    x_j = circle_state(RHO, N, t, 0.2)
    np.testing.assert_allclose(neighbour_candidate(x_j, delta, N), circle_state(RHO, N, t, 0.2 + delta), atol=1e-15)
    np.testing.assert_allclose(np.asarray(plane_rotation(delta)) @ np.asarray(plane_rotation(-delta)), np.eye(3), atol=1e-15)


def test_delay_compensation_cw_is_exact_and_the_papers_linear_one_costs_a_micrometre():
    # Table 2, "delay only": a state sent 1 s ago and brought to the present.
    t, age = 500.0, 1.0
    sent, now = circle_state(RHO, N, t - age, PHASES), circle_state(RHO, N, t, PHASES)
    cw = compensate_delay(sent, jnp.full(3, age), N, "cw")
    assert np.abs(cw - now).max() < 1e-12  # the paper's "1e-12 m, 1e-15 m/s" level
    linear = compensate_delay(sent, jnp.full(3, age), N, "linear")
    err = np.linalg.norm(np.asarray(linear - now)[:, :3], axis=-1)
    # R + δt V misses the circle's curvature: ½ n² ρ δt².
    np.testing.assert_allclose(err, 0.5 * N**2 * RHO * age**2, rtol=1e-3)
    none = compensate_delay(sent, jnp.full(3, age), N, "none")
    np.testing.assert_allclose(np.linalg.norm(np.asarray(none - now)[:, :3], axis=-1), N * RHO * age, rtol=1e-3)


def test_cw_compensation_follows_the_cw_flow_off_the_circle():
    from scipy.linalg import expm

    x = np.array([0.01, -0.02, 0.005, 1e-4, -2e-4, 3e-5])
    a, _ = cw_matrices(N)
    np.testing.assert_allclose(compensate_delay(jnp.asarray(x), jnp.asarray(3.0), N, "cw"), expm(a * 3.0) @ x, atol=1e-15)


def test_weighted_target_and_its_fallback():
    c = jnp.array([[1.0] * 6, [4.0] * 6])
    target, total = weighted_target(c, jnp.array([2.0, 1.0]), jnp.zeros(6))
    np.testing.assert_allclose(target, 2.0)
    assert total == 3.0
    target, total = weighted_target(c, jnp.zeros(2), jnp.full(6, 7.0))
    np.testing.assert_allclose(target, 7.0)


@pytest.mark.parametrize("weights, expected_rms_factor", [((2.0, 1.0), 1.0 / 3.0), ((0.0, 1.0, 1.0), np.sqrt(0.5))])
def test_navigation_noise_through_the_ring_estimate_matches_its_closed_form(weights, expected_rms_factor):
    # Table 2, "navigation error only": neighbours on the circle, each noisy deputy state with
    # σ = 0.03 mm per axis; the chief's candidate (the plan) is exact. The weighted mean
    # shrinks isotropic noise by ‖w_noisy‖₂ / Σw, whatever the rotation: 1/3 for (chief 2,
    # deputy 1), 1/√2 for two deputies. The paper's "an order of magnitude" needs a chief weight
    # near 9× a deputy's.
    sigma, t, draws = 3e-5, 400.0, 20000
    key = jax.random.PRNGKey(3)
    srcs = len(weights)
    phase_i = PHASES[0]
    src_phase = np.array([0.0, PHASES[1], PHASES[2]])[:srcs]
    is_chief = np.array([True, False, False])[:srcs]
    exact = circle_state(RHO, N, t, jnp.asarray(src_phase))
    noise = sigma * jax.random.normal(key, (draws, srcs, 6)) * jnp.asarray(~is_chief)[None, :, None]
    noise = noise.at[..., 3:].set(0.0)

    def estimate(nz):
        cand = jnp.where(
            jnp.asarray(is_chief)[:, None], circle_state(RHO, N, t, phase_i),
            neighbour_candidate(exact + nz, phase_i - jnp.asarray(src_phase), N),
        )
        return weighted_target(cand, jnp.asarray(weights), circle_state(RHO, N, t, phase_i))[0]

    err = jax.vmap(estimate)(noise) - circle_state(RHO, N, t, phase_i)
    rms_axis = np.sqrt(np.mean(np.asarray(err[:, :3]) ** 2))
    assert rms_axis == pytest.approx(expected_rms_factor * sigma, rel=0.03)
    # Velocity from ω × R: the position error times n.
    assert np.sqrt(np.mean(np.asarray(err[:, 3:]) ** 2)) < 2 * N * expected_rms_factor * sigma
