"""The report's network panel: link states per graph of the run, relayed routes and delays."""

import numpy as np

from coopsat.network.routing import direct_routes, link_delays, relayed_routes
from coopsat.network.topology import complete_adjacency, ring_adjacency
from coopsat.reports.network_view import LOST, RELAYED, UP, build_network_view, circle_layout, epoch_links


def _by_pair(links):
    return {(k.transmitter, k.receiver): k for k in links}


def test_links_lost_after_a_switch_are_shown_lost_the_others_up():
    a0, a1 = complete_adjacency(4), ring_adjacency(4)
    zero = np.zeros((4, 4), dtype=np.int64)
    epochs = epoch_links([a0, a1], [direct_routes(a0, zero), direct_routes(a1, zero)], 0.01)
    assert {k.state for k in epochs[0]} == {UP} and len(epochs[0]) == 12
    second = _by_pair(epochs[1])
    assert len(second) == 12  # every link of the run stays drawn
    lost = {pair for pair, k in second.items() if k.state == LOST}
    assert lost == {(0, 2), (2, 0), (1, 3), (3, 1)}  # the ring's diagonals
    assert all(second[p].hops == 0 for p in lost)


def test_relayed_pairs_carry_their_hops_and_summed_delay():
    a = ring_adjacency(4)  # undirected ring 0-1-2-3-0: opposite corners are two hops apart
    per_link = link_delays(a, 3, [])
    routes = relayed_routes(a, per_link, 0.5)
    links = _by_pair(epoch_links([a], [routes], 0.1)[0])
    relayed = {p: k for p, k in links.items() if k.state == RELAYED}
    assert set(relayed) == {(0, 2), (2, 0), (1, 3), (3, 1)}
    assert all(k.hops == 2 and np.isclose(k.delay_s, 0.6) for k in relayed.values())
    assert np.isclose(links[(0, 1)].delay_s, 0.3) and links[(0, 1)].state == UP


def test_circle_layout_puts_the_first_node_on_top():
    xy = circle_layout(5)
    np.testing.assert_allclose(xy[0], [0.0, 1.0], atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(xy, axis=1), 1.0)


def test_a_built_scenario_gives_its_switch_times_and_random_delay(run_toml, tmp_path):
    built, ds = run_toml(tmp_path, 'extends = "delay-designed"\n', ["sim.t_final_s=2"])
    view = build_network_view(built, ds)
    assert view.epoch_start_s == [0.0] and view.names == built.names
    tau = view.tau_s
    rd = built.scenario.network.delivery.random_delay
    assert tau is not None and len(tau) == ds.sizes["time"]
    assert np.all((tau >= rd.min_s - 1e-12) & (tau <= rd.max_s + 1e-12))
