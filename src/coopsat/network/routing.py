"""Routing at design time: who hears whom over how many hops, and with what fixed delay.

A message from j to i travels the shortest directed path of the physical graph (fewest hops;
among equally short paths, the one with the least fixed delay), and arrives late by the sum
of the per-hop delays along it. Computed for each topology epoch (networkx where messages are
relayed); the compiled loop only indexes the resulting arrays.

Routes are lists of heard pairs, memory linear in them: direct delivery over a ring of 1e5
spacecraft is 2e5 pairs. Relaying makes every reachable pair heard, up to n (n − 1): that is
the model (every spacecraft hears every other), not a matrix kept for convenience.
"""

from dataclasses import dataclass

import numpy as np

from coopsat.network import edge_list
from coopsat.network.topology import information_digraph


@dataclass(frozen=True)
class Routes:
    """Heard pairs of one topology epoch (i hears j), each once.

    Attributes
    ----------
    heard : coopsat.network.edge_list.EdgeList
        The pairs (``src`` j, ``dst`` i, sorted by receiver then transmitter) and the weight
        ``a_ij`` with which i uses what it hears from j.
    hops : ndarray of int (P,)
        Links on the route from j to i, per pair (≥ 1).
    delay_periods : ndarray of int (P,)
        Sum of the fixed per-hop delays along the route, control periods, per pair.
    """

    heard: edge_list.EdgeList
    hops: np.ndarray
    delay_periods: np.ndarray

    def matrices(self):
        """(weight, hops, delay_periods) as dense (n, n) arrays ``[i, j]`` (i hears j; 0 where
        it does not): n² memory, for small formations and tests."""
        n, dst, src = self.heard.n, self.heard.dst, self.heard.src
        out = []
        for values, dtype in ((self.heard.weight, float), (self.hops, np.int64), (self.delay_periods, np.int64)):
            m = np.zeros((n, n), dtype=dtype)
            m[dst, src] = values
            out.append(m)
        return tuple(out)


def per_link(graph, link_delay_periods):
    """Fixed delays of ``graph``'s links, one per link: given so (E,), or read from a matrix
    ``C[i, j]`` (n, n) at the links (entries off the links are ignored)."""
    c = np.asarray(link_delay_periods, dtype=np.int64)
    return c[graph.dst, graph.src] if c.ndim == 2 else c


def direct_routes(graph, link_delay_periods):
    """Each spacecraft hears only its direct neighbours: one hop, that link's delay.

    Parameters
    ----------
    graph : EdgeList or ndarray (n, n)
        The links (``A[i, j] > 0`` iff i hears j directly, with the link's weight).
    link_delay_periods : ndarray of int (E,) or (n, n)
        Fixed delay of each direct link j→i, control periods (:func:`per_link`).

    Returns
    -------
    Routes
    """
    e = edge_list.as_edge_list(graph)
    e = edge_list.EdgeList(e.src, e.dst, np.array(e.weight, dtype=float), e.n)  # not a view of the caller's weights
    return Routes(e, np.ones(e.n_links, dtype=np.int64), per_link(e, link_delay_periods).copy())


def relayed_routes(graph, link_delay_periods, relay_weight):
    """Every spacecraft hears every other it can reach, over the shortest directed path.

    Parameters
    ----------
    graph : EdgeList or ndarray (n, n)
        Physical links, ``A[i, j] > 0`` iff j transmits to i directly.
    link_delay_periods : ndarray of int (E,) or (n, n)
        Fixed delay of each direct link j→i, control periods (:func:`per_link`).
    relay_weight : float
        Weight of a pair heard over more than one hop; a direct neighbour keeps its link's
        weight.

    Returns
    -------
    Routes
        Unreachable pairs are not heard.

    Notes
    -----
    Fewest hops first, then least summed delay: each edge costs ``1 + c / (1 + Σc)``, so any
    path with fewer hops costs less than any with more (the fractions sum to less than 1).
    SPEC §3: "every agent hears every other one over the shortest directed path; a message
    over m hops arrives m·τ(t) late".
    """
    import networkx as nx  # 0.15 s to import: only where routes are relayed, not for direct links

    e = edge_list.as_edge_list(graph)
    c = per_link(e, link_delay_periods)
    g = information_digraph(e)
    scale = 1.0 + float(c.sum())
    delay_of = {}
    for j, i, d in zip(e.src.tolist(), e.dst.tolist(), c.tolist()):
        g.edges[j, i]["cost"] = 1.0 + d / scale
        delay_of[j, i] = d
    src, dst, hops, delay = [], [], [], []
    for j, paths in nx.all_pairs_dijkstra_path(g, weight="cost"):
        for i, path in paths.items():
            if i != j:
                src.append(j)
                dst.append(i)
                hops.append(len(path) - 1)
                delay.append(sum(delay_of[u, v] for u, v in zip(path[:-1], path[1:])))
    direct = e.weights_at(dst, src)
    heard = edge_list.edge_list(e.n, src, dst, np.where(direct > 0, direct, relay_weight)) if src else edge_list.empty(e.n)
    order = heard.index_of(dst, src)  # each pair's place among the sorted heard pairs
    sorted_hops, sorted_delay = np.zeros(heard.n_links, np.int64), np.zeros(heard.n_links, np.int64)
    sorted_hops[order], sorted_delay[order] = hops, delay
    return Routes(heard, sorted_hops, sorted_delay)


def lost_route(before, after, names):
    """A pair (receiver, transmitter) of names heard in ``before`` but unreachable in ``after``,
    or None (a link failure that leaves no route between two spacecraft that talked)."""
    b = before.heard
    lost = np.flatnonzero(after.heard.weights_at(b.dst, b.src) == 0)
    if not lost.size:
        return None
    return names[b.dst[lost[0]]], names[b.src[lost[0]]]


def link_delays(graph, default_periods, overrides):
    """Fixed delay of each link of ``graph``, control periods, one per link (E,).

    Parameters
    ----------
    graph : EdgeList or ndarray (n, n)
    default_periods : int
        Delay of every link not overridden.
    overrides : iterable of (int, int, int)
        ``(j, i, periods)``: link j→i (one direction) takes this delay; ignored where the
        graph has no such link (a link that exists only in another topology epoch).

    Returns
    -------
    ndarray of int (E,)
        In the order of the graph's links (:class:`~coopsat.network.edge_list.EdgeList`).
    """
    e = edge_list.as_edge_list(graph)
    c = np.full(e.n_links, default_periods, dtype=np.int64)
    for j, i, d in overrides:
        at = int(e.index_of(i, j))
        if at >= 0:
            c[at] = d
    return c
