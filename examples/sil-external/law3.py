"""Law (3) of the 2010 consensus paper as one spacecraft's flight software, outside coopsat.

    u_i = −Σ_j a_ij [ α vec(q_j* ⊗ q_i) + β (ω_i − ω_j) ]

It speaks the SIL protocol of docs/sil.md (version 1) and imports only pyzmq, msgpack and
numpy, so that any program in any language can take a spacecraft's place the same way:

    coopsat sil consensus-sync-a-stable --out runs/sil-ext \\
        --external sat2="python examples/sil-external/law3.py"

The simulator starts it with three environment variables: COOPSAT_SIL_ENDPOINT (where to
connect), COOPSAT_SIL_NAME (which spacecraft it flies) and COOPSAT_SIL_PARENT (the simulator's
process id: when the simulator is gone, so is the reason to run).
"""

import os
import sys

import msgpack
import numpy as np
import zmq

VERSION = 1


def send(sock, message):
    sock.send(msgpack.packb(message, use_bin_type=True))


def receive(sock, parent):
    """The next message; leave when the simulator is gone (never wait forever)."""
    while not sock.poll(1000):
        if os.getppid() != parent:
            sys.exit(1)
    return msgpack.unpackb(sock.recv(), raw=False)


def error_vector(q_i, q_j, short_way):
    """vec(q_j* ⊗ q_i) for q_i (4,) and the heard attitudes q_j (4, m): (3, m)."""
    a0, a1, a2, a3 = q_j[0], -q_j[1], -q_j[2], -q_j[3]  # q_j*
    b0, b1, b2, b3 = q_i
    e0 = a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3
    vec = np.stack([a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
                    a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
                    a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0])
    return np.where(e0 < 0.0, -vec, vec) if short_way else vec


def law3(q_i, omega_i, q_msg, omega_msg, weight, alpha, beta, short_way):
    """u_i (3,) N·m from the spacecraft's own q_i (4,), ω_i (3,) rad/s and its m links: the heard
    q (4, m), ω (3, m) and the weights a_ij (m,)."""
    per_link = weight * (alpha * error_vector(q_i, q_msg, short_way) + beta * (omega_i[:, None] - omega_msg))
    return -per_link.sum(axis=-1)


def main():
    name, parent = os.environ["COOPSAT_SIL_NAME"], int(os.environ["COOPSAT_SIL_PARENT"])
    sock = zmq.Context().socket(zmq.DEALER)
    sock.linger = 0
    sock.connect(os.environ["COOPSAT_SIL_ENDPOINT"])
    send(sock, {"type": "hello", "version": VERSION, "name": name})
    setup = receive(sock, parent)
    table = setup["controller"]
    if setup["type"] != "setup" or setup["version"] != VERSION or table["kind"] != "consensus-sync":
        send(sock, {"type": "error", "message": f"law3.py flies consensus-sync (law 3), not {table['kind']}"})
        return 1
    alpha, beta, short_way = table["alpha"], table["beta"], table.get("short_way", False)
    send(sock, {"type": "ready"})
    y = None
    while True:
        m = receive(sock, parent)
        if m["type"] == "sense":  # broadcast my own measured attitude and rate
            y = {q: np.array(v) for q, v in m["y"].items()}
            send(sock, {"type": "outbox", "k": m["k"], "msg": {"q": m["y"]["q"], "omega": m["y"]["omega"]}})
        elif m["type"] == "inbox":  # the links addressed to me: command my torque
            u = law3(y["q"], y["omega"], np.array(m["msg"]["q"]).reshape(4, -1), np.array(m["msg"]["omega"]).reshape(3, -1),
                     np.array(m["weight"]), alpha, beta, short_way)
            send(sock, {"type": "command", "k": m["k"], "commands": {"torque_b": u.tolist()},
                        "record": {"torque_command": u.tolist()}})
        elif m["type"] == "stop":
            return 0


if __name__ == "__main__":
    sys.exit(main())
