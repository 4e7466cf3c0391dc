"""Design-time routing (coopsat.network.routing) against independent references.

Conventions (docs/conventions.md, Graphs): ``A[i, j] > 0`` iff i hears j, i.e. j transmits to
i; ``C[i, j]`` is the fixed delay of the link j→i. The references here build their own
networkx graphs from ``A`` (never topology.information_digraph) and enumerate every simple
path by brute force: fewest hops first, then the least summed delay.
"""

import itertools
from types import SimpleNamespace

import networkx as nx
import numpy as np
import pytest

from coopsat.network import edge_list
from coopsat.network.routing import Routes, direct_routes, link_delays, lost_route, relayed_routes
from coopsat.network.topology import chain_adjacency, ring_adjacency, star_adjacency

RELAY = 0.5


def _dense(routes):
    """The routes' heard pairs as (n, n) matrices ``[i, j]`` (i hears j), 0 where not heard."""
    assert isinstance(routes, Routes)
    heard = routes.heard
    assert np.all(routes.hops >= 1) and np.all(heard.weight > 0)  # only heard pairs are listed
    weight, hops, delay = routes.matrices()
    np.testing.assert_array_equal(hops[heard.dst, heard.src], routes.hops)
    return SimpleNamespace(weight=weight, hops=hops, delay_periods=delay)


def _digraph(a):
    """Edge j→i for every A[i, j] > 0 (information flows from j to i)."""
    g = nx.DiGraph()
    g.add_nodes_from(range(len(a)))
    g.add_edges_from((j, i) for i, j in zip(*np.nonzero(np.asarray(a) > 0)) if i != j)
    return g


def _reference(a, c):
    """(hops, delay) by brute force over all simple paths j → i; 0 where unreachable."""
    n = len(a)
    g = _digraph(a)
    hops = np.zeros((n, n), dtype=int)
    delay = np.zeros((n, n), dtype=int)
    for j, i in itertools.permutations(range(n), 2):
        paths = list(nx.all_simple_paths(g, j, i))
        if not paths:
            continue
        best = min((len(p) - 1, sum(c[v, u] for u, v in zip(p, p[1:]))) for p in paths)
        hops[i, j], delay[i, j] = best
    return hops, delay


def _check_against_reference(a, c, relay_weight=RELAY):
    routes = _dense(relayed_routes(a, c, relay_weight))
    hops, delay = _reference(a, c)
    np.testing.assert_array_equal(routes.hops, hops)
    np.testing.assert_array_equal(routes.delay_periods, delay)
    heard = hops > 0
    direct = (np.asarray(a) > 0) & ~np.eye(len(a), dtype=bool)
    expected_weight = np.where(direct, a, np.where(heard, relay_weight, 0.0))
    np.testing.assert_array_equal(routes.weight, expected_weight)
    # Cross-check the hop counts with networkx's own BFS (a second, independent reference).
    lengths = dict(nx.all_pairs_shortest_path_length(_digraph(a)))
    for i, j in itertools.permutations(range(len(a)), 2):
        assert routes.hops[i, j] == lengths[j].get(i, 0)
    return routes


# --------------------------------------------------------------------------------------------
# direct_routes


def test_direct_routes_hear_only_the_links_one_hop_at_their_delay():
    a = np.array([[0.0, 2.0, 0.0], [0.0, 0.0, 0.0], [0.7, 1.0, 0.0]])  # 0 hears 1; 2 hears 0 and 1
    c = np.array([[9, 3, 9], [9, 9, 9], [4, 5, 9]])  # 9 where there is no link: must not leak
    routes = _dense(direct_routes(a, c))
    np.testing.assert_array_equal(routes.weight, a)
    np.testing.assert_array_equal(routes.hops, [[0, 1, 0], [0, 0, 0], [1, 1, 0]])
    np.testing.assert_array_equal(routes.delay_periods, [[0, 3, 0], [0, 0, 0], [4, 5, 0]])
    assert routes.hops.dtype.kind == "i" and routes.delay_periods.dtype.kind == "i"
    graph = edge_list.from_adjacency(a)
    kept = direct_routes(graph, link_delays(graph, 4, []))
    graph.weight[:] = 99.0
    assert kept.heard.weight.tolist() == [2.0, 0.7, 1.0]  # a copy, not a view of the caller's links
    assert kept.delay_periods.tolist() == [4, 4, 4]


