"""What a flight-software process may send, and the one check every message from it passes
(docs/sil.md, "The protocol").

The arrays a process sends are described by one *schema*, built here once per run
(:func:`replies_schema`) and sent to each process in its ``setup`` (``replies``); the simulator
checks every reply against the schema it sent (:func:`check_reply`), so what a process is told
and what it is held to cannot differ. Every message from a process holds exactly its fields:
``hello`` its ``type``, ``version`` and ``name``; ``ready`` its ``type``; ``outbox`` its
``type``, ``k`` and ``msg``; ``command`` its ``type``, ``k``, ``commands`` and ``record``
(``error``, with its ``message``, ends the run: it is quoted, never refused).

An array is nested lists of numbers, component first, of exactly its shape; a number is a
msgpack float or integer (taken as float64), finite. Anything else (a missing, extra or
misspelled field, another shape or nesting, a string, a boolean, NaN or infinity, a frame over
:data:`MAX_FRAME_BYTES`, a reply out of turn) is a :class:`SILError` of one line naming the
spacecraft and the field: the run ends with it (status 2 on the command line).
"""

import math

import numpy as np

from coopsat.core.errors import ExternalProcessError, InputError
from coopsat.workflows.sil import protocol

MAX_FRAME_BYTES = 1 << 20
"""Largest message a flight software may send, bytes: every reply of a bundled law is under
2 KiB; a larger one is a mistake, refused before it is decoded."""

DTYPE = "float64"
"""The type of every number a flight software sends (the simulator's arithmetic)."""

_SHOWN = 40
"""Longest quotation of a received value in an error line, characters."""

_FIELDS = {
    protocol.HELLO: ("type", "version", "name"),
    protocol.READY: ("type",),
    protocol.OUTBOX: ("type", "k", "msg"),
    protocol.COMMAND: ("type", "k", "commands", "record"),
}
"""The fields of each message a flight software sends (``error`` aside: it ends the run)."""


class SILError(ExternalProcessError):
    """A flight-software process that did not start, did not answer in time or broke the
    protocol (one line naming the spacecraft and the field; exit status 2)."""


class SILSetupError(InputError):
    """A SIL run that cannot start as asked: a law with no per-spacecraft form, a fault record
    or an external command that cannot be used (one line naming the option; exit status 2)."""


def replies_schema(outbox, commands, record):
    """The schema of a flight software's replies, as ``setup`` carries it (``replies``).

    Parameters
    ----------
    outbox, commands, record : dict of str -> tuple of int
        Shape of each field of the broadcast (``outbox``'s ``msg``), of each command (N·m or N,
        (3,)) and of each recorded quantity (``command``'s ``record``), one spacecraft's.

    Returns
    -------
    dict
        ``{reply type: {map field: {name: {"shape": [int…], "dtype": "float64"}}}}``: for
        ``outbox`` its ``msg``, for ``command`` its ``commands`` and ``record``.
    """
    table = lambda shapes: {k: {"shape": [int(d) for d in s], "dtype": DTYPE} for k, s in shapes.items()}  # noqa: E731
    return {protocol.OUTBOX: {"msg": table(outbox)},
            protocol.COMMAND: {"commands": table(commands), "record": table(record)}}


def read(name, frames):
    """A message from a flight software (its ZeroMQ frames: one) as a map with a ``type``;
    ``name``: the spacecraft that sent it, None before its hello.

    Raises
    ------
    SILError
        Not one frame, a frame over :data:`MAX_FRAME_BYTES` or not a msgpack map with a
        ``type``; and an ``error`` message, quoted (its first 200 characters, on one line).
    """
    who = name or "a flight-software process before its hello"
    if len(frames) != 1:
        raise SILError(f"{who}: a message of {len(frames)} ZeroMQ frames (a message is one frame)")
    frame = frames[0]
    if len(frame) > MAX_FRAME_BYTES:
        raise SILError(f"{who}: a message of {len(frame)} bytes (at most {MAX_FRAME_BYTES})")
    try:
        message = protocol.decode(frame)
    except ValueError as err:
        raise SILError(f"{who}: {err}") from None
    if message["type"] == protocol.ERROR:
        text = message.get("message")
        line = " ".join(text.split())[:200] if isinstance(text, str) else "(no message)"
        raise SILError(f"{name}'s flight software failed: {line}" if name else f"{who} failed: {line}")
    return message


def check_hello(message, waiting):
    """The spacecraft a ``hello`` names (``waiting``: the spacecraft not yet heard from).

    Raises
    ------
    SILError
        Another message, other fields, a name not waited for, another protocol version.
    """
    if message["type"] != protocol.HELLO:
        raise SILError(f"a flight-software process sent {_show(message['type'])} before its hello")
    _check_fields("a flight-software process: hello", protocol.HELLO, message)
    name = message["name"]
    if not isinstance(name, str) or name not in waiting:
        raise SILError(f"a flight-software process said hello as {_show(name)}, which is not a spacecraft waiting for "
                       f"one (expected one of {', '.join(waiting)})")
    if type(message["version"]) is not int or message["version"] != protocol.VERSION:
        raise SILError(f"{name}'s flight software speaks SIL protocol version {_show(message['version'])}; this "
                       f"simulator speaks {protocol.VERSION}")
    return name


def check_ready(name, message):
    """Raises :class:`SILError` unless ``message`` is ``ready`` and nothing else."""
    if message["type"] != protocol.READY:
        raise SILError(f"{name}: sent {_show(message['type'])} during the handshake (expected 'ready')")
    _check_fields(f"{name}: ready", protocol.READY, message)


