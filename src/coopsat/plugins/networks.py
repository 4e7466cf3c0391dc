"""Network models (``[network.delivery]``): how the outboxes of the spacecraft reach their
neighbours over the graph of ``[network]`` (and its ``[[network.switches]]``)."""

from typing import Literal

from pydantic import Field, model_validator

from coopsat.plugins import DesignError, Plugin, Tunable, register
from coopsat.plugins.tables import MAX_GAIN, MAX_TIME_S, Record, Table


class IdealDelivery(Table):
    """``kind = "ideal"``: every link carries its transmitter's current message (no delay, no loss)."""

    kind: Literal["ideal"]


def _build_ideal(table, ctx):
    from coopsat.network import topology
    from coopsat.network.delivery import IdealNetwork
    from coopsat.sim.system import as_arrays

    links = topology.links_for_schedule(ctx.graphs)
    return IdealNetwork(*as_arrays((links.src, links.dst, links.weight, ctx.switch_ticks)))


def _edge_weight_tunables(table, ctx, part):
    """``edges``: the weights of an edge-list graph (``[network] kind = "edges"``, no
    switches), in the file's order. Each link carries the weight of the one edge it comes
    from (the schema refuses a pair given twice), gathered traced: memory linear in the links."""
    from dataclasses import replace

    import jax.numpy as jnp
    import numpy as np

    from coopsat.network import edge_list

    graph = ctx.scenario.network
    if graph.kind != "edges" or graph.switches:
        return {}
    index = {name: k for k, name in enumerate(ctx.names)}
    src, dst = (np.array([index[e[end]] for e in graph.edges], dtype=np.int64) for end in (0, 1))
    # The edges numbered from 1 as weights: read at the links, 0 is a padding slot.
    numbered = edge_list.edge_list(ctx.n, src, dst, np.arange(1, src.size + 1), graph.directed)
    edge_of = numbered.weights_at(np.asarray(part.dst), np.asarray(part.src)).astype(np.int64) - 1  # (links…)
    carries, at = jnp.asarray(edge_of >= 0), jnp.asarray(np.maximum(edge_of, 0))

    def apply(p, w):
        return replace(p, weight=jnp.where(carries, jnp.asarray(w)[at], 0.0)[None])

    def write(w):
        return {"network.edges": [[a, b, float(v)] for (a, b, _), v in zip(graph.edges, np.asarray(w))]}

    return {"edges": Tunable(np.array([w for _, _, w in graph.edges], dtype=float), apply, write, root=True)}


register(Plugin("network", "ideal", IdealDelivery, _build_ideal, tunables=_edge_weight_tunables))


class RandomDelay(Table):
    """``random_delay``: the random single-hop delay τ(t) of SPEC §3, piecewise constant."""

    min_s: float = Field(0.0, ge=0, le=1e6, description="Smallest τ, s (whole control periods).")
    max_s: float = Field(ge=0, le=1e6, description="Largest τ (its bound), s (whole control periods).")
    hold_min_s: float = Field(gt=0, le=MAX_TIME_S, description="Shortest time between two draws of τ, s (whole control periods).")
    hold_max_s: float = Field(gt=0, le=MAX_TIME_S, description="Longest time between two draws of τ, s (whole control periods).")

    @model_validator(mode="after")
    def _ordered(self):
        if self.min_s > self.max_s:
            raise ValueError(f"min_s ({self.min_s:g} s) is above the bound max_s ({self.max_s:g} s)")
        if self.hold_min_s > self.hold_max_s:
            raise ValueError(f"hold_min_s ({self.hold_min_s:g} s) is above hold_max_s ({self.hold_max_s:g} s)")
        return self


class DelayedDelivery(Table):
    """``kind = "delayed"``: per-link delays, multi-hop relaying, a random τ(t), drop-outs."""

    kind: Literal["delayed"]
    delay_s: float = Field(0.0, ge=0, le=1e6, description="Fixed delay of every hop, s (whole control periods).")
    link_delays: list[Record(str, str, float)] = Field(
        [], description="[transmitter, receiver, delay_s] per direction of a link: overrides delay_s there."
    )
    relay: bool = Field(
        False,
        description="Every spacecraft hears every one it can reach, over the shortest directed path "
        "(delays summed per hop); false: direct neighbours only.",
    )
    relay_weight: float = Field(1.0, gt=0, le=MAX_GAIN, description="Weight of a pair heard over more than one hop.")
    random_delay: RandomDelay | None = Field(None, description="Random single-hop delay τ(t) added per hop.")
    dropout_probability: float = Field(0.0, ge=0, lt=1, description="Probability that one hop loses a message.")
    on_loss: Literal["hold", "drop"] = Field(
        "hold", description="A lost message: the receiver holds the last one it got (hold) or drops the term (drop)."
    )