# --------------------------------------------------------------------------------------------
# relayed_routes: named graphs in closed form


@pytest.mark.parametrize("n", [2, 5])
def test_directed_chain_relays_downstream_only(n):
    # Directed chain: i hears i − 1, so j reaches i > j over i − j hops; nothing flows back.
    routes = _check_against_reference(chain_adjacency(n, directed=True), np.ones((n, n), dtype=int))
    i, j = np.indices((n, n))
    np.testing.assert_array_equal(routes.hops, np.where(i > j, i - j, 0))
    np.testing.assert_array_equal(routes.delay_periods, routes.hops)  # one period per hop
    assert np.all(routes.weight[i == j + 1] == 1.0) and np.all(routes.weight[i > j + 1] == RELAY)


def test_undirected_chain_hops_are_the_index_distance():
    n = 6
    routes = _check_against_reference(chain_adjacency(n), 2 * chain_adjacency(n).astype(int))
    i, j = np.indices((n, n))
    np.testing.assert_array_equal(routes.hops, np.abs(i - j))
    np.testing.assert_array_equal(routes.delay_periods, 2 * np.abs(i - j))  # m hops arrive m·τ late


@pytest.mark.parametrize("n", [3, 6])
def test_directed_ring_hops_go_round_one_way(n):
    # Directed ring: information flows 0 → 1 → … → n−1 → 0, so i hears j over (i − j) mod n hops.
    routes = _check_against_reference(ring_adjacency(n, directed=True), np.full((n, n), 3))
    i, j = np.indices((n, n))
    np.testing.assert_array_equal(routes.hops, (i - j) % n)
    np.testing.assert_array_equal(routes.delay_periods, 3 * ((i - j) % n))


def test_undirected_ring_takes_the_short_way_round():
    n = 7
    routes = _check_against_reference(ring_adjacency(n), np.ones((n, n), dtype=int))
    i, j = np.indices((n, n))
    np.testing.assert_array_equal(routes.hops, np.minimum((i - j) % n, (j - i) % n))


def test_directed_star_leaves_hear_the_hub_and_nothing_else():
    n, hub = 5, 2
    routes = _check_against_reference(star_adjacency(n, directed=True, hub=hub), np.ones((n, n), dtype=int))
    expected = np.zeros((n, n), dtype=int)
    expected[[k for k in range(n) if k != hub], hub] = 1
    np.testing.assert_array_equal(routes.hops, expected)
    assert routes.weight[hub].sum() == 0.0  # the hub hears nobody


def test_undirected_star_leaves_hear_each_other_through_the_hub():
    n = 5
    c = np.zeros((n, n), dtype=int)
    c[0, 1:] = [1, 2, 3, 4]  # leaf k → hub: k periods
    c[1:, 0] = 10  # hub → any leaf: 10 periods
    routes = _check_against_reference(star_adjacency(n), c * (star_adjacency(n) > 0))
    for i, j in itertools.permutations(range(1, n), 2):
        assert routes.hops[i, j] == 2 and routes.delay_periods[i, j] == j + 10
        assert routes.weight[i, j] == RELAY


# --------------------------------------------------------------------------------------------
# relayed_routes: the tie-break and unreachable spacecraft


def test_fewest_hops_win_over_a_shorter_delay():
    # 0 → 3 directly (20 periods) or 0 → 1 → 2 → 3 (1 period each): the direct link wins.
    a = np.zeros((4, 4))
    a[3, 0] = a[1, 0] = a[2, 1] = a[3, 2] = 1.0
    c = np.where(a > 0, 1, 0)
    c[3, 0] = 20
    routes = _check_against_reference(a, c)
    assert (routes.hops[3, 0], routes.delay_periods[3, 0]) == (1, 20)


