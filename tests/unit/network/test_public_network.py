"""Public topology metrics of ``coopsat.network`` on networkx graphs and adjacency arrays.

References are independent of the package: networkx's own ``average_shortest_path_length``
and ``algebraic_connectivity``, closed forms of two-terminal and pairwise reliability
(series p^k, parallel 1 − Π(1 − p^L), the Wheatstone bridge, trees Π over the path), and
exact enumeration for Monte Carlo.
"""

import dataclasses
import doctest
import json
import math
import subprocess
import sys

import networkx as nx
import numpy as np
import pytest

import coopsat.network as network
from coopsat.network import metrics
from coopsat.network.topology import GraphError

P = 0.8


# --- graphs ---------------------------------------------------------------------------------


def _random_connected(n=12, prob=0.35, seed=4):
    g = nx.gnp_random_graph(n, prob, seed=seed)
    assert nx.is_connected(g)
    rng = np.random.default_rng(seed)
    for u, v in g.edges:
        g.edges[u, v]["weight"] = float(rng.uniform(0.5, 2.0))
    return g


def _random_strongly_connected(n=10, prob=0.3):
    for seed in range(100):
        g = nx.gnp_random_graph(n, prob, seed=seed, directed=True)
        if nx.is_strongly_connected(g):
            rng = np.random.default_rng(seed)
            for u, v in g.edges:
                g.edges[u, v]["weight"] = float(rng.uniform(0.5, 2.0))
            return g
    raise AssertionError("no strongly connected digraph among the seeds")


def _scrambled_labels(g):
    """Same graph, string labels, nodes inserted in a shuffled order (G.nodes order ≠ sorted)."""
    order = list(g.nodes)[::-1]
    h = g.__class__()
    h.add_nodes_from(f"sc{k}" for k in order)
    h.add_edges_from((f"sc{u}", f"sc{v}", d) for u, v, d in g.edges(data=True))
    return h


def _theta(paths, length):
    """s = 0, t = 1 joined by ``paths`` internally disjoint paths of ``length`` links each."""
    g = nx.Graph()
    nxt = 2
    for _ in range(paths):
        chain = [0, *range(nxt, nxt + length - 1), 1]
        nxt += length - 1
        nx.add_path(g, chain)
    return g


def _bridge():
    """Wheatstone bridge: s=0, t=3, middle nodes 1, 2 joined by the bridge link 1–2."""
    return nx.Graph([(0, 1), (0, 2), (1, 3), (2, 3), (1, 2)])


UNDIRECTED = {
    "ring": nx.cycle_graph(8),
    "star": nx.star_graph(7),
    "complete": nx.complete_graph(6),
    "random": _random_connected(),
}


def _reference_adjacency(g):
    """A[i, j] = weight of the link on which node i hears node j, nodes in G.nodes order,
    built here from the edge list (not by the package's conversion)."""
    index = {u: k for k, u in enumerate(g.nodes)}
    a = np.zeros((len(index), len(index)))
    for u, v, w in g.edges(data="weight", default=1.0):
        a[index[v], index[u]] = w
        if not g.is_directed():
            a[index[u], index[v]] = w
    return a


# --- the module itself ----------------------------------------------------------------------


def test_import_is_cheap_and_names_load_lazily():
    probe = (
        "import json, sys\n"
        "heavy = ('numpy', 'scipy', 'networkx', 'coopsat.network.metrics')\n"
        "import coopsat.network as n\n"
        "before = [m for m in heavy if m in sys.modules]\n"
        "n.Reliability\n"
        "print(json.dumps({'before': before, 'after': [m for m in heavy if m in sys.modules]}))\n"
    )
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    loaded = json.loads(out.stdout.strip().splitlines()[-1])
    assert loaded["before"] == []
    assert "coopsat.network.metrics" in loaded["after"]


