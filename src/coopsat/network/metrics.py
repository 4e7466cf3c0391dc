"""Topology metrics: average shortest path, link-failure reliability, algebraic connectivity.

SPEC §2 "Topology analysis" (paper Table 1, eqs. 5–6). Direction convention as in
:mod:`coopsat.network.topology`: ``A[i, j] > 0`` iff i hears j, information flows j → i.
Every metric here is read along the information flow, so for an undirected (symmetric)
adjacency each reduces to its usual undirected definition.

Link model for reliability: each *link* works independently with probability p. An unordered
pair {i, j} with ``A[i, j] > 0`` and ``A[j, i] > 0`` is ONE link that carries both ways (it
fails both ways at once); a pair heard one way only is a directed link. Weights play no part
in the reliability or the hop counts; the algebraic connectivity uses them.

The functions here take adjacency arrays. :func:`as_adjacency` turns a networkx graph (or an
array) into one, and the result types :class:`TwoTerminalReliability` and
:class:`TopologyMetrics` serve the public functions of :mod:`coopsat.network`, which accept
either. Bad input raises :class:`~coopsat.network.topology.GraphError` (a ``ValueError``).

Design-time code (NumPy/SciPy/networkx).
"""

import math
import numbers
import operator
from dataclasses import dataclass

import networkx as nx
import numpy as np
from scipy.sparse.csgraph import shortest_path

from coopsat.network.topology import GraphError, laplacian, spanning_tree_roots, validate_adjacency

MAX_EXACT_LINKS = 20
"""Largest number of links whose 2^m link states ``method="auto"`` enumerates exactly."""

_Z95 = 1.959963984540054  # standard normal 97.5 % quantile: two-sided 95 % interval
_CHUNK_CELLS = 1 << 22  # states × n² booleans per chunk of the reachability computation


@dataclass(frozen=True)
class Reliability:
    """Mean pairwise (all-terminal-pairs) reliability of a graph with failing links.

    Attributes
    ----------
    value : float
        Mean over ordered pairs (i ≠ j) of P(i hears j over working links), in [0, 1].
    method : str
        "exact" (all 2^m link states enumerated) or "monte-carlo".
    ci_low, ci_high : float
        95 % confidence interval for ``value``; both equal ``value`` when exact.
    samples : int
        Link states evaluated: 2^m when exact, the Monte Carlo sample count otherwise.
    per_pair : ndarray, shape (n, n), read-only
        ``per_pair[i, j]`` = P(i hears j) (same orientation as the adjacency); nan on the
        diagonal.
    std_error : float
        Standard error of ``value``: 0 when exact; for Monte Carlo ``std(X_s) / √samples``,
        X_s the fraction of ordered pairs connected in sampled state s.
    """

    value: float
    method: str
    ci_low: float
    ci_high: float
    samples: int
    per_pair: np.ndarray
    std_error: float = 0.0

    def __post_init__(self):
        if isinstance(self.per_pair, np.ndarray):
            self.per_pair.flags.writeable = False  # frozen means frozen: the array too


@dataclass(frozen=True)
class TwoTerminalReliability:
    """Probability that one node hears another over independently failing links.

    Attributes
    ----------
    value : float
        P(target hears source, possibly relayed), in [0, 1].
    method : str
        "exact" (all 2^m link states enumerated) or "monte-carlo".
    samples : int
        Link states evaluated: 2^m when exact, the Monte Carlo sample count otherwise.
    std_error : float
        Standard error of ``value``: 0 when exact; for Monte Carlo the binomial one,
        ``√(value (1 − value) / samples)``.
    ci_low, ci_high : float
        95 % interval ``value ± 1.96 · std_error`` clipped to [0, 1]; both equal ``value``
        when exact (and when Monte Carlo saw the pair always, or never, connected).
    """

    value: float
    method: str
    samples: int
    std_error: float
    ci_low: float
    ci_high: float


@dataclass(frozen=True)
class TopologyMetrics:
    """Every topology metric of one graph (SPEC §2 Table 1).

    Attributes
    ----------
    nodes : tuple
        Node labels in index order: ``G.nodes`` order for a networkx graph, ``0 … n−1`` for
        an adjacency array. Row/column k of ``reliability.per_pair`` is ``nodes[k]``.
    links : int
        Number of links m of the reliability model (a two-way pair counts once).
    average_path_length : float
        Mean fewest hops over ordered pairs along the information flow; ``inf`` when some
        node cannot hear some other (see :func:`average_shortest_path`).
    reliability : Reliability
        Mean pairwise reliability (see :func:`mean_pairwise_reliability`).
    algebraic_connectivity : float
        See :func:`algebraic_connectivity`; in the units of the edge weights.
    spanning_tree_roots : tuple
        Labels of the nodes whose information reaches every node; empty when the graph has
        no directed spanning tree (undirected: is disconnected).
    """

    nodes: tuple
    links: int
    average_path_length: float
    reliability: Reliability
    algebraic_connectivity: float
    spanning_tree_roots: tuple

    @property
    def n(self) -> int:
        """Number of nodes."""
        return len(self.nodes)

    @property
    def spanning_tree(self) -> bool:
        """True when some node's information reaches every node (consensus is possible)."""
        return bool(self.spanning_tree_roots)


