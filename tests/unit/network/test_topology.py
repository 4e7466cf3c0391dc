"""Graph conventions (DESIGN §3): edge (j, i) = j transmits to i; A[i, j] > 0 iff i hears j."""

import networkx as nx
import numpy as np
import pytest

from coopsat.network import topology


def test_directed_chain_pins_direction_and_laplacian():
    # 0 -> 1 -> 2: 1 hears 0, 2 hears 1.
    a = topology.chain_adjacency(3, directed=True)
    np.testing.assert_array_equal(a, [[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    lap = topology.laplacian(a)
    np.testing.assert_array_equal(lap, [[0, 0, 0], [-1, 1, 0], [0, -1, 1]])
    np.testing.assert_array_equal(lap @ np.ones(3), 0.0)
    # networkx's directed Laplacian uses out-degree; on the reversed graph it equals ours.
    g = nx.DiGraph([(0, 1), (1, 2)])  # information flow j -> i
    nx_lap = nx.laplacian_matrix(g.reverse(), nodelist=[0, 1, 2]).toarray()
    np.testing.assert_array_equal(nx_lap, lap)
    assert topology.spanning_tree_roots(a) == [0]


def test_undirected_named_graphs_are_symmetric_with_expected_degrees():
    for name, degree in (("ring", 2), ("complete", 4)):
        a = topology.NAMED_GRAPHS[name](5)
        np.testing.assert_array_equal(a, a.T)
        np.testing.assert_array_equal(a.sum(axis=1), degree)
    star = topology.star_adjacency(5, hub=2)
    assert star[2].sum() == 4 and star[0].sum() == 1 and star[0, 2] == 1


def test_spanning_tree_detection():
    assert topology.spanning_tree_roots(topology.ring_adjacency(4)) == [0, 1, 2, 3]
    two_islands = topology.adjacency_from_edges(4, [(0, 1, 1.0), (2, 3, 1.0)], directed=False)
    assert topology.spanning_tree_roots(two_islands) == []
    assert "2 groups" in topology.describe_components(two_islands, ["a", "b", "c", "d"])
    # Two spacecraft that only transmit: nobody hears both, no spanning tree.
    two_roots = topology.adjacency_from_edges(3, [(0, 2, 1.0), (1, 2, 1.0)], directed=True)
    assert topology.spanning_tree_roots(two_roots) == []
    # A directed star whose hub transmits to all: rooted at the hub.
    assert topology.spanning_tree_roots(topology.star_adjacency(4, directed=True)) == [0]


def test_bad_graphs_are_refused():
    with pytest.raises(topology.GraphError, match="self-loop"):
        topology.adjacency_from_edges(3, [(1, 1, 1.0)], directed=False)
    with pytest.raises(topology.GraphError, match="> 0"):
        topology.adjacency_from_edges(3, [(0, 1, -1.0)], directed=False)
    with pytest.raises(topology.GraphError, match="square"):
        topology.validate_adjacency(np.ones((2, 3)))
    with pytest.raises(topology.GraphError, match="diagonal"):
        topology.validate_adjacency(np.eye(3))


@pytest.mark.parametrize("layout", ["edges", "padded"])
def test_links_reproduce_the_adjacency(layout):
    rng = np.random.default_rng(1)
    a = (rng.random((7, 7)) < 0.4) * rng.uniform(0.5, 2.0, (7, 7))
    np.fill_diagonal(a, 0.0)
    links = topology.links_from_adjacency(a, layout=layout)
    rebuilt = np.zeros_like(a)
    np.add.at(rebuilt, (links.dst.ravel(), links.src.ravel()), links.weight.ravel())
    np.testing.assert_allclose(rebuilt, a)


def test_auto_layout_avoids_padding_a_hub():
    assert topology.links_from_adjacency(topology.ring_adjacency(100)).src.ndim == 2
    assert topology.links_from_adjacency(topology.star_adjacency(100)).src.ndim == 1


def test_spanning_tree_roots_match_networkx_on_random_digraphs():
    """The roots (scipy's strong components) against networkx's condensation, on 200 random
    sparse digraphs, with and without a spanning tree."""
    import networkx as nx

    rng = np.random.default_rng(7)
    found = 0
    for _ in range(200):
        n = int(rng.integers(1, 9))
        a = (rng.random((n, n)) < rng.uniform(0.05, 0.5)) * rng.uniform(0.5, 2.0, (n, n))
        np.fill_diagonal(a, 0.0)
        g = nx.DiGraph()
        g.add_nodes_from(range(n))
        g.add_edges_from((j, i) for i, j in zip(*np.nonzero(a)))  # information flows j -> i
        cond = nx.condensation(g)
        sources = [c for c in cond.nodes if cond.in_degree(c) == 0]
        expected = sorted(cond.nodes[sources[0]]["members"]) if len(sources) == 1 else []
        assert topology.spanning_tree_roots(a) == expected
        found += bool(expected)
    assert 20 < found < 180  # both cases were exercised
