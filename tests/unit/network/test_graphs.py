"""coopsat.network.graphs: one builder per graph kind of a scenario, the named graphs of
``coopsat topology``; the references are topology's dense constructors (themselves checked
against loops over the nodes in test_edge_list)."""

import typing
from types import SimpleNamespace

import numpy as np
import pytest

from coopsat.network import topology
from coopsat.network.graphs import GRAPH_KINDS, NAMED_GRAPH_NAMES, graph_edges, named_graph
from coopsat.scenarios.schema import Graph

NAMES = ["a", "b", "c", "d"]


def _graph(**fields):
    return SimpleNamespace(**{"kind": "none", "directed": False, "weight": 1.0, "hub": None, "edges": None,
                              "adjacency": None, **fields})


def test_the_schema_takes_its_graph_kinds_from_the_registry():
    assert typing.get_args(Graph.model_fields["kind"].annotation) == tuple(GRAPH_KINDS)


@pytest.mark.parametrize("kind", ["ring", "chain", "complete"])
@pytest.mark.parametrize("directed", [False, True])
def test_named_kinds_are_topology_graphs_times_the_weight(kind, directed):
    a = graph_edges(_graph(kind=kind, directed=directed, weight=0.5), NAMES).toarray()
    np.testing.assert_array_equal(a, 0.5 * topology.NAMED_GRAPHS[kind](4, directed=directed))


def test_star_around_a_named_hub_and_the_other_kinds():
    np.testing.assert_array_equal(graph_edges(_graph(kind="star", hub="c"), NAMES).toarray(), topology.star_adjacency(4, hub=2))
    np.testing.assert_array_equal(graph_edges(_graph(), NAMES).toarray(), np.zeros((4, 4)))
    a = graph_edges(_graph(kind="edges", directed=True, edges=[["a", "b", 2.0]]), NAMES).toarray()
    assert a[1, 0] == 2.0 and np.count_nonzero(a) == 1


@pytest.mark.parametrize("fields, message", [
    ({"kind": "star", "hub": "z"}, "network.switches[1].hub: unknown spacecraft 'z' (known: a, b, c, d)"),
    ({"kind": "edges", "edges": [["a", "z", 1.0]]}, "network.switches[1].edges[0]: unknown spacecraft 'z' (known: a, b, c, d)"),
    ({"kind": "edges", "edges": [["a", "b", 0.0]]}, "network.switches[1].edges: weight of edge 0->1 must be > 0, got 0.0"),
    ({"kind": "adjacency", "adjacency": [[0.0, 1.0], [1.0, 0.0]]}, "network.switches[1].adjacency: is 2×2 but there are 4 spacecraft"),
    ({"kind": "adjacency", "adjacency": [[0.0, -1.0], [1.0, 0.0]]}, "network.switches[1].adjacency: entries must be finite and >= 0"),
    ({"kind": "hexagon"}, "network.switches[1].kind: unknown graph kind 'hexagon'"),
])
def test_a_bad_graph_is_one_line_naming_its_place(fields, message):
    with pytest.raises(topology.GraphError) as err:
        graph_edges(_graph(**fields), NAMES, "network.switches[1]")
    assert str(err.value).startswith(message)


def test_named_graphs_of_the_topology_command():
    assert NAMED_GRAPH_NAMES == ("star", "ring", "chain", "mesh", "complete")
    np.testing.assert_array_equal(named_graph("mesh", 5), topology.complete_adjacency(5))
    np.testing.assert_array_equal(named_graph("star", 5), topology.star_adjacency(5))
    np.testing.assert_array_equal(named_graph("ring", 5), topology.ring_adjacency(5))
    with pytest.raises(topology.GraphError, match="'hexagon' is not a named graph"):
        named_graph("hexagon", 5)
