"""Communication graphs of a formation: topology metrics of any graph.

Public functions (docs/api.md), each taking a *graph* given either as

* a networkx ``Graph`` (undirected: every edge is a two-way link) or ``DiGraph`` (an edge
  u → v means information flows from u to v: v hears u), with an optional numeric edge
  attribute ``weight`` (default 1, must be > 0); nodes are indexed in ``G.nodes`` order; or
* an adjacency array ``A`` of shape (n, n), ``A[i, j] > 0`` iff node i hears node j, with
  the link's weight; nodes are indexed 0 … n−1.

* :func:`average_path_length` → float: mean fewest hops between ordered pairs;
* :func:`reliability` → :class:`Reliability`: mean pairwise reliability with failing links;
* :func:`two_terminal_reliability` → :class:`TwoTerminalReliability`: P(target hears source);
* :func:`algebraic_connectivity` → float: λ2 of the Laplacian, the consensus rate;
* :func:`topology_metrics` → :class:`TopologyMetrics`: all of the above for one graph.

*Reliability* follows the link model of :mod:`coopsat.network.metrics`: every link works
independently with probability p (fails with probability 1 − p); a pair that hears each
other is one two-way link, failing both ways at once. Probabilities are computed exactly by
enumerating the 2^m link states (m ≤ 20 links) or by seeded Monte Carlo. Weights play no
part in hop counts or reliability; the algebraic connectivity uses them.

Bad input raises :class:`GraphError` (a ``ValueError``) with one line naming the cause.

The names load on first use: ``import coopsat.network`` imports neither NumPy, SciPy nor
networkx.

Examples
--------
>>> import networkx as nx
>>> from coopsat import network
>>> network.average_path_length(nx.star_graph(3))  # hub 0 and 3 leaves
1.5
>>> round(network.reliability(nx.star_graph(3), 0.8).value, 12)  # (0.8 + 0.8²) / 2
0.72
>>> r = network.two_terminal_reliability(nx.path_graph(3), 0.9, source=0, target=2)
>>> round(r.value, 12), r.method, r.samples  # series: p², 2 links, 4 states
(0.81, 'exact', 4)
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Literal, Union

if TYPE_CHECKING:  # for type checkers; at run time these load lazily (__getattr__)
    from collections.abc import Hashable

    import networkx as nx
    from numpy.typing import ArrayLike

    from coopsat.network.metrics import Reliability, TopologyMetrics, TwoTerminalReliability
    from coopsat.network.topology import GraphError

GraphLike = Union["nx.Graph", "ArrayLike"]
"""A networkx Graph/DiGraph or an adjacency array ``A[i, j]`` (i hears j), shape (n, n)."""

Method = Literal["auto", "exact", "monte-carlo"]
"""How reliabilities are computed: "auto" is exact for at most 20 links, else Monte Carlo."""

_LAZY = {
    "Reliability": "coopsat.network.metrics",
    "TwoTerminalReliability": "coopsat.network.metrics",
    "TopologyMetrics": "coopsat.network.metrics",
    "GraphError": "coopsat.network.topology",
}

__all__ = sorted(
    [
        "average_path_length",
        "reliability",
        "two_terminal_reliability",
        "algebraic_connectivity",
        "topology_metrics",
        "GraphLike",
        "Method",
        *_LAZY,
    ]
)


def __getattr__(name: str):
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value  # the next lookup is a plain attribute
        return value
    raise AttributeError(f"module 'coopsat.network' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))


def _metrics():
    return importlib.import_module("coopsat.network.metrics")


def average_path_length(graph: GraphLike) -> float:
    """Average shortest path along the information flow (SPEC §2 eq. 5).

    Parameters
    ----------
    graph : networkx.Graph, networkx.DiGraph or array_like, shape (n, n)
        The communication graph (module docstring), n ≥ 2 nodes. Weights are ignored.

    Returns
    -------
    float
        Mean over the n(n − 1) ordered pairs of the fewest hops (links) over which one node
        hears the other, in hops. ``inf`` when some node cannot hear some other even over
        relays (a disconnected graph; a directed one that is not strongly connected). For a
        connected undirected graph (or strongly connected DiGraph) this equals networkx's
        ``average_shortest_path_length``.

    Raises
    ------
    GraphError
        Malformed graph (see :func:`coopsat.network.metrics.as_adjacency`), or fewer than 2
        nodes.
    """
    m = _metrics()
    a, _ = m.as_adjacency(graph)
    return m.average_shortest_path(a)


def reliability(
    graph: GraphLike, p: float, *, method: Method = "auto", samples: int = 100_000, seed: int = 0
) -> Reliability:
    """Mean pairwise (all ordered pairs) reliability when links fail independently.

    ``R = (1 / (n(n−1))) Σ_{i≠j} P(i hears j)`` (SPEC §2 eq. 6), every link working with
    probability p and failing with probability 1 − p, independently of the others; i hears
    j when some path of working links carries j's information to i.

    Parameters
    ----------
    graph : networkx.Graph, networkx.DiGraph or array_like, shape (n, n)
        The communication graph (module docstring), n ≥ 2 nodes. Weights are ignored.
    p : float
        Probability that a link works, in [0, 1] (dimensionless).
    method : {"auto", "exact", "monte-carlo"}
        "exact" enumerates all 2^m link states (m ≤ 20 links); "monte-carlo" draws
        ``samples`` states; "auto" is exact when m ≤ 20, else Monte Carlo.
    samples : int
        Monte Carlo link states drawn (≥ 2); unused when exact.
    seed : int
        Seed of ``numpy.random.default_rng`` for Monte Carlo: the same seed gives the same
        value.

    Returns
    -------
    Reliability
        Frozen: ``value``; ``method`` ("exact" or "monte-carlo"); ``samples`` (2^m when
        exact); ``std_error`` (0 when exact); the 95 % interval ``ci_low``, ``ci_high``;
        ``per_pair`` (n, n) with ``per_pair[i, j]`` = P(node i hears node j), nodes in
        index order, nan on the diagonal.

    Raises
    ------
    GraphError
        Malformed graph, fewer than 2 nodes, p outside [0, 1], an unknown method, "exact"
        with more than 20 links, or fewer than 2 Monte Carlo samples.
    """
    m = _metrics()
    a, _ = m.as_adjacency(graph)
    return m.mean_pairwise_reliability(a, p, method=method, samples=samples, seed=seed)


def two_terminal_reliability(
    graph: GraphLike,
    p: float,
    source: Hashable,
    target: Hashable,
    *,
    method: Method = "auto",
    samples: int = 100_000,
    seed: int = 0,
) -> TwoTerminalReliability:
    """Probability that ``target`` hears ``source`` when links fail independently.

    Every link works with probability p and fails with probability 1 − p, independently;
    the result is P(some path of working links carries ``source``'s information to
    ``target``), relays allowed.

    Parameters
    ----------
    graph : networkx.Graph, networkx.DiGraph or array_like, shape (n, n)
        The communication graph (module docstring), n ≥ 2 nodes. Weights are ignored.
    p : float
        Probability that a link works, in [0, 1].
    source, target : node
        Transmitting and receiving node, distinct: node labels of a networkx graph, indices
        in [0, n) of an array.
    method, samples, seed
        As :func:`reliability`.

    Returns
    -------
    TwoTerminalReliability
        Frozen: ``value``, ``method``, ``samples``, ``std_error`` (0 when exact, else
        ``√(value (1 − value) / samples)``), 95 % interval ``ci_low``, ``ci_high``.

    Raises
    ------
    GraphError
        As :func:`reliability`; also a source or target that is not a node of the graph
        (out of range for an array), or source == target.
    """
    m = _metrics()
    a, nodes = m.as_adjacency(graph)
    if len(nodes) < 2:
        raise m.GraphError(f"network: need at least 2 nodes for two-terminal reliability, got {len(nodes)}")
    from_array = not _is_networkx(graph)
    s = m.node_index(nodes, source, "source", from_array)
    t = m.node_index(nodes, target, "target", from_array)
    if s == t:
        raise m.GraphError(f"network: source and target are the same node {source!r}")
    return m.two_terminal_result(a, p, s, t, method=method, samples=samples, seed=seed)


def algebraic_connectivity(graph: GraphLike) -> float:
    """Algebraic connectivity: the consensus convergence rate of the graph.

    Parameters
    ----------
    graph : networkx.Graph, networkx.DiGraph or array_like, shape (n, n)
        The communication graph (module docstring), n ≥ 2 nodes, weights used.

    Returns
    -------
    float
        Of the in-degree Laplacian ``L = diag(A·1) − A``: for an undirected graph the
        Fiedler value λ2 (second smallest eigenvalue; equals networkx's
        ``algebraic_connectivity``); for a directed one ``min Re λ`` over the nonzero modes.
        0 when the graph has no directed spanning tree (undirected: is disconnected). In the
        units of the weights (with consensus gains in 1/s, a rate in 1/s; unit weights:
        dimensionless). See :func:`coopsat.network.metrics.algebraic_connectivity`.

    Raises
    ------
    GraphError
        Malformed graph, or fewer than 2 nodes.
    """
    m = _metrics()
    a, _ = m.as_adjacency(graph)
    return m.algebraic_connectivity(a)


def topology_metrics(
    graph: GraphLike, p: float, *, method: Method = "auto", samples: int = 100_000, seed: int = 0
) -> TopologyMetrics:
    """Every topology metric of one graph (SPEC §2 Table 1): one row of ``coopsat topology``.

    Parameters
    ----------
    graph : networkx.Graph, networkx.DiGraph or array_like, shape (n, n)
        The communication graph (module docstring), n ≥ 2 nodes.
    p : float
        Probability that a link works, in [0, 1], for the reliability.
    method, samples, seed
        As :func:`reliability`.

    Returns
    -------
    TopologyMetrics
        Frozen: ``nodes`` (labels in index order), ``n``, ``links`` (a two-way pair counts
        once), ``average_path_length`` (hops), ``reliability`` (:class:`Reliability`),
        ``algebraic_connectivity``, ``spanning_tree_roots`` (labels) and ``spanning_tree``.

    Raises
    ------
    GraphError
        As :func:`reliability`.
    """
    m = _metrics()
    a, nodes = m.as_adjacency(graph)
    rel = m.mean_pairwise_reliability(a, p, method=method, samples=samples, seed=seed)
    return m.TopologyMetrics(
        nodes=nodes,
        links=m.count_links(a),
        average_path_length=m.average_shortest_path(a),
        reliability=rel,
        algebraic_connectivity=m.algebraic_connectivity(a),
        spanning_tree_roots=tuple(nodes[k] for k in m.spanning_tree_roots(a)),
    )


def _is_networkx(graph) -> bool:
    import networkx as nx

    return isinstance(graph, nx.Graph)