def test_public_names_resolve_and_are_documented():
    for name in network.__all__:
        obj = getattr(network, name)
        assert obj is not None
        assert name in dir(network)
    for name in ("average_path_length", "reliability", "two_terminal_reliability", "algebraic_connectivity",
                 "topology_metrics"):
        doc = getattr(network, name).__doc__
        assert "Parameters" in doc and "Returns" in doc and "Raises" in doc, name
    assert network.Reliability is metrics.Reliability and network.GraphError is GraphError
    for cls in (network.Reliability, network.TwoTerminalReliability, network.TopologyMetrics):
        assert dataclasses.is_dataclass(cls) and cls.__dataclass_params__.frozen
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        network.nope  # noqa: B018


def test_module_docstring_examples_run():
    result = doctest.testmod(network, optionflags=doctest.ELLIPSIS)
    assert result.attempted >= 3 and result.failed == 0


def test_results_are_frozen_including_the_pair_matrix():
    rel = network.reliability(nx.cycle_graph(4), P)
    with pytest.raises(dataclasses.FrozenInstanceError):
        rel.value = 1.0
    with pytest.raises(ValueError, match="read-only"):
        rel.per_pair[0, 1] = 1.0
    tt = network.two_terminal_reliability(nx.cycle_graph(4), P, 0, 2)
    with pytest.raises(dataclasses.FrozenInstanceError):
        tt.value = 1.0
    tm = network.topology_metrics(nx.cycle_graph(4), P)
    with pytest.raises(dataclasses.FrozenInstanceError):
        tm.links = 0


# --- path length and algebraic connectivity against networkx ---------------------------------


@pytest.mark.parametrize("name", [*UNDIRECTED, "digraph"])
def test_average_path_length_matches_networkx(name):
    g = UNDIRECTED[name] if name in UNDIRECTED else _random_strongly_connected()
    expected = nx.average_shortest_path_length(g)  # hops: no weight argument
    for graph in (g, _scrambled_labels(g), _reference_adjacency(g)):
        assert network.average_path_length(graph) == pytest.approx(expected, rel=1e-14)


def test_average_path_length_closed_forms_and_unreachable_pairs():
    # Complete: 1 hop; star on n: (2(n−1)·1 + (n−1)(n−2)·2) / (n(n−1)) = 2 − 2/n.
    assert network.average_path_length(nx.complete_graph(5)) == 1.0
    assert network.average_path_length(nx.star_graph(4)) == pytest.approx(2 - 2 / 5, abs=1e-15)
    # Information flows a → b only: b never reaches a.
    assert network.average_path_length(nx.DiGraph([("a", "b")])) == math.inf
    assert network.average_path_length(nx.Graph([(0, 1), (2, 3)])) == math.inf


@pytest.mark.parametrize("name", list(UNDIRECTED))
def test_algebraic_connectivity_matches_networkx(name):
    g = UNDIRECTED[name]
    expected = nx.linalg.algebraic_connectivity(g, weight="weight", method="tracemin_lu", tol=1e-12)
    for graph in (g, _scrambled_labels(g), _reference_adjacency(g)):
        assert network.algebraic_connectivity(graph) == pytest.approx(expected, rel=1e-8)


def test_algebraic_connectivity_closed_forms_and_weights():
    n = 8
    assert network.algebraic_connectivity(nx.cycle_graph(n)) == pytest.approx(2 - 2 * math.cos(2 * math.pi / n))
    assert network.algebraic_connectivity(nx.complete_graph(n)) == pytest.approx(n)
    assert network.algebraic_connectivity(nx.star_graph(n - 1)) == pytest.approx(1.0)
    assert network.algebraic_connectivity(nx.Graph([(0, 1), (2, 3)])) == 0.0
    # Weights scale the Laplacian, so λ2 scales with them (weights are used here).
    g = _random_connected()
    heavier = g.copy()
    for u, v in heavier.edges:
        heavier.edges[u, v]["weight"] *= 3.0
    assert network.algebraic_connectivity(heavier) == pytest.approx(3 * network.algebraic_connectivity(g), rel=1e-12)