def test_among_equally_short_routes_the_least_delay_wins():
    # Diamond 0 → {1, 2} → 3: through 1 costs 5 + 5, through 2 costs 1 + 7.
    a = np.zeros((4, 4))
    for j, i in [(0, 1), (0, 2), (1, 3), (2, 3)]:
        a[i, j] = 1.0
    c = np.zeros((4, 4), dtype=int)
    c[1, 0], c[3, 1], c[2, 0], c[3, 2] = 5, 5, 1, 7
    routes = _check_against_reference(a, c)
    assert (routes.hops[3, 0], routes.delay_periods[3, 0]) == (2, 8)
    c[3, 2] = 10  # now the route through 1 is the cheaper one
    assert _dense(relayed_routes(a, c, RELAY)).delay_periods[3, 0] == 10


def test_an_unreachable_spacecraft_is_heard_by_nobody_and_hears_its_sources():
    # 0 → 1 → 2 and 3 → 0: nobody transmits to 3, and 4 is cut off altogether.
    a = np.zeros((5, 5))
    for j, i in [(0, 1), (1, 2), (3, 0)]:
        a[i, j] = 0.8
    routes = _check_against_reference(a, np.where(a > 0, 2, 0))
    assert routes.weight[3].sum() == 0.0 and routes.hops[3].sum() == 0  # 3 hears no one
    assert routes.weight[:, 4].sum() == 0.0 and routes.weight[4].sum() == 0.0  # 4: no one, either way
    assert routes.hops[2, 3] == 3 and routes.delay_periods[2, 3] == 6  # 3 → 0 → 1 → 2
    assert routes.weight[2, 3] == RELAY and routes.weight[1, 0] == 0.8  # relayed vs direct weight


@pytest.mark.parametrize("seed", range(6))
def test_random_digraphs_match_the_brute_force_reference(seed):
    rng = np.random.default_rng(seed)
    n = 6
    a = np.where(rng.random((n, n)) < 0.3, rng.uniform(0.5, 2.0, (n, n)), 0.0)
    np.fill_diagonal(a, 0.0)
    c = np.where(a > 0, rng.integers(0, 6, (n, n)), 0)
    _check_against_reference(a, c, relay_weight=0.25)


# --------------------------------------------------------------------------------------------
# link_delays and lost_route


def test_link_delays_apply_the_default_and_one_way_overrides_on_links_only():
    a = ring_adjacency(4)  # undirected: both directions exist
    per_link = link_delays(a, 2, [(0, 1, 7), (2, 0, 5)])  # (j, i, d): link j → i; 2 → 0 is no link
    assert per_link.dtype.kind == "i" and per_link.shape == (8,)
    rows, cols = np.nonzero(a)  # the links in the order of the graph's edge list
    c = np.zeros((4, 4), dtype=int)
    c[rows, cols] = per_link
    expected = np.where(a > 0, 2, 0)
    expected[1, 0] = 7  # 0 → 1 only: 1 → 0 keeps the default
    np.testing.assert_array_equal(c, expected)
    assert c[0, 1] == 2 and c[0, 2] == 0


def test_lost_route_names_the_receiver_then_the_transmitter():
    names = ["a", "b", "c"]
    chain = relayed_routes(chain_adjacency(3, directed=True), np.ones((3, 3), dtype=int), RELAY)  # a → b → c
    ring = relayed_routes(ring_adjacency(3, directed=True), np.ones((3, 3), dtype=int), RELAY)
    broken = chain_adjacency(3, directed=True)
    broken[2, 1] = 0.0  # b → c fails: c no longer hears a or b
    after = relayed_routes(broken, np.ones((3, 3), dtype=int), RELAY)
    assert lost_route(chain, after, names) in {("c", "a"), ("c", "b")}
    assert lost_route(chain, ring, names) is None  # more is heard, nothing lost
    assert lost_route(ring, ring, names) is None
    only = np.zeros((3, 3))
    only[0, 2] = 1.0  # a hears c only
    lone = relayed_routes(only, np.zeros((3, 3), dtype=int), RELAY)
    assert lost_route(lone, chain, names) == ("a", "c")