def _first(mask):
    """(i, j) of the first True entry of a 2-D mask, row-major."""
    i, j = np.argwhere(mask)[0]
    return int(i), int(j)


def as_adjacency(graph):
    """Adjacency array and node labels of a networkx graph or an adjacency array.

    Parameters
    ----------
    graph : networkx.Graph, networkx.DiGraph or array_like, shape (n, n)
        A networkx ``Graph`` (undirected: every edge a two-way link) or ``DiGraph`` (edge
        u → v: information flows from u to v, v hears u), with an optional numeric edge
        attribute ``weight`` (default 1), nodes taken in ``G.nodes`` order; or an adjacency
        array, ``A[i, j] > 0`` iff i hears j, with the link's weight.

    Returns
    -------
    a : ndarray of float, shape (n, n)
        ``a[i, j]`` = weight of the link on which ``nodes[i]`` hears ``nodes[j]``, 0 if none.
    nodes : tuple
        Node labels in index order (``tuple(range(n))`` for an array).

    Raises
    ------
    GraphError
        One line naming the cause: no nodes; an array that is not square n×n or not numeric;
        an entry that is NaN/inf, negative or on the diagonal; a self-loop; an edge weight
        that is not a finite number > 0; a multigraph.
    """
    if isinstance(graph, nx.Graph):
        return _graph_adjacency(graph)
    try:
        a = np.asarray(graph, dtype=float)
    except (TypeError, ValueError) as err:
        why = str(err).splitlines()[0]
        raise GraphError(f"network: not a networkx graph or a numeric adjacency array ({why})") from None
    if a.ndim != 2 or a.shape[0] != a.shape[1]:
        raise GraphError(f"network: an adjacency array must be square n×n, got shape {a.shape}")
    if a.shape[0] == 0:
        raise GraphError("network: the graph has no nodes")
    if not np.all(np.isfinite(a)):
        i, j = _first(~np.isfinite(a))
        raise GraphError(f"network: adjacency entry A[{i}, {j}] = {a[i, j]} is not finite")
    if np.any(a < 0.0):
        i, j = _first(a < 0.0)
        raise GraphError(
            f"network: adjacency entry A[{i}, {j}] = {a[i, j]:g} is negative (weights are >= 0, 0 for no link)"
        )
    if np.any(np.diag(a) != 0.0):
        i = int(np.flatnonzero(np.diag(a))[0])
        raise GraphError(
            f"network: adjacency entry A[{i}, {i}] = {a[i, i]:g} is a self-loop (the diagonal must be zero)"
        )
    return a, tuple(range(a.shape[0]))


def _graph_adjacency(g):
    if g.is_multigraph():
        raise GraphError("network: multigraphs are not supported; give a Graph or DiGraph with one edge per link")
    nodes = tuple(g.nodes)
    if not nodes:
        raise GraphError("network: the graph has no nodes")
    index = {u: k for k, u in enumerate(nodes)}
    directed = g.is_directed()
    arrow = "->" if directed else "--"
    a = np.zeros((len(nodes), len(nodes)))
    for u, v, w in g.edges(data="weight", default=1.0):
        if u == v:
            raise GraphError(f"network: self-loop on node {u!r} (a spacecraft does not hear itself)")
        try:
            weight = float(w)
        except (TypeError, ValueError):
            raise GraphError(f"network: edge {u!r} {arrow} {v!r} has weight {w!r}, not a number") from None
        if not math.isfinite(weight):
            raise GraphError(f"network: edge {u!r} {arrow} {v!r} has weight {weight}, not finite")
        if weight <= 0.0:
            raise GraphError(
                f"network: edge {u!r} {arrow} {v!r} has weight {weight:g}; weights must be > 0 (remove the edge for no link)"
            )
        a[index[v], index[u]] = weight  # v hears u
        if not directed:
            a[index[u], index[v]] = weight
    return a, nodes