def test_directed_algebraic_connectivity_is_min_real_part_of_in_degree_laplacian():
    g = _random_strongly_connected()
    # networkx's Laplacian uses out-degree; on the reversed graph it is the in-degree one of g
    # (the receiver's row sums its inputs).
    lap = nx.laplacian_matrix(g.reverse(), nodelist=list(g.nodes), weight="weight").toarray()
    eig = np.linalg.eigvals(lap)
    expected = np.delete(eig, np.argmin(np.abs(eig))).real.min()
    assert network.algebraic_connectivity(g) == pytest.approx(expected, rel=1e-9)
    # 0 → 1 → 2: L = [[0,0,0],[-1,1,0],[0,-1,1]], eigenvalues 0, 1, 1.
    assert network.algebraic_connectivity(nx.DiGraph([(0, 1), (1, 2)])) == pytest.approx(1.0)
    # Two roots transmit to one receiver: no spanning tree.
    assert network.algebraic_connectivity(nx.DiGraph([(0, 2), (1, 2)])) == 0.0


# --- reliability: closed forms ----------------------------------------------------------------


@pytest.mark.parametrize("k", [1, 2, 3, 5])
def test_two_terminal_series_path_is_p_to_the_k(k):
    p = 0.7
    r = network.two_terminal_reliability(nx.path_graph(k + 1), p, source=0, target=k)
    assert r.value == pytest.approx(p**k, abs=1e-14)
    assert (r.method, r.samples, r.std_error, r.ci_low, r.ci_high) == ("exact", 2**k, 0.0, r.value, r.value)
    # Directed: information flows 0 → k only.
    d = nx.DiGraph(nx.path_graph(k + 1, create_using=nx.DiGraph))
    assert network.two_terminal_reliability(d, p, 0, k).value == pytest.approx(p**k, abs=1e-14)
    assert network.two_terminal_reliability(d, p, k, 0).value == 0.0


@pytest.mark.parametrize("paths, length", [(2, 2), (2, 3), (3, 2), (3, 3), (4, 1)])
def test_two_terminal_parallel_paths(paths, length):
    # k disjoint paths of L links each: 1 − (1 − p^L)^k; e.g. two 2-link paths 1 − (1 − p²)².
    g = _theta(paths, length) if length > 1 else nx.Graph([(0, 1)])
    if length == 1:
        paths = 1  # a Graph has one edge per pair
    r = network.two_terminal_reliability(g, P, source=0, target=1)
    assert r.value == pytest.approx(1 - (1 - P**length) ** paths, abs=1e-13)
    assert r.samples == 2 ** (paths * length)


def test_two_terminal_mixed_and_bridge_closed_forms():
    # Triangle: a direct link parallel to a 2-link path.
    assert network.two_terminal_reliability(nx.cycle_graph(3), P, 0, 1).value == pytest.approx(
        1 - (1 - P) * (1 - P**2), abs=1e-14
    )
    # Two parallel 2-link paths (4-ring, opposite nodes).
    assert network.two_terminal_reliability(nx.cycle_graph(4), P, 0, 2).value == pytest.approx(
        1 - (1 - P**2) ** 2, abs=1e-14
    )
    # Wheatstone bridge: 2p⁵ − 5p⁴ + 2p³ + 2p².
    for p in (0.3, 0.8, 0.95):
        assert network.two_terminal_reliability(_bridge(), p, 0, 3).value == pytest.approx(
            2 * p**5 - 5 * p**4 + 2 * p**3 + 2 * p**2, abs=1e-14
        )
    # p = 1: always; p = 0: never.
    assert network.two_terminal_reliability(_bridge(), 1.0, 0, 3).value == 1.0
    assert network.two_terminal_reliability(_bridge(), 0.0, 0, 3).value == 0.0


@pytest.mark.parametrize(
    "tree", [nx.star_graph(6), nx.path_graph(7), nx.random_labeled_tree(9, seed=2)], ids=["star", "path", "random"]
)
def test_mean_pairwise_reliability_of_a_tree_is_mean_of_p_to_the_distance(tree):
    # One path per pair in a tree: P(i hears j) = p^d(i, j).
    n = tree.number_of_nodes()
    dist = dict(nx.all_pairs_shortest_path_length(tree))
    expected = sum(P ** dist[u][v] for u in tree for v in tree if u != v) / (n * (n - 1))
    rel = network.reliability(tree, P)
    assert rel.value == pytest.approx(expected, abs=1e-13)
    nodes = list(tree.nodes)
    for i, u in enumerate(nodes):
        for j, v in enumerate(nodes):
            if i != j:
                assert rel.per_pair[i, j] == pytest.approx(P ** dist[u][v], abs=1e-13)


