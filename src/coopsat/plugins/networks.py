"""Network models (``[network.delivery]``): how the outboxes of the spacecraft reach their
neighbours over the graph of ``[network]`` (and its ``[[network.switches]]``)."""

from typing import Literal

from coopsat.plugins import Plugin, register
from coopsat.plugins.tables import Table


class IdealDelivery(Table):
    """``kind = "ideal"``: every link carries its transmitter's current message (no delay, no loss)."""

    kind: Literal["ideal"]


def _build_ideal(table, ctx):
    from coopsat.network import topology
    from coopsat.network.delivery import IdealNetwork
    from coopsat.sim.system import as_arrays

    links = topology.links_for_schedule(ctx.adjacencies)
    return IdealNetwork(*as_arrays((links.src, links.dst, links.weight, ctx.switch_ticks)))


register(Plugin("network", "ideal", IdealDelivery, _build_ideal))
