"""Sampled-data stability check: closed forms, and the nonlinear loop confirms the bound."""

import numpy as np
import pytest

from coopsat.design.sampled_data import analyze_sampled_data, linearize_consensus_loop, period_map
from coopsat.workflows.pipeline import prepare, simulate_built
from coopsat.scenarios.load import load_scenario


def closed_form_bound(inertia, k_p, k_d):
    """Largest stable period of one axis, I ε̈·2 = −K ε − D ε̇·2, held over T (Jury's test).

    With ε̇ = ½δω and I δω̇ = −K ε − D δω held: trace = 2 − KT²/(4I) − DT/I,
    det = 1 − DT/I + KT²/(4I). Stable iff T < 2I/D, T < 4D/K, and KT²/(4I) − DT/I + 2 > 0.
    """
    bounds = [2 * inertia / k_d, 4 * k_d / k_p]
    disc = (k_d / inertia) ** 2 - 2 * k_p / inertia
    if disc > 0:
        bounds.append((k_d / inertia - np.sqrt(disc)) / (k_p / (2 * inertia)))
    return min(bounds)


@pytest.mark.parametrize("inertia, k_p, k_d", [(0.1, 90.0, 80.0), (1.0, 1.0, 2.0), (0.7, 5.0, 0.5)])
def test_single_axis_bound_matches_jury_closed_form(inertia, k_p, k_d):
    # One spacecraft tracking a fixed reference: no graph, three decoupled identical axes.
    st = analyze_sampled_data(np.eye(3)[None] * inertia, np.zeros((1, 1)), 0.001, 1.0, 1.0, k_p, k_d)
    assert st.max_stable_period_s == pytest.approx(closed_form_bound(inertia, k_p, k_d), rel=1e-8)


def test_period_map_tends_to_identity_and_matches_expm_series():
    a, b, g = linearize_consensus_loop(np.eye(3)[None], np.zeros((1, 1)), 1.0, 1.0, 2.0, 3.0)
    np.testing.assert_allclose(period_map(a, b, g, 1e-9), np.eye(6), atol=1e-8)
    t = 1e-3
    first_order = np.eye(6) + t * (a - b @ g)
    np.testing.assert_allclose(period_map(a, b, g, t), first_order, atol=1e-5)


def test_paper_cases_unstable_at_the_published_period():
    # SPEC §1: the published T = 0.5 s is not stable; the mode lives on satellite 1's y axis.
    for name in ("consensus-sync-a", "consensus-sync-b", "consensus-track"):
        built = prepare(load_scenario(name))
        st = built.checks["sampled-data"].detail
        assert st.spectral_radius > 10.0
        assert st.max_stable_period_s < 0.1
        assert st.dominant == (0, 1)
        assert any("UNSTABLE" in w for w in built.warnings)


def test_stable_variants_lie_inside_their_bounds():
    for name in ("consensus-sync-a-stable", "consensus-sync-b-stable", "consensus-track-stable"):
        st = prepare(load_scenario(name)).checks["sampled-data"].detail
        assert st.stable and st.period_s < 0.5 * st.max_stable_period_s


@pytest.mark.parametrize("factor, grows", [(0.8, False), (1.25, True)])
def test_nonlinear_loop_confirms_the_bound(factor, grows):
    # Ideal (unsaturated) torque, a small disagreement: just inside the bound it decays, just
    # outside it grows. The engine shares no code with the linear analysis.
    base = prepare(load_scenario("consensus-sync-b-stable"))
    t_max = base.checks["sampled-data"].detail.max_stable_period_s
    period = round(factor * t_max, 6)
    overrides = [
        "actuators.kind=ideal-torque", f"controller.period_s={period}", f"sim.dt_s={period / 10}",
        f"sim.record_interval_s={period}", f"sim.t_final_s={period * 30}",
    ] + [f"spacecraft.{k}.omega_b_rad_s=[0.0, {1e-4 * (k - 2)}, 0.0]" for k in range(5)] + [
        f"spacecraft.{k}.q_bi=[1.0, 0.0, 0.0, 0.0]" for k in range(5)
    ]
    ds, _ = simulate_built(prepare(load_scenario("consensus-sync-b", overrides)))
    w = ds.omega.values
    spread = np.linalg.norm(w - w.mean(axis=1, keepdims=True), axis=(1, 2))
    assert (spread[-1] > 10 * spread[0]) == grows
    assert (spread[-1] < spread[0]) == (not grows)


def test_linearisation_matches_a_finite_difference_jacobian_about_a_spinning_reference():
    # One spacecraft tracking ω_r = [0, 0.1, 0] (a principal axis): the nonlinear error
    # dynamics of law (4), differentiated numerically at the reference, must equal A − B G.
    inertia = np.diag([1.0, 0.1, 0.9])
    w_r = np.array([0.0, 0.1, 0.0])
    k_p, k_d = 90.0, 80.0

    def quat_mul(p, q):
        return np.concatenate([[p[0] * q[0] - p[1:] @ q[1:]], p[0] * q[1:] + q[0] * p[1:] + np.cross(p[1:], q[1:])])

    def f(x):
        eps, dw = x[:3], x[3:]
        q_e = np.concatenate([[np.sqrt(1.0 - eps @ eps)], eps])  # q_r* ⊗ q_i with q_r = identity now
        w = w_r + dw
        dq_e = -0.5 * quat_mul(np.concatenate([[0.0], w_r]), q_e) + 0.5 * quat_mul(q_e, np.concatenate([[0.0], w]))
        u = -k_p * eps - k_d * dw
        return np.concatenate([dq_e[1:], np.linalg.solve(inertia, u - np.cross(w, inertia @ w))])

    h = 1e-7
    jac = np.column_stack([(f(h * e) - f(-h * e)) / (2 * h) for e in np.eye(6)])
    a, b, g = linearize_consensus_loop(inertia[None], np.zeros((1, 1)), 1.0, 2.0, k_p, k_d, w_r)
    np.testing.assert_allclose(a - b @ g, jac, atol=1e-6)


def test_one_spacecraft_and_unsaturated_messages():
    # One spacecraft under the sync law: nothing to agree on, no check and no crash.
    built = prepare(load_scenario("rigid-body-free", [
        "controller.kind=consensus-sync", "controller.period_s=0.001", "controller.alpha=1.0", "controller.beta=2.0",
        "network.kind=ring", "sim.t_final_s=1.0",
    ]))
    assert "sampled-data" not in built.checks
    # An unstable loop with an unsaturated actuator diverges rather than settling into a cycle.
    built = prepare(load_scenario("consensus-sync-a", ["actuators.kind=ideal-torque"]))
    assert "expect divergence" in built.checks["sampled-data"].note
