"""Switching topology: the graph in force changes at the scheduled instants, and only then."""

import numpy as np
import pytest

from coopsat.network.topology import complete_adjacency, links_for_schedule, ring_adjacency
from coopsat.workflows.pipeline import prepare, simulate_built
from coopsat.scenarios.load import ScenarioError, load_scenario

RING_A = '[{t_s = 2.0, kind = "edges", edges = [["sat1","sat2",1.0],["sat2","sat3",0.5],["sat3","sat4",0.5],["sat4","sat5",0.5],["sat5","sat1",0.5]]}]'


def test_schedule_links_share_one_index_set():
    links = links_for_schedule([complete_adjacency(4), ring_adjacency(4)], layout="edges")
    assert links.weight.shape == (2, 12)
    rebuilt = np.zeros((2, 4, 4))
    for g in range(2):
        np.add.at(rebuilt[g], (links.dst, links.src), links.weight[g])
    np.testing.assert_array_equal(rebuilt, [complete_adjacency(4), ring_adjacency(4)])


def test_switched_run_equals_the_two_graphs_run_one_after_the_other():
    # Law (3) is time-invariant: running graph 1 to t_s, then graph 2 from that state, must give
    # the switched run's state (to rounding).
    common = ["sim.dt_s=0.01", "controller.period_s=0.01", "actuators.min_pulse_s=0.001", "sim.record_interval_s=0.5"]
    switched = prepare(load_scenario("consensus-sync-b", [*common, "sim.t_final_s=4.0", f"network.switches={RING_A}"]))
    assert [a.sum() for a in switched.adjacencies] == [20.0, 6.0]
    ds_switched, _ = simulate_built(switched)

    first, _ = simulate_built(prepare(load_scenario("consensus-sync-b", [*common, "sim.t_final_s=2.0"])))
    q_mid, w_mid = first.q.values[-1], first.omega.values[-1]
    restart = [f"spacecraft.{k}.q_bi={q_mid[k].tolist()}" for k in range(5)]
    restart += [f"spacecraft.{k}.omega_b_rad_s={w_mid[k].tolist()}" for k in range(5)]
    second, _ = simulate_built(prepare(load_scenario("consensus-sync-a", [*common, "sim.t_final_s=2.0", *restart])))
    np.testing.assert_allclose(ds_switched.q.values[:5], first.q.values, atol=1e-14)
    np.testing.assert_allclose(ds_switched.omega.values[-1], second.omega.values[-1], atol=1e-10)
    q_a, q_b = ds_switched.q.values[-1], second.q.values[-1]
    np.testing.assert_allclose(q_a * np.sign(np.sum(q_a * q_b, axis=1))[:, None], q_b, atol=1e-10)


def test_a_switch_to_a_graph_without_spanning_tree_is_refused_by_name():
    islands = '[{t_s = 1.0, kind = "edges", edges = [["sat1","sat2",1.0],["sat3","sat4",1.0]]}]'
    with pytest.raises(ScenarioError, match=r"network\.switches\[0\]: the graph has no spanning tree"):
        prepare(load_scenario("consensus-sync-b-stable", [f"network.switches={islands}"]))


def test_switch_times_are_validated():
    late = '[{t_s = 500.0, kind = "ring"}]'  # after the run: it never happens, and that is allowed
    assert load_scenario("consensus-sync-b-stable", [f"network.switches={late}"]).network.switches[0].t_s == 500.0
    off_grid = '[{t_s = 1.005, kind = "ring"}]'
    with pytest.raises(ScenarioError, match=r"whole multiple"):
        load_scenario("consensus-sync-b-stable", [f"network.switches={off_grid}"])
    unordered = '[{t_s = 2.0, kind = "ring"}, {t_s = 1.0, kind = "complete"}]'
    with pytest.raises(ScenarioError, match="increase"):
        load_scenario("consensus-sync-b-stable", [f"network.switches={unordered}"])


def test_stability_check_reports_the_worst_graph():
    built = prepare(load_scenario("consensus-sync-link-failure"))
    ring_only = prepare(load_scenario("consensus-sync-a-stable")).checks["sampled-data"].detail
    complete_only = prepare(load_scenario("consensus-sync-b-stable")).checks["sampled-data"].detail
    assert built.checks["sampled-data"].detail.spectral_radius == max(ring_only.spectral_radius, complete_only.spectral_radius)
    assert built.checks["sampled-data"].detail.max_stable_period_s == min(ring_only.max_stable_period_s, complete_only.max_stable_period_s)
