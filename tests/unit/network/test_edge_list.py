"""coopsat.network.edge_list: graphs as their links, checked against adjacencies built entry by
entry (loops over the nodes, the convention A[i, j] > 0 iff i hears j written out)."""

import numpy as np
import pytest

from coopsat.network import edge_list, topology


def _dense(n, pairs):
    """A[i, j] = w for every (j, i, w): j transmits to i; a pair given again overwrites."""
    a = np.zeros((n, n))
    for j, i, w in pairs:
        a[i, j] = w
    return a


@pytest.mark.parametrize("n", [1, 2, 3, 7])
@pytest.mark.parametrize("directed", [False, True])
def test_named_graphs_are_the_loops_over_their_nodes(n, directed):
    ring = [((i - 1) % n, i, 1.0) for i in range(n) if n > 1]
    chain = [(i - 1, i, 1.0) for i in range(1, n)]
    star = [(1, k, 1.0) for k in range(n) if k != 1] if n > 1 else []
    both = lambda pairs: pairs if directed else pairs + [(i, j, w) for j, i, w in pairs]  # noqa: E731
    np.testing.assert_array_equal(edge_list.ring(n, directed).toarray(), _dense(n, both(ring)))
    np.testing.assert_array_equal(edge_list.chain(n, directed).toarray(), _dense(n, both(chain)))
    if n > 1:
        np.testing.assert_array_equal(edge_list.star(n, directed, hub=1).toarray(), _dense(n, both(star)))
    full = [(j, i, 1.0) for i in range(n) for j in range(n) if i != j]
    np.testing.assert_array_equal(edge_list.complete(n).toarray(), _dense(n, full))


def test_links_are_each_pair_once_sorted_as_nonzero_gives_them():
    rng = np.random.default_rng(3)
    n = 9
    src, dst = rng.integers(0, n, 60), rng.integers(0, n, 60)
    keep = src != dst
    src, dst = src[keep], dst[keep]
    w = rng.uniform(0.5, 2.0, src.size)
    for directed in (True, False):
        e = edge_list.edge_list(n, src, dst, w, directed)
        pairs = []
        for j, i, wk in zip(src, dst, w):  # undirected: each edge both ways, in the order given
            pairs += [(j, i, wk)] if directed else [(j, i, wk), (i, j, wk)]
        a = _dense(n, pairs)  # the last weight given for a pair wins
        np.testing.assert_array_equal(e.toarray(), a)
        rows, cols = np.nonzero(a)
        np.testing.assert_array_equal(e.dst, rows)
        np.testing.assert_array_equal(e.src, cols)
        assert e.n_links == np.count_nonzero(a)


def test_weights_at_any_pairs_and_scaling():
    e = edge_list.edge_list(5, [0, 3, 4], [1, 1, 2], [2.0, 0.5, 3.0])
    a = e.toarray()
    dst, src = np.meshgrid(np.arange(5), np.arange(5), indexing="ij")
    np.testing.assert_array_equal(e.weights_at(dst, src), a)
    np.testing.assert_array_equal(e.scaled(2.0).toarray(), 2.0 * a)
    np.testing.assert_array_equal(edge_list.empty(4).weights_at([1, 2], [0, 0]), [0.0, 0.0])


def test_adjacency_round_trip_and_union():
    rng = np.random.default_rng(5)
    a = (rng.random((8, 8)) < 0.3) * rng.uniform(0.5, 2.0, (8, 8))
    np.fill_diagonal(a, 0.0)
    b = (rng.random((8, 8)) < 0.3) * 1.0
    np.fill_diagonal(b, 0.0)
    np.testing.assert_array_equal(edge_list.from_adjacency(a).toarray(), a)
    np.testing.assert_array_equal(edge_list.union([a, edge_list.from_adjacency(b)]).toarray(), ((a > 0) | (b > 0)) * 1.0)


def test_schedule_links_from_edge_lists_equal_those_from_adjacencies():
    graphs = [edge_list.ring(12), edge_list.edge_list(12, [0, 5], [3, 7], [2.0, 0.25], directed=False), edge_list.empty(12)]
    for layout in ("edges", "padded"):
        sparse = topology.links_for_schedule(graphs, layout)
        dense = topology.links_for_schedule([g.toarray() for g in graphs], layout)
        for field in ("src", "dst", "weight"):
            np.testing.assert_array_equal(getattr(sparse, field), getattr(dense, field))
        # Every graph's weights are its adjacency read at the links (padding reads 0).
        for g, w in zip(graphs, sparse.weight):
            np.testing.assert_array_equal(w, g.toarray()[sparse.dst, sparse.src])


def test_spanning_tree_on_edge_lists_matches_the_dense_answer():
    assert topology.spanning_tree_roots(edge_list.ring(6, directed=True)) == list(range(6))
    assert topology.spanning_tree_roots(edge_list.star(5, directed=True, hub=3)) == [3]
    islands = edge_list.edge_list(4, [0, 2], [1, 3], 1.0, directed=False)
    assert topology.spanning_tree_roots(islands) == topology.spanning_tree_roots(islands.toarray()) == []
    assert "2 groups" in topology.describe_components(islands)


@pytest.mark.parametrize("src, dst, weight, message", [
    ([0, 2], [1, 2], [1.0, 1.0], "g.edges: self-loop on spacecraft 2 (a spacecraft does not hear itself)"),
    ([0, 1], [1, 2], [1.0, -0.5], "g.edges: weight of edge 1->2 must be > 0, got -0.5"),
    ([0], [1], [np.nan], "g.edges: weight of edge 0->1 must be > 0, got nan"),
])
def test_bad_links_are_one_line(src, dst, weight, message):
    with pytest.raises(topology.GraphError) as err:
        edge_list.edge_list(3, src, dst, weight, where="g.edges")
    assert str(err.value) == message


def test_spanning_tree_roots_are_the_nodes_that_reach_every_node():
    """Against networkx's reachability on random digraphs (sparse and dense, rooted or not)."""
    import networkx as nx

    rng = np.random.default_rng(11)
    for trial in range(40):
        n = int(rng.integers(1, 12))
        a = (rng.random((n, n)) < rng.uniform(0.05, 0.4)) * 1.0
        np.fill_diagonal(a, 0.0)
        g = nx.DiGraph()
        g.add_nodes_from(range(n))
        g.add_edges_from((j, i) for i, j in zip(*np.nonzero(a)))  # information flows j -> i
        expected = sorted(k for k in range(n) if len(nx.descendants(g, k)) == n - 1)
        assert topology.spanning_tree_roots(edge_list.from_adjacency(a)) == expected
        assert topology.spanning_tree_roots(a) == expected
