"""Message delivery over the communication graph, inside the compiled loop.

Each spacecraft broadcasts an *outbox* (a dict of arrays with a leading spacecraft axis); the
network turns it into an *inbox*: one message per directed edge of :class:`~coopsat.network.
topology.Links`, ``inbox[k][e] = outbox[k][src[e]]``. This is the seam where per-link and
multi-hop delays (ring buffers of past outboxes indexed by tick), drop-outs and link-failure
schedules enter; with an ideal network the message is the transmitter's current outbox.
"""

from coopsat import _jax  # noqa: F401

import jax
import jax.numpy as jnp


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