def test_mean_pairwise_reliability_of_rings():
    # Undirected n-ring: nodes d apart are joined by two disjoint paths of d and n − d links.
    n = 7
    expected = np.mean([1 - (1 - P**d) * (1 - P ** (n - d)) for d in range(1, n)])
    rel = network.reliability(nx.cycle_graph(n), P)
    assert rel.value == pytest.approx(expected, abs=1e-13)
    assert (rel.method, rel.samples, rel.std_error) == ("exact", 2**n, 0.0)
    # Directed n-ring: one path, of d links, from a node d steps behind.
    ring = nx.cycle_graph(n, create_using=nx.DiGraph)
    assert network.reliability(ring, P).value == pytest.approx(np.mean([P**d for d in range(1, n)]), abs=1e-13)


# --- Monte Carlo against exact -----------------------------------------------------------------


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_monte_carlo_two_terminal_within_four_standard_errors(seed):
    for g, s, t in ((_bridge(), 0, 3), (_theta(3, 3), 0, 1)):
        exact = network.two_terminal_reliability(g, P, s, t)
        mc = network.two_terminal_reliability(g, P, s, t, method="monte-carlo", samples=20_000, seed=seed)
        assert (mc.method, mc.samples) == ("monte-carlo", 20_000)
        assert mc.std_error == pytest.approx(math.sqrt(exact.value * (1 - exact.value) / 20_000), rel=0.05)
        assert abs(mc.value - exact.value) < 4 * mc.std_error
        assert mc.ci_low < mc.value < mc.ci_high


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_monte_carlo_mean_pairwise_within_four_standard_errors(seed):
    for g in (nx.cycle_graph(7), _random_connected(8, 0.4, seed=1), _bridge()):
        exact = network.reliability(g, P, method="exact")
        mc = network.reliability(g, P, method="monte-carlo", samples=20_000, seed=seed)
        assert mc.method == "monte-carlo" and mc.std_error > 0
        assert abs(mc.value - exact.value) < 4 * mc.std_error
        assert mc.ci_low < mc.value < mc.ci_high
        # The interval is the normal one built on the same standard error.
        assert mc.ci_high - mc.ci_low == pytest.approx(2 * 1.959963984540054 * mc.std_error, rel=1e-9)


def test_monte_carlo_is_seeded_and_auto_switches_beyond_twenty_links():
    g = nx.cycle_graph(7)
    a = network.reliability(g, P, method="monte-carlo", samples=5_000, seed=7)
    b = network.reliability(g, P, method="monte-carlo", samples=5_000, seed=7)
    c = network.reliability(g, P, method="monte-carlo", samples=5_000, seed=8)
    assert a.value == b.value and a.value != c.value
    # Directed 25-ring: 25 links, so "auto" samples; closed form mean of p^d.
    n = 25
    ring = nx.cycle_graph(n, create_using=nx.DiGraph)
    mc = network.reliability(ring, P, samples=20_000, seed=3)
    assert (mc.method, mc.samples) == ("monte-carlo", 20_000)
    assert abs(mc.value - np.mean([P**d for d in range(1, n)])) < 4 * mc.std_error
    tt = network.two_terminal_reliability(ring, P, 0, 5, samples=20_000, seed=3)
    assert tt.method == "monte-carlo" and abs(tt.value - P**5) < 4 * tt.std_error


# --- networkx graph and adjacency array give identical results --------------------------------


