"""Per-spacecraft flight software: the engine runs it so that a spacecraft can read only what
it could have.

A controller part normally sees every spacecraft's measurements at once (``step(t, y, inbox,
state, key)`` over ``(k, n)`` arrays), which suits laws written as sums over links. A part with
``local = True`` is instead one spacecraft's computer, and :func:`as_flight_software` wraps it
so that the engine calls it once per spacecraft (``jax.vmap``) with:

* ``y_i``: only the quantities the part names in ``reads``, only spacecraft i's reading (its
  own column; a sensor's derived measurement such as the relative positions it sees);
* ``inbox_i``: only the links addressed to spacecraft i (every other link's message and weight
  zeroed), as one flat link axis (last) whatever the network's layout, and no ``own`` history
  unless the part says ``reads_own = True`` (then, per link addressed to i, its own outbox of
  the instant that link's message was sent, as the network delivers it; zeroed elsewhere);
* ``state_i``: its own slice of the controller state (the spacecraft axis is last);
* ``key_i``: ``fold_in(key, i)``.

It answers with ``step_one(i, t, y_i, inbox_i, state_i, key_i) -> (commands_i, state_i,
record_i)`` and ``outbox_one(i, y_i, state_i) -> message_i``; the wrapper stacks the answers
on a last spacecraft axis. Anything else a spacecraft uses must arrive over the network: the
information structure is the engine's, not the law's promise (SPEC §4, decentralization).
"""


import jax
import jax.numpy as jnp

from coopsat.network.delivery import Inbox


class _PerSpacecraft:
    """The global controller protocol around a ``local`` part (see the module docstring)."""

    def __init__(self, software, n):
        self.software = software
        self.n = n
        self.commands = software.commands

    def _mine(self, y):
        missing = [q for q in self.software.reads if q not in y]
        if missing:
            raise KeyError(f"flight software reads {missing}, which no sensor or state provides")
        return {q: y[q] for q in self.software.reads}

    def init(self, n):
        return self.software.init(n)

    def outbox(self, y, state):
        ids = jnp.arange(self.n)
        return jax.vmap(self.software.outbox_one, in_axes=(0, -1, -1), out_axes=-1)(ids, self._mine(y), state)

    def step(self, t, y, inbox, state, key):
        # Links as one flat edge axis, whatever the network's layout (edge list (E,), or padded
        # in-neighbour table (d, n)).
        links = inbox.weight.ndim
        dst = inbox.dst.reshape(-1)
        flat = lambda m: m.reshape(m.shape[: m.ndim - links] + (-1,))  # noqa: E731
        msg = jax.tree_util.tree_map(flat, inbox.msg)
        own = jax.tree_util.tree_map(flat, inbox.own) if getattr(self.software, "reads_own", False) else {}
        weight = inbox.weight.reshape(-1)

        def one(i, y_i, state_i):
            addressed = dst == i
            mine = lambda m: jnp.where(addressed, m, jnp.zeros_like(m))  # noqa: E731
            inbox_i = Inbox(
                msg=jax.tree_util.tree_map(mine, msg),
                weight=jnp.where(addressed, weight, 0.0),
                dst=dst,
                own=jax.tree_util.tree_map(mine, own),
            )
            return self.software.step_one(i, t, y_i, inbox_i, state_i, jax.random.fold_in(key, i))

        ids = jnp.arange(self.n)
        return jax.vmap(one, in_axes=(0, -1, -1), out_axes=-1)(ids, self._mine(y), state)


def as_flight_software(controller, n):
    """The controller as the engine calls it: a ``local`` part wrapped per spacecraft, any
    other part as it is.

    Parameters
    ----------
    controller : part
    n : int
        Number of spacecraft (static).
    """
    return _PerSpacecraft(controller, n) if getattr(controller, "local", False) else controller
