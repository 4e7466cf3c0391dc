"""Communication graphs: construction, adjacency, Laplacian, spanning-tree check.

Direction convention, fixed here once for the whole package (DESIGN §3):

* an edge ``(j, i)`` means **j transmits to i** (i hears j);
* ``A[i, j] > 0`` iff i hears j, with the link's weight;
* ``L = diag(A·1) − A`` (row sums: in-degree), so a consensus law ``−Σ_j a_ij (x_i − x_j)``
  is ``−(L ⊗ I) x``.

networkx's ``directed_laplacian``/``laplacian_matrix`` on a DiGraph use out-degree; we build
``L`` from ``A`` directly instead. Design-time code (NumPy/networkx); the compiled loop gets the
edge arrays of :class:`Links`.
"""

from dataclasses import dataclass

import numpy as np

from coopsat.core.errors import InputError


class GraphError(InputError):
    """A graph that is malformed or cannot do what the scenario asks of it."""


@dataclass(frozen=True)
class Links:
    """A weighted directed graph as index arrays, the form the compiled loop consumes.

    Two layouts, chosen by :func:`links_from_adjacency`:

    * *edge list*: ``src``, ``dst``, ``weight`` of shape (E,), sorted by receiver; sums over
      the edges into a spacecraft are segment sums;
    * *padded in-neighbour table*: shape (d, n), d the largest in-degree: column i lists whom
      spacecraft i hears (``dst[:, i] = i``); unused slots have weight 0 and point at i
      itself. Sums are over axis 0, with no scatter: faster when degrees are alike (rings,
      complete graphs), wasteful for hubs (an undirected star's hub hears n − 1).

    Attributes
    ----------
    src : ndarray of int, shape (E,) or (d, n)
        Transmitting spacecraft index j of each link.
    dst : ndarray of int, shape (E,) or (d, n)
        Receiving spacecraft index i of each link.
    weight : ndarray of float, shape (E,) or (d, n)
        ``a_ij`` of each link (0 for padding).
    n : int
        Number of spacecraft (nodes), including any that hear nobody.
    """

    src: np.ndarray
    dst: np.ndarray
    weight: np.ndarray
    n: int


def _check_n(n):
    if n < 1:
        raise GraphError(f"network: need at least one spacecraft, got {n}")


def ring_adjacency(n, directed=False):
    """Ring 0–1–…–(n−1)–0; directed: i hears i−1 (information flows 0→1→…→0).

    Returns
    -------
    ndarray, shape (n, n)
        Unit-weight adjacency ``A[i, j]`` (i hears j).
    """
    _check_n(n)
    a = np.zeros((n, n))
    if n == 1:
        return a
    idx = np.arange(n)
    a[idx, (idx - 1) % n] = 1.0
    if not directed:
        a[idx, (idx + 1) % n] = 1.0
    return a


def chain_adjacency(n, directed=False):
    """Chain 0–1–…–(n−1); directed: i hears i−1 (0 is the root). Shape (n, n)."""
    _check_n(n)
    a = np.zeros((n, n))
    idx = np.arange(1, n)
    a[idx, idx - 1] = 1.0
    if not directed:
        a[idx - 1, idx] = 1.0
    return a


def star_adjacency(n, directed=False, hub=0):
    """Star around ``hub``; directed: every other node hears the hub only. Shape (n, n)."""
    _check_n(n)
    a = np.zeros((n, n))
    others = np.array([k for k in range(n) if k != hub], dtype=int)
    a[others, hub] = 1.0
    if not directed:
        a[hub, others] = 1.0
    return a


def complete_adjacency(n):
    """Complete graph, every node hears every other with weight 1. Shape (n, n)."""
    _check_n(n)
    return np.ones((n, n)) - np.eye(n)


NAMED_GRAPHS = {
    "ring": ring_adjacency,
    "chain": chain_adjacency,
    "star": star_adjacency,
    "complete": lambda n, directed=False: complete_adjacency(n),
}


