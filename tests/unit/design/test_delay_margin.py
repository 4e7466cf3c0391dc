"""Exact delay margin: closed forms, Lambert W, and direct simulation on both sides of the margin."""

import math

import numpy as np
import pytest
from scipy.linalg import svd
from scipy.special import lambertw

from coopsat.design.delay_exact import (
    characteristic_matrix,
    exact_delay_margin,
    leader_follower_error_system,
    rightmost_root,
    simulate_dde,
)

A = np.array([[0.0, 1.0], [0.0, 0.0]])
B = np.array([[0.0], [1.0]])
# SPEC §3 ring v0→v1→v2→v0 with relaying: row i = follower v(i+1), column j = agent vj.
RING_HOPS = [[1, 0, 2], [2, 1, 0]]
# ẍ = −x − 0.5 x(t − 2τ) − ẋ(t − τ): second order, one- and two-hop delays.
OSC = (
    np.array([[0.0, 1.0], [-1.0, 0.0]]),
    [(np.array([[0.0, 0.0], [0.0, -1.0]]), 1), (np.array([[0.0, 0.0], [-0.5, 0.0]]), 2)],
)


def growth_ratio(a0, terms, tau, x0, t_final, steps_per_tau=20):
    """Peak |x| over the last quarter of the run over the peak over the second quarter."""
    _, x = simulate_dde(a0, terms, tau, x0, t_final, tau / steps_per_tau)
    norm = np.linalg.norm(x, axis=1)
    q = len(norm) // 4
    return norm[-q:].max() / norm[q : 2 * q].max()


def relative_sigma_min(a0, terms, tau, omega):
    scale = np.linalg.norm(a0, 2) + sum(np.linalg.norm(a, 2) for a, _ in terms) + omega
    return svd(characteristic_matrix(a0, terms, 1j * omega, tau), compute_uv=False)[-1] / scale


def test_pure_delay_margin_is_pi_over_two():
    r = exact_delay_margin([[0.0]], [([[-1.0]], 1)], tau_max_search=15.0)
    assert r.stable_without_delay
    assert r.tau_s == pytest.approx(math.pi / 2, abs=1e-6)
    assert r.omega_rad_s == pytest.approx(1.0, abs=1e-9)
    assert [t for t, _ in r.crossings] == pytest.approx([math.pi / 2, 5 * math.pi / 2, 9 * math.pi / 2], abs=1e-9)
    assert r.root_speed > 0.0


@pytest.mark.parametrize("a, b", [(1.0, 0.0), (3.0, 1.2), (2.0, -0.5), (5.0, 4.9)])
def test_hayes_closed_form(a, b):
    # ẋ = −b x − a x(t − τ), a > |b|: τ* = arccos(−b/a)/√(a² − b²) at ω = √(a² − b²).
    r = exact_delay_margin([[-b]], [([[-a]], 1)])
    omega = math.sqrt(a * a - b * b)
    assert r.tau_s == pytest.approx(math.acos(-b / a) / omega, rel=1e-10)
    assert r.omega_rad_s == pytest.approx(omega, rel=1e-10)


def test_delay_independent_and_delay_free_unstable_cases():
    r = exact_delay_margin([[-2.0]], [([[-1.0]], 1)])
    assert r.tau_s == math.inf and math.isnan(r.omega_rad_s) and r.stable_without_delay and r.crossings == []
    r = exact_delay_margin([[0.5]], [([[-0.2]], 1)])
    assert r.tau_s == 0.0 and not r.stable_without_delay


@pytest.mark.parametrize("tau", [0.3, 1.0, 1.5, 3.0])
def test_rightmost_root_matches_lambert_w(tau):
    # s + e^{−sτ} = 0: s = W_0(−τ)/τ, the principal branch being the rightmost root.
    assert rightmost_root([[0.0]], [([[-1.0]], 1)], tau) == pytest.approx((lambertw(-tau, 0) / tau).real, abs=1e-9)


def test_simulator_matches_method_of_steps():
    # ẋ = −x(t − 1), x ≡ 1 on [−1, 0]: piecewise polynomials, which RK4 + Hermite reproduce exactly.
    t, x = simulate_dde([[0.0]], [([[-1.0]], 1)], 1.0, [1.0], 3.0, 0.01)
    u = np.clip(t - 1.0, 0.0, None)
    v = np.clip(t - 2.0, 0.0, None)
    np.testing.assert_allclose(x[:, 0], 1.0 - t + u**2 / 2 - v**3 / 6, atol=1e-12)
    with pytest.raises(ValueError):
        simulate_dde([[0.0]], [([[-1.0]], 1)], 1.0, [1.0], 3.0, 0.3)