def check_reply(name, message, answer, k, schema, awaited):
    """Spacecraft ``name``'s ``message`` checked against its ``schema`` while the simulator
    collects the ``answer`` replies (``"outbox"`` or ``"command"``) of period ``k``.

    Parameters
    ----------
    name : str
    message : dict
        As :func:`read` returns it.
    answer : str
        The reply type this round collects.
    k : int
        The period of the round.
    schema : dict
        :func:`replies_schema`'s, as that spacecraft's ``setup`` carried it.
    awaited : bool
        The round still waits for this spacecraft's answer (it was sent the round's message and
        has not answered it).

    Returns
    -------
    dict or None
        The reply with its arrays as float64 ndarrays of their shapes (``{"type", "k", field:
        {name: ndarray}}``); None for a late answer, which is discarded: one to an earlier
        period, or an ``outbox`` of period ``k`` that came after its deadline (the round then
        collects commands without it).

    Raises
    ------
    SILError
        Any other message (the module docstring), in one line naming the spacecraft and field.
    """
    kind = message["type"]
    if kind not in schema:
        raise SILError(f"{name}: sent {_show(kind)} in period {k} (expected its {answer} reply)")
    where = f"{name}: {kind} reply"
    _check_fields(where, kind, message)
    period = message["k"]
    if type(period) is not int or period < 0:
        raise SILError(f"{where}: field 'k' holds {_show(period)} (expected the period, an integer from 0)")
    checked = {"type": kind, "k": period}
    for field, table in schema[kind].items():
        checked[field] = _check_map(f"{where}: {field}", message[field], table)
    if period > k:
        raise SILError(f"{where} for period {period} during period {k} (a period not begun)")
    if period < k or (kind == protocol.OUTBOX and answer == protocol.COMMAND and not awaited):
        return None
    if kind != answer:
        raise SILError(f"{where} for period {k} before its inbox")
    if not awaited:
        raise SILError(f"{where} for period {k} that was not asked for (a second answer, or one to a message it was "
                       f"not sent)")
    return checked


def _check_fields(where, kind, message):
    """Raises :class:`SILError` unless ``message`` holds exactly the fields of a ``kind``."""
    expected = _FIELDS[kind]
    if len(message) == len(expected) and all(f in message for f in expected):
        return
    missing = [f for f in expected if f not in message]
    extra = [f for f in message if f not in expected]
    what = f"{_show(missing[0])} missing" if missing else f"{_show(extra[0])} unexpected"
    raise SILError(f"{where}: field {what} (expected fields: {', '.join(expected)})")


def _check_map(where, value, table):
    """``{name: ndarray}`` from a received map that must hold exactly ``table``'s arrays
    (``{name: {"shape", "dtype"}}``); ``where`` begins an error line."""
    if type(value) is not dict:
        expected = ", ".join(f"{k} {_expected(spec)}" for k, spec in table.items()) or "nothing"
        raise SILError(f"{where} holds {_show(value)} (expected a map: {expected})")
    if value.keys() != table.keys():
        missing = [k for k in table if k not in value]
        if missing:
            raise SILError(f"{where} field {_show(missing[0])} missing (expected {_expected(table[missing[0]])})")
        extra = next(k for k in value if k not in table)
        raise SILError(f"{where} field {_show(extra)} unexpected (expected only {', '.join(table) or 'nothing'})")
    return {k: _check_array(where, k, value[k], spec) for k, spec in table.items()}


def _check_array(where, key, value, spec):
    """A received nested list (``where``'s field ``key``) as a finite float64 ndarray of
    ``spec``'s shape. Walked level by level, never deeper than the shape (a received nesting may
    be deep), with the builtins' type tests: a reply's dozen numbers cost a few microseconds."""
    shape = spec["shape"]
    level = [value]
    for n in shape:
        for v in level:
            if type(v) is not list or len(v) != n:
                raise SILError(f"{where} field {_show(key)} {_found(value)} (expected {_expected(spec)})")
        level = [x for v in level for x in v]
    for v in level:
        if type(v) is not float and type(v) is not int:  # bool is not a number here
            raise SILError(f"{where} field {_show(key)} {_found(value)} (expected {_expected(spec)})")
    if not all(map(math.isfinite, level)):
        bad = next(v for v in level if not math.isfinite(v))
        raise SILError(f"{where} field {_show(key)} holds {bad}, not a finite number (expected {_expected(spec)})")
    return np.array(level, np.float64).reshape(shape)


def _found(value):
    """What a received value that is not the expected array is, in a few words: its shape
    (followed through first elements), or the first thing in it that is not a number."""
    dims, first = [], value
    while type(first) is list and first:
        dims.append(len(first))
        first = first[0]
    if type(first) is list:  # an empty list at the bottom
        dims.append(0)
    elif type(first) not in (float, int):
        return f"holds {_show(first)}"
    level = [value]
    for n in dims:
        if any(type(v) is not list or len(v) != n for v in level):
            return "is ragged (nested lists of unequal lengths or depths)"
        level = [x for v in level for x in v]
    bad = next((v for v in level if type(v) not in (float, int)), None)
    return f"holds {_show(bad)}" if bad is not None else f"has shape {tuple(dims)}"


def _expected(spec):
    return f"{spec['dtype']} shape {tuple(spec['shape'])}"


def _show(value):
    """``repr`` of a received value, cut to :data:`_SHOWN` characters (one line: repr escapes
    line breaks)."""
    text = repr(value)
    return text if len(text) <= _SHOWN else text[: _SHOWN - 1] + "…"