def adjacency_from_edges(n, edges, directed):
    """Adjacency from ``(j, i, weight)`` triples; undirected edges are added both ways.

    Parameters
    ----------
    n : int
    edges : iterable of (int, int, float)
        Transmitter j, receiver i, weight a_ij > 0.
    directed : bool

    Returns
    -------
    ndarray, shape (n, n)
    """
    a = np.zeros((n, n))
    for j, i, w in edges:
        if i == j:
            raise GraphError(f"network.edges: self-loop on spacecraft {i} (a spacecraft does not hear itself)")
        if not w > 0.0:
            raise GraphError(f"network.edges: weight of edge {j}->{i} must be > 0, got {w}")
        a[i, j] = w
        if not directed:
            a[j, i] = w
    return a


def validate_adjacency(a):
    """Check an adjacency matrix: square, finite, non-negative, zero diagonal.

    Returns
    -------
    ndarray, shape (n, n), float
    """
    a = np.asarray(a, dtype=float)
    if a.ndim != 2 or a.shape[0] != a.shape[1]:
        raise GraphError(f"network.adjacency: must be a square n×n matrix, got shape {a.shape}")
    if not np.all(np.isfinite(a)) or np.any(a < 0.0):
        raise GraphError("network.adjacency: entries must be finite and >= 0")
    if np.any(np.diag(a) != 0.0):
        raise GraphError("network.adjacency: diagonal must be zero (a spacecraft does not hear itself)")
    return a


def laplacian(a):
    """Graph Laplacian ``L = diag(A·1) − A`` (in-degree convention), shape (n, n)."""
    a = np.asarray(a, dtype=float)
    return np.diag(a.sum(axis=1)) - a


def links_from_adjacency(a, layout="auto"):
    """Index arrays of ``A`` for the compiled loop (:func:`links_from_edges` of its nonzeros).

    Parameters
    ----------
    a : array_like, shape (n, n)
    layout : {"auto", "edges", "padded"}
        As :func:`links_from_edges`.

    Returns
    -------
    Links
    """
    a = np.asarray(a, dtype=float)
    dst, src = np.nonzero(a)  # row-major: sorted by dst (= i), then src
    return links_from_edges(src, dst, a[dst, src], a.shape[0], layout)


def links_from_edges(src, dst, weight, n, layout="auto"):
    """Index arrays of a graph given as an edge list, for the compiled loop: memory linear in
    the edges, no n × n matrix (a formation of a million spacecraft).

    Parameters
    ----------
    src, dst : array_like of int, shape (E,)
        Transmitter j and receiver i of each link (i hears j), each pair once.
    weight : array_like, shape (E,)
        ``a_ij`` of each link, > 0.
    n : int
        Number of spacecraft.
    layout : {"auto", "edges", "padded"}
        "auto" takes the padded table when it holds at most twice the slots of the edge list
        (degrees alike), else the edge list.

    Returns
    -------
    Links
    """
    src, dst, weight = np.asarray(src, dtype=np.int64), np.asarray(dst, dtype=np.int64), np.asarray(weight, dtype=float)
    order = np.lexsort((src, dst))  # by receiver, then transmitter: the order np.nonzero(A) gives
    src, dst, weight = src[order], dst[order], weight[order]
    in_degree = np.bincount(dst, minlength=n)
    d = max(1, int(in_degree.max(initial=0)))
    if layout == "auto":
        layout = "padded" if n * d <= 2 * max(len(dst), n) else "edges"
    if layout == "edges":
        return Links(src=src.astype(np.int32), dst=dst.astype(np.int32), weight=weight, n=n)
    slot = np.arange(len(dst)) - np.searchsorted(dst, dst)  # position of each edge among its receiver's
    table_src = np.tile(np.arange(n, dtype=np.int32), (d, 1))
    table_w = np.zeros((d, n))
    table_src[slot, dst] = src
    table_w[slot, dst] = weight
    return Links(src=table_src, dst=np.tile(np.arange(n, dtype=np.int32), (d, 1)), weight=table_w, n=n)


def ring_edges(n, directed=False):
    """The ring of :func:`ring_adjacency` as an edge list (src (E,), dst (E,), weight (E,)),
    unit weights: memory linear in n."""
    _check_n(n)
    if n == 1:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    idx = np.arange(n)
    src, dst = [(idx - 1) % n], [idx]
    if not directed and n > 2:  # with two spacecraft the ring's two links are the same one
        src.append((idx + 1) % n)
        dst.append(idx)
    src, dst = np.concatenate(src), np.concatenate(dst)
    return src, dst, np.ones(src.size)


