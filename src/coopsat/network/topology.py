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
from coopsat.network import edge_list


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
        Unit-weight adjacency ``A[i, j]`` (i hears j) of :func:`coopsat.network.edge_list.ring`.
    """
    _check_n(n)
    return edge_list.ring(n, directed).toarray()


def chain_adjacency(n, directed=False):
    """Chain 0–1–…–(n−1); directed: i hears i−1 (0 is the root). Shape (n, n)."""
    _check_n(n)
    return edge_list.chain(n, directed).toarray()


def star_adjacency(n, directed=False, hub=0):
    """Star around ``hub``; directed: every other node hears the hub only. Shape (n, n)."""
    _check_n(n)
    return edge_list.star(n, directed, hub).toarray()


def complete_adjacency(n):
    """Complete graph, every node hears every other with weight 1. Shape (n, n)."""
    _check_n(n)
    return edge_list.complete(n).toarray()


NAMED_GRAPHS = {
    "ring": ring_adjacency,
    "chain": chain_adjacency,
    "star": star_adjacency,
    "complete": lambda n, directed=False: complete_adjacency(n),
}


def adjacency_from_edges(n, edges, directed):
    """Adjacency from ``(j, i, weight)`` triples; undirected edges are added both ways
    (:func:`coopsat.network.edge_list.edge_list`).

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
    triples = np.array(list(edges), dtype=float).reshape(-1, 3)
    return edge_list.edge_list(n, triples[:, 0].astype(np.int64), triples[:, 1].astype(np.int64), triples[:, 2], directed).toarray()


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


def links_for_schedule(graphs, layout="auto"):
    """Links of a switching topology: one index set (the union), one weight set per graph.

    Parameters
    ----------
    graphs : sequence of EdgeList or array_like (n, n)
        The graphs in time order (:class:`~coopsat.network.edge_list.EdgeList`, or adjacencies
        ``A[i, j]``: i hears j).
    layout : {"auto", "edges", "padded"}
        As :func:`links_from_edges`, chosen on the union.

    Returns
    -------
    Links
        ``weight`` has a leading axis, one row per graph: (G, E) or (G, d, n). A link absent
        from a graph has weight 0 there (a failed link carries nothing). Memory is linear in
        the links: no n × n matrix is made.
    """
    graphs = [edge_list.as_edge_list(g) for g in graphs]
    ever = edge_list.union(graphs)
    union = links_from_edges(ever.src, ever.dst, ever.weight, ever.n, layout=layout)
    # Padding slots point a spacecraft at itself, where no graph has a link: weight 0.
    weight = np.stack([g.weights_at(union.dst, union.src) for g in graphs])
    return Links(src=union.src, dst=union.dst, weight=weight, n=union.n)


def information_digraph(a):
    """networkx DiGraph with an edge j→i for every ``a_ij > 0`` (direction of information flow)
    of an adjacency (n, n) or an :class:`~coopsat.network.edge_list.EdgeList`."""
    import networkx as nx  # 0.3 s to import: only where a graph is analysed

    e = edge_list.as_edge_list(a)
    g = nx.DiGraph()
    g.add_nodes_from(range(e.n))
    g.add_weighted_edges_from(zip(e.src.tolist(), e.dst.tolist(), e.weight.tolist()))
    return g


def spanning_tree_roots(a):
    """Nodes from which information reaches every node (roots of a directed spanning tree).

    Parameters
    ----------
    a : array_like, shape (n, n), or EdgeList
        The graph (``A[i, j]``: i hears j, or :class:`~coopsat.network.edge_list.EdgeList`).

    Returns
    -------
    list of int
        Empty when the graph has no directed spanning tree, in which case no consensus law
        can bring all spacecraft to agreement. For an undirected graph this is "connected".

    Notes
    -----
    A digraph has a spanning tree iff its condensation has exactly one source component;
    the roots are that component's nodes (Ren & Beard, 2005). The strongly connected
    components are SciPy's (csgraph, linear time in compiled code: every scenario build asks,
    a formation of 1e5 spacecraft too; its import is 0.06 s where the build has SciPy's sparse
    package already, networkx's 0.3 s).
    """
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components

    e = edge_list.as_edge_list(a)
    if e.n == 0:
        return []
    flow = csr_matrix((np.ones(e.n_links), (e.src, e.dst)), shape=(e.n, e.n))  # information flows src -> dst
    _, component = connected_components(flow, directed=True, connection="strong")
    entered = np.zeros(component.max() + 1, dtype=bool)
    across = component[e.src] != component[e.dst]
    entered[component[e.dst[across]]] = True
    sources = np.flatnonzero(~entered)
    if sources.size != 1:
        return []
    return np.flatnonzero(component == sources[0]).tolist()


def describe_components(a, names=None):
    """One-line description of why a graph has no spanning tree, naming the node groups.

    Parameters
    ----------
    a : array_like, shape (n, n), or EdgeList
        The graph (``A[i, j]``: i hears j, or :class:`~coopsat.network.edge_list.EdgeList`).
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