@pytest.mark.parametrize(
    "g",
    [
        _random_connected(9, 0.4, seed=1),
        _scrambled_labels(_random_strongly_connected(7, 0.35)),
        # Two-way pair a↔b (one link), plus one-way links b → c and c → a.
        nx.DiGraph([("a", "b", {"weight": 1.0}), ("b", "a", {"weight": 2.0}), ("b", "c"), ("c", "a")]),
    ],
    ids=["undirected", "digraph", "mixed"],
)
def test_graph_and_adjacency_inputs_agree_exactly(g):
    a = _reference_adjacency(g)
    nodes = list(g.nodes)
    from_graph = network.topology_metrics(g, P)
    from_array = network.topology_metrics(a, P)
    assert from_graph.nodes == tuple(nodes) and from_array.nodes == tuple(range(len(nodes)))
    assert from_graph.n == from_array.n == len(nodes)
    assert from_graph.links == from_array.links
    assert from_graph.average_path_length == from_array.average_path_length
    assert from_graph.algebraic_connectivity == from_array.algebraic_connectivity
    assert from_graph.reliability.value == from_array.reliability.value
    np.testing.assert_array_equal(from_graph.reliability.per_pair, from_array.reliability.per_pair)
    assert from_graph.spanning_tree_roots == tuple(nodes[k] for k in from_array.spanning_tree_roots)
    assert from_graph.spanning_tree is from_array.spanning_tree is True
    # The separate functions agree with the bundle.
    assert network.average_path_length(g) == from_graph.average_path_length
    assert network.algebraic_connectivity(g) == from_graph.algebraic_connectivity
    assert network.reliability(g, P).value == from_graph.reliability.value
    for i, j in ((0, 1), (len(nodes) - 1, 0)):
        by_label = network.two_terminal_reliability(g, P, nodes[i], nodes[j])
        by_index = network.two_terminal_reliability(a, P, i, j)
        assert by_label == by_index
        # per_pair[r, s] = P(r hears s): target row, source column.
        assert by_label.value == pytest.approx(from_graph.reliability.per_pair[j, i], abs=1e-12)


def test_direction_and_link_model_of_a_digraph():
    g = nx.DiGraph([("a", "b", {"weight": 1.0}), ("b", "a", {"weight": 2.0}), ("b", "c"), ("c", "a")])
    tm = network.topology_metrics(g, P)
    assert tm.links == 3  # a↔b is one link
    # b hears a only over a↔b; a hears b directly or over b → c → a.
    assert network.two_terminal_reliability(g, P, "a", "b").value == pytest.approx(P, abs=1e-15)
    assert network.two_terminal_reliability(g, P, "b", "a").value == pytest.approx(1 - (1 - P) * (1 - P**2))
    one_way = network.topology_metrics(nx.DiGraph([("hub", "x"), ("hub", "y")]), P)
    assert one_way.spanning_tree_roots == ("hub",) and one_way.average_path_length == math.inf
    assert network.two_terminal_reliability(nx.DiGraph([("hub", "x")]), P, "x", "hub").value == 0.0


def test_weights_play_no_part_in_hops_or_reliability():
    g = _random_connected(9, 0.4, seed=1)
    unweighted = nx.Graph()
    unweighted.add_nodes_from(g.nodes)  # same node order
    unweighted.add_edges_from(g.edges)  # no weight attribute: 1
    assert network.average_path_length(g) == network.average_path_length(unweighted)
    assert network.reliability(g, P).value == network.reliability(unweighted, P).value


# --- bad input ----------------------------------------------------------------------------------

CALLS = {
    "average_path_length": lambda g: network.average_path_length(g),
    "reliability": lambda g: network.reliability(g, P),
    "two_terminal_reliability": lambda g: network.two_terminal_reliability(g, P, 0, 1),
    "algebraic_connectivity": lambda g: network.algebraic_connectivity(g),
    "topology_metrics": lambda g: network.topology_metrics(g, P),
}


def _weighted(w):
    return nx.Graph([(0, 1, {"weight": w}), (1, 2)])


