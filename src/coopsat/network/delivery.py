"""Message delivery over the communication graph, inside the compiled loop.

Each spacecraft broadcasts an *outbox* (a dict of arrays with a leading spacecraft axis); the
network turns it into an *inbox*: one message per directed edge of :class:`~coopsat.network.
topology.Links`, ``inbox[k][e] = outbox[k][src[e]]``. This is the seam where per-link and
multi-hop delays (ring buffers of past outboxes indexed by tick), drop-outs and link-failure
schedules enter; with an ideal network the message is the transmitter's current outbox.
"""

from typing import NamedTuple


import jax
import jax.numpy as jnp

from coopsat.core.parts import part


def deliver_ideal(outbox, src, spacecraft_axis=0):
    """Ideal network: every edge carries its transmitter's current message.

    Parameters
    ----------
    outbox : dict of arrays
        Each with the spacecraft on ``spacecraft_axis`` (``(n, k)``, or ``(k, n)`` with
        ``spacecraft_axis=-1`` inside the compiled loop).
    src : int array, shape (E,)
    spacecraft_axis : int

    Returns
    -------
    dict of arrays
        Edges in place of spacecraft: ``(E, k)`` or ``(k, E)``.
    """
    return jax.tree_util.tree_map(lambda a: jnp.take(a, src, axis=spacecraft_axis), outbox)


class Inbox(NamedTuple):
    """What the flight software of every spacecraft receives in one control period.

    Attributes
    ----------
    msg : dict of arrays
        Per link, the transmitter's message as delivered: ``(k, E)`` for an edge list, or
        ``(k, d, n)`` for a padded in-neighbour table (component-major).
    weight : (E,) or (d, n)
        ``a_ij`` of each link now; 0 for a link that is absent from the graph in force, failed,
        or (with ``on_loss = "drop"``) whose message was lost.
    dst : int (E,) or (d, n)
        Receiver of each link (for sums over a receiver's links).
    own : dict of arrays
        Per link, the *receiver's own* outbox from the same instant as the message it got (as
        ``msg``): what a protocol that delays the whole relative state uses. Free when unused
        (XLA drops what no law reads).
    source : (dict of arrays, int array) or None
        ``(table, index)`` when every message is a plain gather, ``msg[k] = table[k][..., index]``
        (``table[k]``: ``(k, T)``, the transmitters' current outboxes or a delay line;
        ``index``: shaped as ``dst``); None when the messages are not (held lost messages).
        A native kernel (:mod:`coopsat.sim.native`) gathers from it in its own loop instead of
        reading ``msg``; a law written in JAX ignores it.
    """

    msg: dict
    weight: jnp.ndarray
    dst: jnp.ndarray
    own: dict
    source: tuple = None


def active_row(switch_ticks, tick):
    """Index of the topology epoch in force at ``tick`` (last switch ≤ tick); 0 for one epoch."""
    if switch_ticks.shape[0] == 1:
        return 0
    return jnp.searchsorted(switch_ticks, tick, side="right") - 1


@part()
class IdealNetwork:
    """Network part without delay or loss: each link carries its transmitter's current message.

    Attributes
    ----------
    src, dst : int (E,) or (d, n)
        Links (:class:`~coopsat.network.topology.Links`; the union over topology epochs).
    weight : (G, E) or (G, d, n)
        Link weights of each of the G epochs of a switching topology.
    switch_ticks : int (G,)
        First tick of each epoch (the first is 0).
    """

    src: jnp.ndarray
    dst: jnp.ndarray
    weight: jnp.ndarray
    switch_ticks: jnp.ndarray

    def init(self, outbox0):
        return ()

    def deliver(self, tick, outbox, state, key):
        """(inbox, state, record) of this period; the outbox is component-major ``(k, n)``."""
        msg = deliver_ideal(outbox, self.src, spacecraft_axis=-1)
        own = deliver_ideal(outbox, self.dst, spacecraft_axis=-1)
        weight = self.weight[active_row(self.switch_ticks, tick)]
        return Inbox(msg, weight, self.dst, own, (outbox, self.src)), state, {}

    def output_specs(self):
        return {}
