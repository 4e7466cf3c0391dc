"""coopsat's flight-software host: one spacecraft's part of the controller in its own process
(``python -m coopsat.workflows.sil.fsw``, started by the simulator; docs/sil.md).

It knows its spacecraft from ``COOPSAT_SIL_NAME``, its simulator from
``COOPSAT_SIL_ENDPOINT`` and ``COOPSAT_SIL_PARENT``, and what to fly from the ``setup``
message: the controller part (pickled by the simulator, its parent) and which links are
addressed to it. Each period it runs the part's ``outbox_one`` on its own readings and its
``step_one`` on its inbox, as the compiled loop runs them per spacecraft
(:mod:`coopsat.sim.flight_software`): the same functions on the same numbers, jitted. It keeps
its own controller state; it sees nothing of any other spacecraft but what arrives on its
links.
"""

import os
import pickle
import signal
import sys

from coopsat.workflows.sil import protocol

IDLE_CHECK_MS = 1000
"""Longest wait for a message before the host checks that its simulator still exists."""


class OneSpacecraft:
    """One spacecraft's flight software: the controller part, its index, its state.

    Parameters
    ----------
    part : controller part
        With ``reads``, ``outbox_one`` and ``step_one`` (a LocalController, or a formation-wide
        law offering its per-spacecraft form).
    index : int
        The spacecraft's index i.
    n : int
        Spacecraft in the formation (the part's ``init`` is the formation's).
    dst : int (E,)
        Receiver of every link, flat (as the compiled loop flattens them).
    mine : int (m,)
        The links addressed to i, indices into ``dst``.
    """

    def __init__(self, part, index, n, dst, mine):
        import jax
        import numpy as np

        self.part = part
        self.i = np.int64(index)
        self.dst = np.asarray(dst, np.int64)
        self.mine = np.asarray(mine, np.int64)
        self.state = jax.tree_util.tree_map(lambda a: a[..., index], part.init(n))
        self.y = None
        self._outbox = jax.jit(_outbox)
        self._step = jax.jit(_step)

    def outbox(self, y):
        """This period's broadcast from the readings ``y`` (``{quantity: (k,)}``), kept for
        :meth:`step`; float64, as the protocol's schema says every number is."""
        import numpy as np

        self.y = {q: np.asarray(v, np.float64) for q, v in y.items()}
        return {k: np.asarray(v, np.float64) for k, v in self._outbox(self.part, self.i, self.y, self.state).items()}

    def step(self, t, msg, weight, key, own=None):
        """This period's commands and record from the messages on the links addressed to it
        (``msg``: ``{name: (k, m)}``, ``weight``: (m,)), its key (uint32 (2,)) and, for a part
        that ``reads_own``, its own outbox of the instant each message was sent (``own``, as
        ``msg``). Both float64, as the protocol's schema says every number is."""
        import numpy as np

        msg = {k: np.asarray(v, np.float64) for k, v in msg.items()}
        own = {k: np.asarray(v, np.float64) for k, v in (own or {}).items()}
        commands, self.state, record = self._step(self.part, self.i, np.float64(t), self.y, msg,
                                                  np.asarray(weight, np.float64), self.state,
                                                  np.asarray(key, np.uint32), self.dst, self.mine, own)
        return ({k: np.asarray(v, np.float64) for k, v in commands.items()},
                {k: np.asarray(v, np.float64) for k, v in record.items()})

    def warm_up(self, reads):
        """Compile both functions once on zeros (``reads``: ``{quantity: shape}``), leaving the
        state as it is, so that the first period is not late."""
        import numpy as np

        from coopsat.plugins.protocols import optional

        y = {q: np.zeros(shape) for q, shape in reads.items()}
        msg = self._outbox(self.part, self.i, y, self.state)
        zeros = {k: np.zeros((*np.shape(v), len(self.mine))) for k, v in msg.items()}
        own = zeros if optional(self.part, "reads_own") else {}
        self._step(self.part, self.i, np.float64(0.0), y, zeros, np.zeros(len(self.mine)), self.state,
                   np.zeros(2, np.uint32), self.dst, self.mine, own)


def _outbox(part, i, y_i, state_i):
    return part.outbox_one(i, y_i, state_i)


