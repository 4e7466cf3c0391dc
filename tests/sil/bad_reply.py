"""A flight software written from docs/sil.md alone that builds every reply from the schema its
``setup`` carries (``replies``): zeros of each shape, as float64. ``python bad_reply.py MODE``:
``zeros`` answers well-formed replies; ``no-record`` sends its commands without their record
(``record`` empty), ``short-record`` each record field one number short (tests/sil/test_sil.py)."""

import os
import sys

import msgpack
import zmq

MODE = sys.argv[1]


def zeros(shape):
    """Nested lists of 0.0 of ``shape`` (component first)."""
    return [zeros(shape[1:]) for _ in range(shape[0])] if shape else 0.0


def fields(table):
    """``{name: zeros}`` of a schema table ``{name: {"shape", "dtype"}}``."""
    return {name: zeros(spec["shape"]) for name, spec in table.items()}


sock = zmq.Context().socket(zmq.DEALER)
sock.linger = 0
sock.connect(os.environ["COOPSAT_SIL_ENDPOINT"])
send = lambda m: sock.send(msgpack.packb(m, use_bin_type=True))  # noqa: E731
send({"type": "hello", "version": 1, "name": os.environ["COOPSAT_SIL_NAME"]})
replies = None
while sock.poll(30000):
    m = msgpack.unpackb(sock.recv(), raw=False)
    if m["type"] == "setup":
        replies = m["replies"]
        send({"type": "ready"})
    elif m["type"] == "sense":
        send({"type": "outbox", "k": m["k"], "msg": fields(replies["outbox"]["msg"])})
    elif m["type"] == "inbox":
        record = fields(replies["command"]["record"])
        if MODE == "no-record":
            record = {}
        elif MODE == "short-record":
            record = {name: value[:-1] for name, value in record.items()}
        send({"type": "command", "k": m["k"], "commands": fields(replies["command"]["commands"]), "record": record})
    else:
        break
