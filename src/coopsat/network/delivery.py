"""Message delivery over the communication graph, inside the compiled loop.

Each spacecraft broadcasts an *outbox* (a dict of arrays with a leading spacecraft axis); the
network turns it into an *inbox*: one message per directed edge of :class:`~coopsat.network.
topology.Links`, ``inbox[k][e] = outbox[k][src[e]]``. This is the seam where per-link and
multi-hop delays (ring buffers of past outboxes indexed by tick), drop-outs and link-failure
schedules enter; with an ideal network the message is the transmitter's current outbox.
"""

from coopsat import _jax  # noqa: F401

import jax


def deliver_ideal(outbox, src):
    """Ideal network: every edge carries its transmitter's current message.

    Parameters
    ----------
    outbox : dict of arrays, each (n, ...)
    src : int array, shape (E,)

    Returns
    -------
    dict of arrays, each (E, ...)
    """
    return jax.tree_util.tree_map(lambda a: a[src], outbox)