def _step(part, i, t, y_i, msg_mine, weight_mine, state_i, key_i, dst, mine, own_mine):
    """``step_one`` on the inbox the compiled loop gives spacecraft i
    (:mod:`coopsat.sim.flight_software`): one flat link axis, the links not addressed to i
    zeroed (message, weight and ``own``), ``own`` empty unless the part ``reads_own``."""
    import jax.numpy as jnp

    from coopsat.network.delivery import Inbox

    e = dst.shape[0]
    spread = lambda m: jnp.zeros((*m.shape[:-1], e), m.dtype).at[..., mine].set(m)  # noqa: E731
    msg = {k: spread(m) for k, m in msg_mine.items()}
    own = {k: spread(m) for k, m in own_mine.items()}
    inbox = Inbox(msg=msg, weight=jnp.zeros(e).at[mine].set(weight_mine), dst=dst, own=own)
    return part.step_one(i, t, y_i, inbox, state_i, key_i)


def _wait(sock, parent):
    """The next message; exits when the simulator (``parent``) is gone."""
    while not sock.poll(IDLE_CHECK_MS):
        if os.getppid() != parent:
            sys.exit(1)
    return protocol.decode(sock.recv())


def _newest(sock, message):
    """The newest of ``message`` and those already waiting behind it: a host that has fallen
    behind a realtime schedule answers the latest period, as a flight computer that overran
    takes the latest reading (the simulator discards answers to periods it has closed)."""
    while sock.poll(0):
        message = protocol.decode(sock.recv())
    return message


def _serve(sock, parent):
    """Handshake, then answer every period until ``stop``."""
    setup = _wait(sock, parent)
    if setup["type"] != protocol.SETUP:
        raise RuntimeError(f"expected setup, got {setup['type']}")
    import jax

    from coopsat.core import runtime

    # Two small programs a period: inline on the CPU they cost less than handed to a thread
    # (set before JAX's CPU client starts; this process is coopsat's own).
    jax.config.update("jax_cpu_enable_async_dispatch", False)
    runtime.enable()  # float64, as in the simulator
    host = OneSpacecraft(pickle.loads(setup["part"]), setup["index"], len(setup["names"]), setup["links"]["dst"],
                         setup["links"]["mine"])
    host.warm_up(setup["reads"])
    sock.send(protocol.encode({"type": protocol.READY}))
    while True:
        message = _newest(sock, _wait(sock, parent))
        kind, k = message["type"], message.get("k")
        if kind == protocol.SENSE:
            reply = {"type": protocol.OUTBOX, "k": k, "msg": protocol.lists(host.outbox(message["y"]))}
        elif kind == protocol.INBOX:
            commands, record = host.step(message["t"], message["msg"], message["weight"], message["key"],
                                         message.get("own"))
            reply = {"type": protocol.COMMAND, "k": k, "commands": protocol.lists(commands),
                     "record": protocol.lists(record)}
        elif kind == protocol.STOP:
            return
        else:
            raise RuntimeError(f"unexpected message '{kind}'")
        sock.send(protocol.encode(reply))


def main():
    """Run one spacecraft's flight software until the simulator says stop or goes away."""
    import zmq

    for sig in (signal.SIGINT, signal.SIGTERM):  # a Ctrl-C reaches the whole group: leave quietly
        signal.signal(sig, lambda signum, frame: os._exit(128 + signum))
    name, parent = os.environ[protocol.NAME_ENV], int(os.environ[protocol.PARENT_ENV])
    ctx = zmq.Context()
    sock = ctx.socket(zmq.DEALER)
    sock.linger = 0
    sock.connect(os.environ[protocol.ENDPOINT_ENV])
    sock.send(protocol.encode(protocol.hello(name)))
    try:
        _serve(sock, parent)
    except Exception as err:  # noqa: BLE001 - whatever fails, the simulator hears it in one line
        sock.send(protocol.encode({"type": protocol.ERROR, "message": f"{type(err).__name__}: {err}"}))
        sock.close(linger=1000)  # let the line reach the simulator before the process ends
        raise
    finally:
        sock.close(0)
        ctx.term()


if __name__ == "__main__":
    main()
