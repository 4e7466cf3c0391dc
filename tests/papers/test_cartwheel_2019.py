"""Cartwheel keeping (SPEC §2) end to end: the bundled deputies start on the circle, the
quantised LQR keeps them there under J2 (which alone moves the circle by centimetres per
orbit), the on-board PSO equals a grid of its own cost at every solve, a failed ring link
reroutes the long way round, and the remainder policy of the quantiser is the price of
accuracy in bits."""

import numpy as np
import pytest

from coopsat.design.cw import cartwheel_state, deputy_phases
from coopsat.geometry.frames import eci_to_lvlh
from coopsat.workflows.analyse import analyse
from coopsat.workflows.pipeline import prepare, simulate_built
from coopsat.scenarios.load import ScenarioError, load_scenario

DEPUTIES = ("dep1", "dep2", "dep3")


def _run(name, overrides=()):
    built = prepare(load_scenario(name, list(overrides)))
    ds, _ = simulate_built(built)
    metrics, rows = analyse(built, ds)
    return built, ds, metrics


@pytest.mark.parametrize("name", ["cartwheel-keeping-ground", "cartwheel-keeping-pso"])
def test_bundled_deputies_start_on_the_circle(name):
    built = prepare(load_scenario(name))
    x0 = built.system.x0
    r, v = np.asarray(x0.r_eci), np.asarray(x0.v_eci)  # (n, 3)
    rho, rho_dot = eci_to_lvlh(r[0], v[0], r[1:], v[1:])
    n = float(built.system.controller.n_rad_s)
    ideal = cartwheel_state(1.5, n, 0.0, deputy_phases(0.0))
    np.testing.assert_allclose(rho, ideal[:, :3], atol=1e-9)
    np.testing.assert_allclose(rho_dot, ideal[:, 3:], atol=1e-12)


@pytest.mark.slow  # long: runs in CI's second pytest pass (README)
def test_reconfiguration_reaches_the_circle_and_pso_equals_its_grid():
    built, ds, m = _run("cartwheel-reconfigure")
    assert m["reconfiguration_time_s"] is not None and m["reconfiguration_time_s"] < 2000.0
    assert m["position_error_3sigma_m"] < 3e-3 and m["velocity_error_3sigma_m_s"] < 4e-5
    # Every solve: the PSO's cost is the grid's minimum of the same cost (201 points over ±0.01°)
    # or below it, and the whole interval is worth less than one bit.
    cost = ds["plan_cost_ns"].values[:, 0]
    solved = cost[:, 2] > 0
    assert solved.sum() >= 25
    bit = 1e-5
    assert np.all(cost[solved, 0] <= cost[solved, 1] + 1e-3 * bit)
    assert 0.0 < m["pso_interval_worth_bits"] < 1.0
    psi = ds["psi_rad"].values[:, 0]
    assert np.all(np.abs(psi) <= np.deg2rad(0.01) * (1 + 1e-12))


def test_a_failed_ring_link_reroutes_the_long_way_with_its_longer_delay():
    built = prepare(load_scenario("cartwheel-link-loss-deputy"))
    net = built.system.network
    names = built.names
    # Links flattened whatever the layout (edge list, or padded in-neighbour table).
    src, dst = np.asarray(net.src).reshape(-1), np.asarray(net.dst).reshape(-1)
    epochs = lambda a: np.asarray(a).reshape(np.asarray(a).shape[0], -1)  # noqa: E731
    edge = np.flatnonzero((src == names.index("dep2")) & (dst == names.index("dep1")))[0]
    assert epochs(net.hops)[:, edge].tolist() == [1, 3]
    assert epochs(net.delay_periods)[:, edge].tolist() == [1, 3]  # 1 s per hop, 1 s periods


def test_a_switch_naming_a_missing_spacecraft_is_one_clear_error():
    with pytest.raises(ScenarioError, match="dep9"):
        prepare(load_scenario("cartwheel-link-loss-deputy", ['network.switches.0.edges=[["chief", "dep9", 1.0]]']))


@pytest.mark.parametrize(
    "override, message",
    [
        ('controller.deputies=["dep1", "dep2", "nobody"]', "controller.deputies\\[2\\]: unknown spacecraft 'nobody'"),
        ('controller.deputies=["dep1", "chief"]', "exclude the chief"),
        ("sensors=[]", 'kind = "relative-navigation"'),
        ("controller.replan_every_s=2.5", "replan_every_s"),
        ("controller.plan_horizon_s=3000.0", "singular at half an orbit"),
    ],
)
def test_bad_cartwheel_input_is_one_line(override, message):
    with pytest.raises(ScenarioError, match=message):
        prepare(load_scenario("cartwheel-keeping-pso", [override]))


def test_a_circle_too_large_for_cw_is_warned():
    built = prepare(load_scenario("cartwheel-keeping-ground", ["controller.radius_m=50000.0"]))
    assert not built.checks["cw-validity"].ok
    assert any("CW model is not meaningful" in w for w in built.warnings)


@pytest.mark.slow
def test_quantised_lqr_keeps_the_circle_against_j2_for_three_orbits():
    built, ds, m = _run("cartwheel-keeping-ground")
    for d in DEPUTIES:
        # Uncontrolled, J2 moves the circle by ~3 cm per orbit (test_cartwheel_drift).
        assert m[f"position_error_max_m_{d}"] < 4e-3
        assert m[f"velocity_error_max_m_s_{d}"] < 5e-5
        assert 3.0 < m[f"j2_floor_bits_per_orbit_{d}"] < 15.0
        assert m[f"impulse_bits_per_orbit_{d}"] > 0


@pytest.mark.slow
def test_carrying_the_remainder_buys_accuracy_with_two_orders_of_magnitude_more_bits():
    _, _, drop = _run("cartwheel-keeping-ground", ["sim.t_final_s=5680.0"])
    _, _, carry = _run("cartwheel-keeping-ground", ["sim.t_final_s=5680.0", 'actuators.0.remainder="carry"'])
    for d in DEPUTIES:
        assert carry[f"position_error_3sigma_m_{d}"] < 0.2 * drop[f"position_error_3sigma_m_{d}"]
        assert carry[f"impulse_bits_{d}"] > 20 * drop[f"impulse_bits_{d}"]