def node_index(nodes, label, role, from_array):
    """Index of node ``label`` in ``nodes`` (see :func:`as_adjacency`); GraphError if absent.

    ``role`` ("source", "target") names the argument in the message; ``from_array`` says
    whether the graph was an array (labels are indices ``0 … n−1``).
    """
    if from_array:
        try:
            k = operator.index(label)
        except TypeError:
            raise GraphError(f"network: {role} {label!r} is not a node index (an int in [0, {len(nodes)}))") from None
        if not 0 <= k < len(nodes):
            raise GraphError(f"network: {role} {k} is out of range: the graph's nodes are 0 … {len(nodes) - 1}")
        return k
    try:
        return nodes.index(label)
    except ValueError:
        raise GraphError(f"network: {role} {label!r} is not a node of the graph") from None


def _adjacency(a):
    a = validate_adjacency(a)
    if a.shape[0] < 2:
        raise GraphError(f"metrics: need at least 2 nodes for pairwise metrics, got {a.shape[0]}")
    return a


def _link_incidence(a):
    """Which heard pairs each link enables.

    Returns
    -------
    ndarray of bool, shape (m, n, n)
        ``e[l, i, j]`` is True iff link l, when working, lets i hear j. A two-way link
        sets two entries, a directed link one.
    """
    n = a.shape[0]
    heard = a > 0.0
    both = heard & heard.T
    rows = []
    for i, j in zip(*np.nonzero(np.triu(both))):
        e = np.zeros((n, n), dtype=bool)
        e[i, j] = e[j, i] = True
        rows.append(e)
    for i, j in zip(*np.nonzero(heard & ~both)):
        e = np.zeros((n, n), dtype=bool)
        e[i, j] = True
        rows.append(e)
    return np.array(rows, dtype=bool).reshape(len(rows), n, n)


def count_links(a):
    """Number of links m under the reliability link model (a two-way pair counts once)."""
    return _link_incidence(validate_adjacency(a)).shape[0]


def _reachability(states, incidence):
    """Transitive closure of the heard relation for a batch of link states.

    Parameters
    ----------
    states : ndarray of bool, shape (C, m)
        Working links of each state.
    incidence : ndarray of bool, shape (m, n, n)

    Returns
    -------
    ndarray of bool, shape (C, n, n)
        ``r[c, i, j]``: in state c, information from j reaches i (``r[c, i, i]`` True).

    Notes
    -----
    Warshall's algorithm vectorised over the states: after step k, ``r[i, j]`` is True iff a
    path from j to i exists through intermediate nodes < k+1 (Warshall, 1962).
    """
    m, n, _ = incidence.shape
    r = (states.astype(np.float32) @ incidence.reshape(m, n * n).astype(np.float32)).reshape(-1, n, n) > 0
    r[:, np.arange(n), np.arange(n)] = True
    for k in range(n):
        r |= r[:, :, k : k + 1] & r[:, k : k + 1, :]
    return r