BAD_GRAPHS = [
    (np.zeros((2, 3)), r"square n×n, got shape \(2, 3\)"),
    (np.zeros((2, 2, 2)), r"square n×n, got shape \(2, 2, 2\)"),
    (np.zeros((0, 0)), "no nodes"),
    ([], "square"),
    (nx.Graph(), "no nodes"),
    (nx.DiGraph(), "no nodes"),
    (np.array([[0.0, -1.0], [1.0, 0.0]]), r"A\[0, 1\] = -1 is negative"),
    (np.array([[0.0, 1.0], [np.nan, 0.0]]), r"A\[1, 0\] = nan is not finite"),
    (np.array([[0.0, np.inf], [1.0, 0.0]]), r"A\[0, 1\] = inf is not finite"),
    (np.array([[1.0, 1.0], [1.0, 0.0]]), r"A\[0, 0\] = 1 is a self-loop"),
    ([["a", "b"], ["c", "d"]], "numeric adjacency array"),
    ([[0, 1], [1]], "numeric adjacency array"),
    (_weighted(-2.0), r"edge 0 -- 1 has weight -2; weights must be > 0"),
    (_weighted(0.0), r"edge 0 -- 1 has weight 0; weights must be > 0"),
    (_weighted(float("nan")), r"edge 0 -- 1 has weight nan, not finite"),
    (_weighted("heavy"), r"edge 0 -- 1 has weight 'heavy', not a number"),
    (nx.DiGraph([("a", "a"), ("a", "b")]), r"self-loop on node 'a'"),
    (nx.MultiGraph([(0, 1), (0, 1)]), "multigraphs are not supported"),
    (np.zeros((1, 1)), "at least 2 nodes"),
    (nx.empty_graph(1), "at least 2 nodes"),
]


@pytest.mark.parametrize("call", list(CALLS))
@pytest.mark.parametrize("graph, match", BAD_GRAPHS, ids=[m.split(",")[0][:30] for _, m in BAD_GRAPHS])
def test_bad_graphs_raise_one_line_graph_error(call, graph, match):
    with pytest.raises(GraphError, match=match) as err:
        CALLS[call](graph)
    assert isinstance(err.value, ValueError) and "\n" not in str(err.value)


@pytest.mark.parametrize(
    "graph, source, target, match",
    [
        (np.ones((4, 4)) - np.eye(4), 5, 0, "source 5 is out of range: the graph's nodes are 0 … 3"),
        (np.ones((4, 4)) - np.eye(4), 0, -1, "target -1 is out of range"),
        (np.ones((4, 4)) - np.eye(4), 1.5, 0, "source 1.5 is not a node index"),
        (nx.path_graph(3), 0, 7, "target 7 is not a node of the graph"),
        (nx.Graph([("a", "b")]), "a", "z", "target 'z' is not a node of the graph"),
        (nx.Graph([("a", "b")]), ["a"], "b", r"source \['a'\] is not a node of the graph"),
        (nx.Graph([("a", "b")]), "a", "a", "source and target are the same node 'a'"),
        (np.ones((3, 3)) - np.eye(3), 2, 2, "same node 2"),
    ],
)
def test_bad_terminals_raise_graph_error(graph, source, target, match):
    with pytest.raises(GraphError, match=match) as err:
        network.two_terminal_reliability(graph, P, source, target)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"p": 1.5}, r"p must be a probability in \[0, 1\], got 1.5"),
        ({"p": -0.1}, "probability"),
        ({"p": float("nan")}, "probability"),
        ({"p": "0.8"}, "probability"),
        ({"method": "fast"}, "method must be 'auto', 'exact' or 'monte-carlo', got 'fast'"),
        ({"method": "monte-carlo", "samples": 1}, "samples >= 2, got 1"),
        ({"method": "monte-carlo", "samples": 10.5}, "integer number of samples"),
    ],
)
def test_bad_reliability_arguments_raise_graph_error(kwargs, match):
    args = {"p": P, **kwargs}
    p = args.pop("p")
    for call in (
        lambda: network.reliability(nx.cycle_graph(4), p, **args),
        lambda: network.two_terminal_reliability(nx.cycle_graph(4), p, 0, 2, **args),
        lambda: network.topology_metrics(nx.cycle_graph(4), p, **args),
    ):
        with pytest.raises(GraphError, match=match):
            call()


def test_exact_refused_beyond_twenty_links_and_auto_checks_samples():
    with pytest.raises(GraphError, match=r"m = 28 > 20"):
        network.reliability(nx.complete_graph(8), P, method="exact")
    # "auto" that falls back to Monte Carlo checks the sample count too.
    with pytest.raises(GraphError, match="samples >= 2"):
        network.reliability(nx.complete_graph(8), P, samples=1)