def test_helper_matches_hand_written_matrices():
    k = np.array([[1.0, 2.0]])
    bk = B @ k
    adj1 = np.array([[0.0, 0.0], [1.0, 0.0]])  # v2 hears v1 over one hop
    adj2 = np.array([[0.0, 1.0], [0.0, 0.0]])  # v1 hears v2 over two hops
    a0, terms = leader_follower_error_system(A, B, k, RING_HOPS, "law3")
    np.testing.assert_array_equal(a0, np.kron(np.eye(2), A) - np.kron(2.0 * np.eye(2), bk))
    assert [m for _, m in terms] == [1, 2]
    np.testing.assert_array_equal(terms[0][0], np.kron(adj1, bk))
    np.testing.assert_array_equal(terms[1][0], np.kron(adj2, bk))
    a0, terms = leader_follower_error_system(A, B, k, RING_HOPS, "classical")
    np.testing.assert_array_equal(a0, np.kron(np.eye(2), A))
    np.testing.assert_array_equal(terms[0][0], np.kron(adj1 - np.eye(2), bk))
    np.testing.assert_array_equal(terms[1][0], np.kron(adj2 - np.eye(2), bk))
    with pytest.raises(ValueError):
        leader_follower_error_system(A, B, k, RING_HOPS, "paper")


@pytest.mark.parametrize(
    "k, tau_star",
    [([[1.0, 2.0]], 0.178045595991944), ([[0.5, 1.5]], 0.239432182255945)],
)
def test_classical_protocol_margin_confirmed_by_simulation(k, tau_star):
    a0, terms = leader_follower_error_system(A, B, k, RING_HOPS, "classical")
    r = exact_delay_margin(a0, terms)
    assert r.tau_s == pytest.approx(tau_star, rel=1e-9)
    assert relative_sigma_min(a0, terms, r.tau_s, r.omega_rad_s) < 1e-9
    assert r.root_speed > 0.0
    assert abs(rightmost_root(a0, terms, r.tau_s)) < 1e-8
    assert rightmost_root(a0, terms, 0.95 * r.tau_s) < 0.0 < rightmost_root(a0, terms, 1.05 * r.tau_s)
    x0 = [0.05, -0.04, -0.07, 0.03]
    assert growth_ratio(a0, terms, 0.95 * r.tau_s, x0, 60.0) < 0.2
    assert growth_ratio(a0, terms, 1.05 * r.tau_s, x0, 60.0) > 5.0


@pytest.mark.parametrize("k", [[[1.0, 2.0]], [[0.5, 1.5]]])
def test_law3_is_delay_independent_and_decays_at_large_delay(k):
    # Own state current, only what is heard delayed: no root ever reaches the axis.
    a0, terms = leader_follower_error_system(A, B, k, RING_HOPS, "law3")
    r = exact_delay_margin(a0, terms)
    assert r.tau_s == math.inf and r.stable_without_delay
    assert max(rightmost_root(a0, terms, tau) for tau in (0.1, 1.0, 3.0, 10.0)) < 0.0
    assert growth_ratio(a0, terms, 3.0, [0.05, -0.04, -0.07, 0.03], 300.0, steps_per_tau=60) < 0.05


def test_second_order_two_delay_margin_confirmed_by_simulation():
    # With s = jω, z = e^{−jωτ}: −ω² + jωz + 1 + z²/2 = 0 meets |z| = 1 only at
    # ω = (1 + √3)/2, z = −j, hence τ* = (π/2)/ω and the later branches τ* + 2πk/ω.
    a0, terms = OSC
    r = exact_delay_margin(a0, terms, tau_max_search=10.0)
    omega = (1.0 + math.sqrt(3.0)) / 2.0
    assert r.omega_rad_s == pytest.approx(omega, rel=1e-12)
    expected = [math.pi / 2 / omega, (math.pi / 2 + 2 * math.pi) / omega]
    assert [t for t, _ in r.crossings] == pytest.approx(expected, rel=1e-12)
    for tau, w in r.crossings:
        assert relative_sigma_min(a0, terms, tau, w) < 1e-9
    assert growth_ratio(a0, terms, 0.95 * r.tau_s, [1.0, 0.0], 300.0) < 0.2
    assert growth_ratio(a0, terms, 1.05 * r.tau_s, [1.0, 0.0], 300.0) > 5.0
