"""Routing at design time: who hears whom over how many hops, and with what fixed delay.

A message from j to i travels the shortest directed path of the physical graph (fewest hops;
among equally short paths, the one with the least fixed delay), and arrives late by the sum
of the per-hop delays along it. Computed with networkx for each topology epoch; the compiled
loop only indexes the resulting arrays.
"""

from dataclasses import dataclass

import numpy as np

from coopsat.network.topology import information_digraph


@dataclass(frozen=True)
class Routes:
    """Heard pairs of one topology epoch as dense (n, n) arrays (``[i, j]``: i hears j).

    Attributes
    ----------
    weight : ndarray (n, n)
        Weight ``a_ij`` with which i uses what it hears from j (0: i does not hear j).
    hops : ndarray of int (n, n)
        Links on the route from j to i (0 where i does not hear j).
    delay_periods : ndarray of int (n, n)
        Sum of the fixed per-hop delays along the route, in control periods.
    """

    weight: np.ndarray
    hops: np.ndarray
    delay_periods: np.ndarray


def direct_routes(adjacency, link_delay_periods):
    """Each spacecraft hears only its direct neighbours: one hop, that link's delay.

    Parameters
    ----------
    adjacency : ndarray (n, n)
        ``A[i, j] > 0`` iff i hears j directly, with the link's weight.
    link_delay_periods : ndarray of int (n, n)
        Fixed delay of each direct link j→i, control periods.

    Returns
    -------
    Routes
    """
    a = np.asarray(adjacency, dtype=float)
    on = a > 0
    return Routes(a.copy(), on.astype(np.int64), np.where(on, link_delay_periods, 0).astype(np.int64))


def relayed_routes(adjacency, link_delay_periods, relay_weight):
    """Every spacecraft hears every other it can reach, over the shortest directed path.

    Parameters
    ----------
    adjacency : ndarray (n, n)
        Physical links, ``A[i, j] > 0`` iff j transmits to i directly.
    link_delay_periods : ndarray of int (n, n)
        Fixed delay of each direct link j→i, control periods.
    relay_weight : float
        Weight of a pair heard over more than one hop; a direct neighbour keeps its link's
        weight.

    Returns
    -------
    Routes
        Unreachable pairs have weight 0.

    Notes
    -----
    Fewest hops first, then least summed delay: each edge costs ``1 + c / (1 + Σc)``, so any
    path with fewer hops costs less than any with more (the fractions sum to less than 1).
    SPEC §3: "every agent hears every other one over the shortest directed path; a message
    over m hops arrives m·τ(t) late".
    """
    import networkx as nx  # 0.15 s to import: only where routes are relayed, not for direct links

    a = np.asarray(adjacency, dtype=float)
    c = np.asarray(link_delay_periods, dtype=np.int64)
    n = a.shape[0]
    g = information_digraph(a)
    scale = 1.0 + float(np.where(a > 0, c, 0).sum())
    for j, i in g.edges:
        g.edges[j, i]["cost"] = 1.0 + c[i, j] / scale
    weight = np.zeros((n, n))
    hops = np.zeros((n, n), dtype=np.int64)
    delay = np.zeros((n, n), dtype=np.int64)
    for j, paths in nx.all_pairs_dijkstra_path(g, weight="cost"):
        for i, path in paths.items():
            if i == j:
                continue
            hops[i, j] = len(path) - 1
            delay[i, j] = sum(c[b, a_] for a_, b in zip(path[:-1], path[1:]))
            weight[i, j] = a[i, j] if a[i, j] > 0 else relay_weight
    return Routes(weight, hops, delay)


def lost_route(before, after, names):
    """A pair (receiver, transmitter) of names heard in ``before`` but unreachable in ``after``,
    or None (a link failure that leaves no route between two spacecraft that talked)."""
    lost = (before.weight > 0) & (after.weight == 0)
    if not lost.any():
        return None
    i, j = np.argwhere(lost)[0]
    return names[i], names[j]


def link_delays(adjacency, default_periods, overrides):
    """Per-link fixed delay matrix ``C[i, j]`` (link j→i), control periods.

    Parameters
    ----------
    adjacency : ndarray (n, n)
    default_periods : int
        Delay of every link not overridden.
    overrides : iterable of (int, int, int)
        ``(j, i, periods)``: link j→i (one direction) takes this delay; ignored where the
        graph has no such link (a link that exists only in another topology epoch).

    Returns
    -------
    ndarray of int (n, n)
    """
    a = np.asarray(adjacency, dtype=float)
    c = np.full(a.shape, default_periods, dtype=np.int64)
    for j, i, d in overrides:
        c[i, j] = d
    return np.where(a > 0, c, 0)
