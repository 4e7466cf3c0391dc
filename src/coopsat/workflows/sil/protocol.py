"""The messages between the simulator and a flight-software process (docs/sil.md, version 1).

Transport: ZeroMQ. The simulator binds one ROUTER socket at the endpoint it gives each
flight-software process in ``COOPSAT_SIL_ENDPOINT`` (``ipc://`` in a private folder, or
``tcp://127.0.0.1:PORT``); a flight-software process connects one DEALER socket to it. Every
message is one frame: a msgpack map with a ``type``. Numbers are msgpack floats (IEEE float64,
so nothing is rounded on the way), arrays are nested lists, component first (a link array is
``[component][link]``). A process names itself in ``hello``; the simulator answers every later
message on the socket that said it.

Per control period ``k`` the simulator sends ``sense`` (the spacecraft's own readings) and
waits for ``outbox`` (its broadcast), then, once the network has delivered every broadcast,
sends ``inbox`` (the links addressed to it) and waits for ``command``. Every message after
``setup`` carries ``k``; an answer to an earlier period is discarded, and anything else out of
turn or out of shape ends the run (:mod:`~coopsat.workflows.sil.schema`, which also holds the
schema of the replies that ``setup`` tells each process).

This module depends on msgpack only: the external example (examples/sil-external/law3.py)
restates it without importing coopsat.
"""

import msgpack

VERSION = 1
"""The message format's version: ``hello`` and ``setup`` carry it, and a process that speaks
another is refused at the handshake."""

ENDPOINT_ENV = "COOPSAT_SIL_ENDPOINT"
"""Environment variable: the endpoint a flight-software process connects to."""
NAME_ENV = "COOPSAT_SIL_NAME"
"""Environment variable: the spacecraft a flight-software process flies (``sat3``)."""
PARENT_ENV = "COOPSAT_SIL_PARENT"
"""Environment variable: the simulator's process id; a flight-software process whose parent is
another has lost its simulator and exits."""

HELLO, SETUP, READY, SENSE, OUTBOX, INBOX, COMMAND, STOP, ERROR = (
    "hello", "setup", "ready", "sense", "outbox", "inbox", "command", "stop", "error"
)


def encode(message):
    """A message (dict) as one frame of bytes."""
    return msgpack.packb(message, use_bin_type=True)


def decode(frame):
    """One frame back as a dict (raises ValueError for anything that is not a message)."""
    try:
        message = msgpack.unpackb(frame, raw=False)
    except Exception as err:  # msgpack's several exception types: one meaning here
        raise ValueError(f"not a message of the SIL protocol (msgpack: {str(err) or type(err).__name__})") from None
    if not isinstance(message, dict) or not isinstance(message.get("type"), str):
        raise ValueError("not a message of the SIL protocol (a map with a 'type')")
    return message


def hello(name):
    """A flight-software process's first message: who it is and the version it speaks."""
    return {"type": HELLO, "version": VERSION, "name": name}


def lists(arrays):
    """``{name: ndarray}`` as ``{name: nested list of float}`` (float64 kept exactly)."""
    return {k: v.tolist() for k, v in arrays.items()}