def _periods(value_s, ctx, where):
    """A time as a whole number of control periods (0 allowed), or a DesignError naming ``where``."""
    k = round(value_s / ctx.period_s)
    if abs(value_s - k * ctx.period_s) > 1e-9 * max(value_s, ctx.period_s):
        raise DesignError(
            f"{where} ({value_s:g} s) must be a whole number of control periods ({ctx.period_s:g} s): "
            "messages are exchanged once per period"
        )
    return k


MAX_BUFFER_PERIODS = 1_000_000
"""Most periods of history the delay buffer may hold (memory grows as buffer × n × fields)."""


def route_epochs(table, ctx):
    """The heard pairs, hops and fixed delays (periods) of each topology epoch, as the network
    model ``table`` delivers them (:class:`~coopsat.network.routing.Routes` per graph).

    The ideal network: direct neighbours, one hop, no delay. Raises :class:`DesignError` on a
    delay that is not a whole number of periods, an unknown link, or a switch that leaves two
    spacecraft that heard each other with no route (relaying).
    """
    import numpy as np

    from coopsat.network import edge_list, routing

    if table.kind == "ideal":
        return [routing.direct_routes(g, np.zeros(g.n_links, dtype=np.int64)) for g in ctx.graphs]
    where = "network.delivery"
    index = {name: k for k, name in enumerate(ctx.names)}
    default = _periods(table.delay_s, ctx, f"{where}.delay_s")
    overrides = []
    ever = edge_list.union(ctx.graphs)
    for k, (src, dst, d) in enumerate(table.link_delays):
        for end in (src, dst):
            if end not in index:
                raise DesignError(f"{where}.link_delays[{k}]: unknown spacecraft '{end}' (known: {', '.join(ctx.names)})")
        if ever.index_of(index[dst], index[src]) < 0:
            raise DesignError(f"{where}.link_delays[{k}]: there is no link {src} -> {dst} in any graph of the run")
        overrides.append((index[src], index[dst], _periods(d, ctx, f"{where}.link_delays[{k}] delay")))
    epochs = []
    for place, graph in zip(ctx.graph_places, ctx.graphs):
        c = routing.link_delays(graph, default, overrides)
        routes = routing.relayed_routes(graph, c, table.relay_weight) if table.relay else routing.direct_routes(graph, c)
        if table.relay and epochs:
            lost = routing.lost_route(epochs[0], routes, ctx.names)
            if lost is not None:
                raise DesignError(
                    f"{place}: no route from {lost[1]} to {lost[0]} is left after this switch, so relaying cannot deliver "
                    "what it delivered before; keep a path between them, or relay = false"
                )
        epochs.append(routes)
    return epochs


def random_delay_periods(table, ctx):
    """(min, max, hold_min, hold_max) of the random single-hop delay, control periods; all 0
    (hold 1) without one."""
    rd = getattr(table, "random_delay", None)
    if rd is None:
        return (0, 0, 1, 1)
    where = "network.delivery.random_delay"
    return tuple(_periods(getattr(rd, f), ctx, f"{where}.{f}") for f in ("min_s", "max_s", "hold_min_s", "hold_max_s"))


def _build_delayed(table, ctx):
    import numpy as np

    from coopsat.network import topology
    from coopsat.network.delay import DelayedNetwork
    from coopsat.sim.system import as_arrays

    where = "network.delivery"
    epochs = route_epochs(table, ctx)
    tau = random_delay_periods(table, ctx)
    links = topology.links_for_schedule([r.heard for r in epochs])
    pick = lambda m: np.stack([r.heard.values_at(getattr(r, m), links.dst, links.src) for r in epochs])  # noqa: E731
    hops, fixed = pick("hops"), pick("delay_periods")
    largest = int((fixed + hops * tau[1]).max(initial=0))
    if largest + 1 > MAX_BUFFER_PERIODS:
        raise DesignError(
            f"{where}: the largest delay is {largest} control periods; more than {MAX_BUFFER_PERIODS} cannot be buffered"
        )
    loss = 1.0 - (1.0 - table.dropout_probability) ** hops
    return DelayedNetwork(
        *as_arrays((links.src, links.dst, links.weight, hops, fixed, loss, ctx.switch_ticks, *tau)),
        period_ticks=round(ctx.period_s / ctx.dt_s),
        buffer_periods=largest + 1,
        random=tau[1] > 0,
        lossy=table.dropout_probability > 0,
        hold=table.on_loss == "hold",
    )


register(Plugin("network", "delayed", DelayedDelivery, _build_delayed))
