"""A flight software that speaks the protocol but broadcasts the wrong shape: a 3-vector where
law (3) broadcasts its quaternion (tests/sil/test_sil.py)."""

import os

import msgpack
import zmq

sock = zmq.Context().socket(zmq.DEALER)
sock.linger = 0
sock.connect(os.environ["COOPSAT_SIL_ENDPOINT"])
send = lambda m: sock.send(msgpack.packb(m, use_bin_type=True))  # noqa: E731
send({"type": "hello", "version": 1, "name": os.environ["COOPSAT_SIL_NAME"]})
while True:
    if not sock.poll(30000):
        break
    m = msgpack.unpackb(sock.recv(), raw=False)
    if m["type"] == "setup":
        send({"type": "ready"})
    elif m["type"] == "sense":
        send({"type": "outbox", "k": m["k"], "msg": {"q": [0.0, 0.0, 1.0], "omega": m["y"]["omega"]}})
    else:
        break
