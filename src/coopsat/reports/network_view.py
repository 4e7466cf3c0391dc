"""The network view of a run: which link is up, lost or late, and when.

Design-time facts (the graphs of the run and when each takes over, the routes and fixed
delays the network model delivers with) come from the built scenario, by the same
``route_epochs`` the compiled loop is built from; what changes during the run (the random
single-hop delay τ(t), each spacecraft's flags such as ``relayed_lines`` or ``cooperating``)
comes from the record. Pure NumPy; the page draws it.
"""

from dataclasses import dataclass

import numpy as np

UP, LOST, RELAYED = "up", "lost", "relayed"
"""Link states: a direct link of the current graph; a link of another graph of the run that
the current one lacks (failed or switched off); a pair heard over more than one hop."""


@dataclass(frozen=True)
class Link:
    """One heard pair of one graph: ``receiver`` hears ``transmitter``.

    Attributes
    ----------
    transmitter, receiver : int
        Spacecraft indices.
    state : str
        :data:`UP`, :data:`LOST` or :data:`RELAYED`.
    hops : int
        Links on the route (0 for a lost link).
    delay_s : float
        Fixed delay of the route, s (the random τ(t), when the model has one, adds per hop).
    """

    transmitter: int
    receiver: int
    state: str
    hops: int
    delay_s: float


@dataclass(frozen=True)
class NetworkView:
    """What the network panel draws.

    Attributes
    ----------
    names : list of str
    xy : ndarray (n, 2)
        Node positions on a unit circle (the first spacecraft at the top).
    epoch_start_s : list of float
        When each graph of the run takes over (the first at 0).
    epochs : list of list of Link
        The links of each graph.
    tau_s : ndarray (time,) or None
        The random single-hop delay τ(t) at each record, s (None without one).
    dropout_probability : float
        Probability that a hop loses a message.
    node_flags : dict of str -> ndarray (time, n)
        Per-spacecraft flags of the record (unitless (time, spacecraft) variables).
    """

    names: list
    xy: np.ndarray
    epoch_start_s: list
    epochs: list
    tau_s: np.ndarray | None
    dropout_probability: float
    node_flags: dict


def circle_layout(n):
    """Nodes evenly on a unit circle, the first at the top, clockwise.

    Returns
    -------
    ndarray (n, 2)
    """
    angle = np.pi / 2 - 2 * np.pi * np.arange(n) / max(n, 1)
    return np.stack([np.cos(angle), np.sin(angle)], axis=-1) if n > 1 else np.zeros((n, 2))


def epoch_links(graphs, routes, period_s):
    """Each graph's links with their state, hops and fixed delay.

    Parameters
    ----------
    graphs : list of EdgeList or ndarray (n, n)
        The links of each graph (``A[i, j] > 0``: i hears j directly).
    routes : list of coopsat.network.routing.Routes
        What the network model delivers in each graph.
    period_s : float
        Control period (delays are whole periods).

    Returns
    -------
    list of list of Link
    """
    from coopsat.network import edge_list

    graphs = [edge_list.as_edge_list(g) for g in graphs]
    ever = edge_list.union(graphs)
    epochs = []
    for graph, route in zip(graphs, routes):
        pairs = edge_list.union([ever, route.heard])  # every link of the run, and what this epoch relays
        up = graph.index_of(pairs.dst, pairs.src) >= 0
        hops = route.heard.values_at(route.hops, pairs.dst, pairs.src)
        delay_s = route.heard.values_at(route.delay_periods, pairs.dst, pairs.src) * period_s
        state = np.where(up, UP, np.where(hops > 1, RELAYED, LOST))
        epochs.append([
            Link(j, i, s, h, d)
            for j, i, s, h, d in zip(pairs.src.tolist(), pairs.dst.tolist(), state.tolist(), hops.tolist(), delay_s.tolist())
        ])
    return epochs


def _routes(built):
    """The network model's routes per graph; direct links without delay for a network plug-in
    that is not one of coopsat's delivery models (its routing is its own)."""
    from coopsat.network.routing import direct_routes
    from coopsat.plugins.networks import route_epochs

    table = built.scenario.network.delivery
    if getattr(table, "kind", None) in ("ideal", "delayed"):
        return route_epochs(table, built.context)
    return [direct_routes(g, np.zeros(g.n_links, dtype=np.int64)) for g in built.graphs]


def _flags(ds):
    return {
        name: np.asarray(var.transpose("time", "spacecraft").values, dtype=float)
        for name, var in ds.data_vars.items()
        if set(var.dims) == {"time", "spacecraft"} and var.attrs.get("units") == "1"
    }


def build_network_view(built, ds):
    """The network panel of a run.

    Parameters
    ----------
    built : coopsat.scenarios.build.Built
    ds : xarray.Dataset

    Returns
    -------
    NetworkView
    """
    period_s = built.context.period_s
    table = built.scenario.network.delivery
    tau = None
    if "network_tau_periods" in ds:
        tau = np.asarray(ds["network_tau_periods"].values, dtype=float) * period_s
    return NetworkView(
        names=list(built.names),
        xy=circle_layout(len(built.names)),
        epoch_start_s=[float(t) for t in built.switch_times_s],
        epochs=epoch_links(built.graphs, _routes(built), period_s),
        tau_s=tau,
        dropout_probability=float(getattr(table, "dropout_probability", 0.0)),
        node_flags=_flags(ds),
    )
