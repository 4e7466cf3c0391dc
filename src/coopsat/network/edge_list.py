"""Graphs as edge lists: a scenario's graphs from the start, memory linear in the links.

A ring of a hundred thousand spacecraft is 2e5 links (a few megabytes), where its adjacency
matrix would be 80 GB. The direction convention is :mod:`coopsat.network.topology`'s: a link
``j → i`` means i hears j, with weight ``a_ij > 0``. The dense matrix is made only where an
algorithm needs one (:meth:`EdgeList.toarray`: eigen-analysis of small formations, the
``coopsat topology`` metrics, the paired arrays of a report).

Importing this module imports NumPy only (every scenario build makes its graphs here).
"""

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class EdgeList:
    """A weighted directed graph of ``n`` nodes as its links, each pair once.

    Attributes
    ----------
    src, dst : ndarray of int64, shape (E,)
        Transmitter j and receiver i of each link (i hears j), sorted by receiver, then
        transmitter (the order ``np.nonzero(A)`` gives); no self-loops.
    weight : ndarray of float, shape (E,)
        ``a_ij > 0`` of each link.
    n : int
        Number of nodes, including any that hear nobody.
    """

    src: np.ndarray
    dst: np.ndarray
    weight: np.ndarray
    n: int

    @property
    def n_links(self):
        """Number of directed links E."""
        return int(self.src.size)

    def toarray(self):
        """The adjacency ``A[i, j]`` (i hears j), shape (n, n): n² memory, for small graphs."""
        a = np.zeros((self.n, self.n))
        a[self.dst, self.src] = self.weight
        return a

    def index_of(self, dst, src):
        """Position of each pair's link in ``src``/``dst``, −1 where there is none.

        Parameters
        ----------
        dst, src : array_like of int, one shape (any)
            Receivers i and transmitters j.

        Returns
        -------
        ndarray of int64, that shape
        """
        dst, src = np.asarray(dst, dtype=np.int64), np.asarray(src, dtype=np.int64)
        if self.n_links == 0:
            return np.full(dst.shape, -1, dtype=np.int64)
        keys = self.dst * self.n + self.src  # ascending: sorted by receiver, then transmitter
        asked = dst * self.n + src
        at = np.minimum(np.searchsorted(keys, asked), keys.size - 1)
        return np.where(keys[at] == asked, at, -1)

    def values_at(self, values, dst, src):
        """``values`` (one per link, shape (E,)) at the pairs (``dst`` = i, ``src`` = j), 0 where
        there is no link; the pairs' shape."""
        values, at = np.asarray(values), self.index_of(dst, src)
        if values.size == 0:
            return np.zeros(at.shape, dtype=values.dtype)
        return np.where(at >= 0, values[np.maximum(at, 0)], 0)

    def weights_at(self, dst, src):
        """``a_ij`` at the pairs (``dst`` = i, ``src`` = j), 0 where there is no link.

        Parameters
        ----------
        dst, src : array_like of int, one shape (any)

        Returns
        -------
        ndarray of float, that shape
        """
        return self.values_at(self.weight, dst, src)

    def scaled(self, factor):
        """Every weight times ``factor`` (> 0)."""
        return EdgeList(self.src, self.dst, self.weight * float(factor), self.n)


def edge_list(n, src, dst, weight, directed=True, where="network.edges"):
    """An :class:`EdgeList` from links in any order; undirected links are added both ways and
    a pair given twice keeps its last weight.

    Parameters
    ----------
    n : int
        Number of nodes.
    src, dst : array_like of int, shape (E,)
        Transmitter j and receiver i of each link.
    weight : array_like of float, shape (E,)
        ``a_ij`` of each link, > 0.
    directed : bool
    where : str
        The graph's place, for error messages.

    Raises
    ------
    coopsat.network.topology.GraphError
        A self-loop, or a weight that is not > 0 (the first such link, one line).
    """
    from coopsat.network.topology import GraphError

    src, dst = np.asarray(src, dtype=np.int64).ravel(), np.asarray(dst, dtype=np.int64).ravel()
    weight = np.broadcast_to(np.asarray(weight, dtype=float), src.shape)
    bad = np.flatnonzero((src == dst) | ~(weight > 0.0))
    if bad.size:
        k = bad[0]
        if src[k] == dst[k]:
            raise GraphError(f"{where}: self-loop on spacecraft {dst[k]} (a spacecraft does not hear itself)")
        raise GraphError(f"{where}: weight of edge {src[k]}->{dst[k]} must be > 0, got {weight[k]}")
    if not directed:  # each link followed by its reverse, so that "last given" is per edge
        src, dst = np.stack([src, dst], axis=1).ravel(), np.stack([dst, src], axis=1).ravel()
        weight = np.repeat(weight, 2)
    keys = dst * n + src
    # The last occurrence of every pair: unique over the reversed keys.
    _, first_of_reversed = np.unique(keys[::-1], return_index=True)
    keep = keys.size - 1 - first_of_reversed  # ascending keys: by receiver, then transmitter
    return EdgeList(src[keep], dst[keep], np.array(weight[keep], dtype=float), int(n))


def from_adjacency(a):
    """The :class:`EdgeList` of the nonzero entries of ``A[i, j]`` (i hears j), shape (n, n)."""
    a = np.asarray(a, dtype=float)
    dst, src = np.nonzero(a)
    return EdgeList(src.astype(np.int64), dst.astype(np.int64), a[dst, src], a.shape[0])


def as_edge_list(graph):
    """``graph`` as an :class:`EdgeList`: itself, or the nonzeros of an adjacency (n, n)."""
    return graph if isinstance(graph, EdgeList) else from_adjacency(graph)


def union(graphs):
    """Every pair linked in any of ``graphs`` (one node count), as an :class:`EdgeList` of
    unit weights."""
    graphs = [as_edge_list(g) for g in graphs]
    keys = np.unique(np.concatenate([g.dst * g.n + g.src for g in graphs]))
    n = graphs[0].n
    return EdgeList(keys % n, keys // n, np.ones(keys.size), n)


def empty(n):
    """No links."""
    return EdgeList(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0), int(n))


def ring(n, directed=False):
    """Ring 0–1–…–(n−1)–0, unit weights; directed: i hears i−1 (0 → 1 → … → 0)."""
    idx = np.arange(n)
    if n < 2:
        return empty(n)
    return edge_list(n, (idx - 1) % n, idx, 1.0, directed)


def chain(n, directed=False):
    """Chain 0–1–…–(n−1), unit weights; directed: i hears i−1 (0 is the root)."""
    idx = np.arange(1, n)
    return edge_list(n, idx - 1, idx, 1.0, directed)


def star(n, directed=False, hub=0):
    """Star around ``hub``, unit weights; directed: every other node hears the hub only."""
    others = np.delete(np.arange(n), hub)
    return edge_list(n, np.full(others.size, hub), others, 1.0, directed)


def complete(n):
    """Every node hears every other, unit weights (n (n − 1) links)."""
    dst, src = np.divmod(np.arange(n * n, dtype=np.int64), n)
    off = dst != src
    return EdgeList(src[off], dst[off], np.ones(int(off.sum())), int(n))