def links_for_schedule(adjacencies, layout="auto"):
    """Links of a switching topology: one index set (the union), one weight set per graph.

    Parameters
    ----------
    adjacencies : sequence of array_like, each (n, n)
        The graphs in time order.
    layout : {"auto", "edges", "padded"}
        As :func:`links_from_adjacency`, chosen on the union.

    Returns
    -------
    Links
        ``weight`` has a leading axis, one row per graph: (G, E) or (G, d, n). A link absent
        from a graph has weight 0 there (a failed link carries nothing).
    """
    stack = np.asarray(adjacencies, dtype=float)
    union = links_from_adjacency((stack > 0).any(axis=0).astype(float), layout=layout)
    # Padding slots point a spacecraft at itself, where every adjacency is 0: weight 0.
    weight = stack[:, union.dst, union.src]
    return Links(src=union.src, dst=union.dst, weight=weight, n=union.n)


def information_digraph(a):
    """networkx DiGraph with an edge j→i for every ``a_ij > 0`` (direction of information flow)."""
    import networkx as nx  # 0.3 s to import: only where a graph is analysed

    a = np.asarray(a, dtype=float)
    g = nx.DiGraph()
    g.add_nodes_from(range(a.shape[0]))
    dst, src = np.nonzero(a)
    g.add_weighted_edges_from(zip(src.tolist(), dst.tolist(), a[dst, src].tolist()))
    return g


def _reached(start, successors):
    """Nodes reachable from ``start`` (itself included) along ``successors`` (list of lists)."""
    seen, stack = {start}, [start]
    while stack:
        for nxt in successors[stack.pop()]:
            if nxt not in seen:
                seen.add(nxt)
                stack.append(nxt)
    return seen


def _last_finished(successors):
    """The node a depth-first search over every node finishes last: it lies in a source
    component of the condensation (Kosaraju's first pass), iteratively."""
    n, seen, last = len(successors), set(), 0
    for root in range(n):
        if root in seen:
            continue
        seen.add(root)
        stack = [(root, iter(successors[root]))]
        while stack:
            node, children = stack[-1]
            child = next((c for c in children if c not in seen), None)
            if child is None:
                stack.pop()
                last = node
            else:
                seen.add(child)
                stack.append((child, iter(successors[child])))
    return last


def spanning_tree_roots(a):
    """Nodes from which information reaches every node (roots of a directed spanning tree).

    Returns
    -------
    list of int
        Empty when the graph has no directed spanning tree, in which case no consensus law
        can bring all spacecraft to agreement. For an undirected graph this is "connected".

    Notes
    -----
    A digraph has a spanning tree iff its condensation has exactly one source component;
    the roots are that component's nodes (Ren & Beard, 2005). The node a depth-first search
    finishes last lies in a source component: if it reaches every node, the roots are the
    nodes that reach it, else there is none. Linear time, and no graph library: every
    scenario build asks, and networkx or scipy's csgraph cost 0.2–0.3 s of import a run.
    """
    a = np.asarray(a)
    n = a.shape[0]
    dst, src = np.nonzero(a)  # information flows src -> dst
    forward, backward = [[] for _ in range(n)], [[] for _ in range(n)]
    for i, j in zip(src.tolist(), dst.tolist()):
        forward[i].append(j)
        backward[j].append(i)
    if n == 0:
        return []
    top = _last_finished(forward)
    if len(_reached(top, forward)) < n:
        return []
    return sorted(_reached(top, backward))


def describe_components(a, names=None):
    """One-line description of why a graph has no spanning tree, naming the node groups.

    Parameters
    ----------
    a : array_like, shape (n, n)
    names : sequence of str, optional
        Node names (default: indices).
    """
    import networkx as nx  # 0.3 s to import: only where a graph is analysed

    g = information_digraph(a)
    cond = nx.condensation(g)
    label = (lambda k: str(k)) if names is None else (lambda k: names[k])
    sources = [sorted(cond.nodes[c]["members"]) for c in cond.nodes if cond.in_degree(c) == 0]
    groups = ["{" + ", ".join(label(k) for k in grp) + "}" for grp in sources]
    return f"{len(sources)} groups hear no one outside themselves: " + " ".join(groups)