def _state_chunks(m, n, p, method, samples, seed):
    """Link states in chunks: (states (C, m) bool, weights (C,) summing to 1 over all chunks)."""
    chunk = max(1, _CHUNK_CELLS // (n * n))
    if method == "exact":
        total = 1 << m
        bits = np.arange(m)
        for start in range(0, total, chunk):
            k = np.arange(start, min(start + chunk, total), dtype=np.int64)
            states = ((k[:, None] >> bits) & 1).astype(bool)
            up = states.sum(axis=1)
            yield states, np.power(p, up) * np.power(1.0 - p, m - up)
    else:
        rng = np.random.default_rng(seed)
        for start in range(0, samples, chunk):
            c = min(chunk, samples - start)
            yield rng.random((c, m)) < p, np.full(c, 1.0 / samples)


def _choose_method(m, method, p, samples):
    """The method to run ("exact" or "monte-carlo"); GraphError (a ValueError) on bad arguments."""
    if not (isinstance(p, numbers.Real) and 0.0 <= p <= 1.0):
        raise GraphError(f"metrics: link reliability p must be a probability in [0, 1], got {p!r}")
    if method == "auto":
        method = "exact" if m <= MAX_EXACT_LINKS else "monte-carlo"
    elif method == "exact":
        if m > MAX_EXACT_LINKS:
            raise GraphError(f"metrics: exact reliability enumerates 2^m states; m = {m} > {MAX_EXACT_LINKS}")
    elif method != "monte-carlo":
        raise GraphError(f"metrics: method must be 'auto', 'exact' or 'monte-carlo', got {method!r}")
    if method == "monte-carlo":
        if isinstance(samples, bool) or not isinstance(samples, numbers.Integral) or samples < 2:
            raise GraphError(f"metrics: Monte Carlo needs an integer number of samples >= 2, got {samples!r}")
    return method


def average_shortest_path(a):
    """Average shortest path along the information flow (SPEC §2 eq. 5).

    Parameters
    ----------
    a : array_like, shape (n, n)
        Adjacency, ``A[i, j] > 0`` iff i hears j; weights ignored (hops only). n ≥ 2.

    Returns
    -------
    float
        Mean over the n(n − 1) ordered pairs (i ≠ j) of the fewest hops from j to i, hops.
        ``inf`` when some i cannot hear some j even over relays (disconnected graph, or a
        directed one without a path both ways between every pair).

    Notes
    -----
    For an undirected graph this is the usual average shortest path length
    ``(1 / (n(n−1))) Σ_{i≠j} d(i, j)``. Breadth-first search by
    ``scipy.sparse.csgraph.shortest_path`` on ``Aᵀ`` (csgraph's ``M[u, v]`` is an edge u→v).
    """
    a = _adjacency(a)
    n = a.shape[0]
    hops = shortest_path(np.ascontiguousarray((a > 0.0).T, dtype=float), directed=True, unweighted=True)
    return float(hops[~np.eye(n, dtype=bool)].mean())


def mean_pairwise_reliability(a, p, method="auto", samples=100_000, seed=0):
    """Mean two-terminal reliability over ordered pairs with independently failing links.

    SPEC §2 eq. 6, read as ``(1 / (n(n−1))) Σ_{i≠j} P(i hears j)`` with each link working
    with probability p (link model in the module docstring).

    Parameters
    ----------
    a : array_like, shape (n, n)
        Adjacency, ``A[i, j] > 0`` iff i hears j. n ≥ 2.
    p : float
        Probability that a link works, in [0, 1].
    method : {"auto", "exact", "monte-carlo"}
        "exact" enumerates all 2^m link states (m ≤ ``MAX_EXACT_LINKS``); "auto" does so when
        m ≤ ``MAX_EXACT_LINKS``, else Monte Carlo.
    samples : int
        Monte Carlo link states drawn.
    seed : int
        Seed of ``numpy.random.default_rng`` for Monte Carlo.

    Returns
    -------
    Reliability

    Notes
    -----
    Exact: ``Σ_states p^{up} (1 − p)^{m − up} · reach(state)``, reachability by Warshall's
    transitive closure vectorised over the states. Monte Carlo: each sampled state s gives
    ``X_s``, the fraction of ordered pairs connected in it; ``value`` is the mean of X_s and
    the 95 % interval is the normal (central-limit) one, ``value ± 1.96 · std(X_s) / √N``
    with the sample standard deviation. Wilson's interval is not used because X_s is not a
    Bernoulli variable (the pairs of one state are correlated); ``std(X_s)`` is at most
    ``√(v(1 − v))``. The interval is clipped to [0, 1].
    """
    a = _adjacency(a)
    n = a.shape[0]
    incidence = _link_incidence(a)
    m = incidence.shape[0]
    method = _choose_method(m, method, p, samples)
    per_pair = np.zeros(n * n)
    x_sum = x_sq = 0.0
    for states, weights in _state_chunks(m, n, p, method, samples, seed):
        reach = _reachability(states, incidence).reshape(len(states), n * n)
        per_pair += weights @ reach
        if method == "monte-carlo":
            x = (reach.sum(axis=1) - n) / (n * (n - 1))
            x_sum += x.sum()
            x_sq += x @ x
    per_pair = per_pair.reshape(n, n)
    per_pair[np.arange(n), np.arange(n)] = np.nan
    value = float(np.nanmean(per_pair))
    if method == "exact":
        return Reliability(value, "exact", value, value, 1 << m, per_pair)
    std = np.sqrt(max(x_sq - x_sum**2 / samples, 0.0) / (samples - 1))
    se = float(std / np.sqrt(samples))
    half = _Z95 * se
    return Reliability(value, "monte-carlo", max(0.0, value - half), min(1.0, value + half), int(samples), per_pair, se)


def two_terminal_reliability(a, p, source, target, method="auto", samples=100_000, seed=0):
    """Probability that ``target`` hears ``source`` over working links (possibly relayed).

    Parameters
    ----------
    a, p
        Adjacency ``(n, n)`` and link probability, as :func:`mean_pairwise_reliability`.
    source, target : int
        Transmitting and receiving node, ``source != target``.
    method, samples, seed
        As :func:`mean_pairwise_reliability`.

    Returns
    -------
    float
        The probability, in [0, 1]; for Monte Carlo the fraction of sampled link states in
        which ``target`` hears ``source`` (standard error ``√(v(1 − v) / samples)``).
        :func:`two_terminal_result` returns it with its method, sample count and error.
    """
    return two_terminal_result(a, p, source, target, method=method, samples=samples, seed=seed).value


def two_terminal_result(a, p, source, target, method="auto", samples=100_000, seed=0):
    """:func:`two_terminal_reliability` as a :class:`TwoTerminalReliability` (same arguments)."""
    a = _adjacency(a)
    n = a.shape[0]
    if source == target or not (0 <= source < n and 0 <= target < n):
        raise GraphError(f"metrics: need two distinct nodes in [0, {n}), got source {source}, target {target}")
    incidence = _link_incidence(a)
    m = incidence.shape[0]
    method = _choose_method(m, method, p, samples)
    total = 0.0
    for states, weights in _state_chunks(m, n, p, method, samples, seed):
        total += weights @ _reachability(states, incidence)[:, target, source]
    value = min(1.0, max(0.0, float(total)))  # exact sums may round a hair outside [0, 1]
    if method == "exact":
        return TwoTerminalReliability(value, "exact", 1 << m, 0.0, value, value)
    se = math.sqrt(value * (1.0 - value) / samples)
    return TwoTerminalReliability(value, "monte-carlo", int(samples), se, max(0.0, value - _Z95 * se),
                                  min(1.0, value + _Z95 * se))


def algebraic_connectivity(a):
    """Algebraic connectivity of ``L = diag(A·1) − A`` (in-degree Laplacian).

    Parameters
    ----------
    a : array_like, shape (n, n)
        Weighted adjacency, ``A[i, j] > 0`` iff i hears j. n ≥ 2.

    Returns
    -------
    float
        Undirected (symmetric A): the Fiedler value λ2, the second smallest eigenvalue of L.
        Directed: ``min Re λ`` over the eigenvalues of L other than the one zero eigenvalue
        (the zero mode, eigenvector 1). 0 when the graph has no directed spanning tree
        (undirected: is disconnected), where zero is a repeated eigenvalue.

    Notes
    -----
    ``L·1 = 0`` always, so 0 is an eigenvalue; it is simple iff the graph has a directed
    spanning tree, and then the other eigenvalues have positive real parts and the slowest
    non-consensus mode of ``ẋ = −L x`` decays as ``exp(−min Re λ · t)`` (Olfati-Saber, Fax &
    Murray, 2007, Proc. IEEE 95(1)). For a symmetric L this equals Fiedler's λ2 (Fiedler,
    1973). Other directed definitions exist (e.g. Wu, 2005, via ``min xᵀLx`` over x ⊥ 1);
    this one is the consensus convergence rate.
    """
    a = _adjacency(a)
    if not spanning_tree_roots(a):
        return 0.0
    lap = laplacian(a)
    if np.array_equal(a, a.T):
        return float(np.linalg.eigvalsh(lap)[1])
    eig = np.linalg.eigvals(lap)
    nonzero_modes = np.delete(eig, np.argmin(np.abs(eig)))
    return float(nonzero_modes.real.min())


def topology_table(graphs, p, method="auto", samples=100_000, seed=0):
    """One row of metrics per graph (SPEC §2 Table 1).

    Parameters
    ----------
    graphs : dict of str to array_like (n, n)
        Name → adjacency (``A[i, j] > 0`` iff i hears j).
    p : float
        Probability that a link works, in [0, 1].
    method, samples, seed
        As :func:`mean_pairwise_reliability`.

    Returns
    -------
    list of dict
        Per graph, in the dict's order: ``name``, ``n``, ``links`` (m, a two-way pair
        counted once), ``average_shortest_path`` (hops, inf if some pair is unreachable),
        ``reliability``, ``reliability_method``, ``reliability_ci_low``,
        ``reliability_ci_high``, ``algebraic_connectivity``, ``spanning_tree`` (bool).
        Plain Python scalars, ready to print or tabulate.
    """
    rows = []
    for name, a in graphs.items():
        a = _adjacency(a)
        rel = mean_pairwise_reliability(a, p, method=method, samples=samples, seed=seed)
        rows.append(
            {
                "name": name,
                "n": int(a.shape[0]),
                "links": count_links(a),
                "average_shortest_path": average_shortest_path(a),
                "reliability": rel.value,
                "reliability_method": rel.method,
                "reliability_ci_low": rel.ci_low,
                "reliability_ci_high": rel.ci_high,
                "algebraic_connectivity": algebraic_connectivity(a),
                "spanning_tree": bool(spanning_tree_roots(a)),
            }
        )
    return rows
