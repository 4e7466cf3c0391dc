"""The check every message from a flight software passes (coopsat.workflows.sil.schema):
random and malformed messages, decoded from msgpack as the simulator decodes them, are either
accepted (a well-formed reply in its turn) or refused with a SILError of one line naming the
spacecraft and the field, never another exception. Pure functions: no process starts."""

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from coopsat.workflows.sil import protocol, schema
from coopsat.workflows.sil.schema import SILError

NAME = "sat3"
KINDS = (protocol.OUTBOX, protocol.COMMAND)

names = st.text("abcdefgh_", min_size=1, max_size=6)
shapes = st.lists(st.integers(0, 3), max_size=2).map(tuple)
tables = st.dictionaries(names, shapes, max_size=3)
schemas = st.builds(schema.replies_schema, tables, tables, tables)
finite = st.floats(allow_nan=False, allow_infinity=False) | st.integers(-(2**63), 2**64 - 1)
leaves = (st.none() | st.booleans() | st.integers(-(2**63), 2**64 - 1) | st.floats() | st.text(max_size=4)
          | st.binary(max_size=4))
values = st.recursive(leaves, lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=3), inner,
                                                                                          max_size=3), max_leaves=12)
"""Anything msgpack carries."""


def _array(draw, shape):
    return [_array(draw, shape[1:]) for _ in range(shape[0])] if shape else draw(finite)


@st.composite
def replies(draw, kind=None):
    """(schema, a well-formed reply of a type to it) for period 0–9."""
    table = draw(schemas)
    kind = kind or draw(st.sampled_from(KINDS))
    message = {"type": kind, "k": draw(st.integers(0, 9))}
    for field, arrays in table[kind].items():
        message[field] = {name: _array(draw, spec["shape"]) for name, spec in arrays.items()}
    return table, message


def _decoded(message):
    """The message as the simulator receives it: encoded, sent, read back."""
    return schema.read(NAME, [protocol.encode(message)])


def _one_line(err):
    text = str(err)
    assert "\n" not in text and len(text) < 400, text
    return text


@settings(max_examples=200, deadline=None)
@given(replies())
def test_a_well_formed_reply_in_its_turn_is_accepted_as_float64_arrays(drawn):
    table, message = drawn
    reply = schema.check_reply(NAME, _decoded(message), message["type"], message["k"], table, awaited=True)
    for field, arrays in table[message["type"]].items():
        assert reply[field].keys() == arrays.keys()
        for name, spec in arrays.items():
            got = reply[field][name]
            assert got.dtype == np.float64 and got.shape == tuple(spec["shape"])
            np.testing.assert_array_equal(got, np.asarray(message[field][name], np.float64).reshape(got.shape))


@settings(max_examples=200, deadline=None)
@given(replies(), st.sampled_from(KINDS), st.integers(0, 9), st.booleans())
def test_a_reply_out_of_turn_is_discarded_when_late_else_refused(drawn, answer, k, awaited):
    """Accepted: the round's reply type, its period, awaited. Discarded (None): an answer to an
    earlier period, or an outbox that missed its deadline (not awaited in the command round).
    Anything else (a later period, a command before its inbox, a second answer): refused."""
    table, message = drawn
    kind, period = message["type"], message["k"]
    late = period < k or (period == k and kind == protocol.OUTBOX and answer == protocol.COMMAND and not awaited)
    if kind == answer and period == k and awaited:
        assert schema.check_reply(NAME, _decoded(message), answer, k, table, awaited)["k"] == k
    elif late:
        assert schema.check_reply(NAME, _decoded(message), answer, k, table, awaited) is None
    else:
        with pytest.raises(SILError) as err:
            schema.check_reply(NAME, _decoded(message), answer, k, table, awaited)
        assert _one_line(err.value).startswith(f"{NAME}: {kind} reply for period {period} ")


def _is_array(value, shape):
    """``value`` is nested lists of finite numbers (not booleans) of ``shape``."""
    if not shape:
        return type(value) in (float, int) and math.isfinite(value)
    return type(value) is list and len(value) == shape[0] and all(_is_array(v, shape[1:]) for v in value)


@settings(max_examples=300, deadline=None)
@given(replies(), values, st.data())
def test_any_wrong_value_of_an_array_is_refused_naming_the_field(drawn, wrong, data):
    table, message = drawn
    kind = message["type"]
    arrays = [(field, name) for field, t in table[kind].items() for name in t]
    assume(arrays)
    field, name = data.draw(st.sampled_from(arrays))
    shape = tuple(table[kind][field][name]["shape"])
    assume(not _is_array(wrong, shape))
    message[field][name] = wrong
    with pytest.raises(SILError) as err:
        schema.check_reply(NAME, _decoded(message), kind, message["k"], table, awaited=True)
    assert _one_line(err.value).startswith(f"{NAME}: {kind} reply: {field} field {name!r} ")
    assert f"(expected float64 shape {shape})" in str(err.value)


@settings(max_examples=200, deadline=None)
@given(replies(), names, values, st.data())
def test_a_missing_or_extra_name_in_a_map_is_refused_naming_it(drawn, extra, value, data):
    table, message = drawn
    kind = message["type"]
    field = data.draw(st.sampled_from(sorted(table[kind])))
    if table[kind][field] and data.draw(st.booleans()):
        name = data.draw(st.sampled_from(sorted(table[kind][field])))
        del message[field][name]
        says = f"{field} field {name!r} missing"
    else:
        assume(extra not in table[kind][field])
        message[field][extra] = value
        says = f"{field} field {extra!r} unexpected"
    with pytest.raises(SILError) as err:
        schema.check_reply(NAME, _decoded(message), kind, message["k"], table, awaited=True)
    assert _one_line(err.value).startswith(f"{NAME}: {kind} reply: {says} ")


@settings(max_examples=200, deadline=None)
@given(replies(), st.text("abcdefghkt_ ", max_size=6), values, st.data())
def test_a_missing_extra_or_wrong_top_level_field_is_refused_naming_it(drawn, extra, value, data):
    table, message = drawn
    kind = message["type"]
    how = data.draw(st.sampled_from(["missing", "unexpected", "wrong"]))
    if how == "missing":
        field = data.draw(st.sampled_from([f for f in message if f != "type"]))
        del message[field]
    elif how == "unexpected":
        field = extra
        assume(field not in message)
        message[field] = value
    else:
        field = data.draw(st.sampled_from([f for f in message if f != "type"]))
        assume(type(value) is not (dict if field != "k" else int))
        message[field] = value
    with pytest.raises(SILError) as err:
        schema.check_reply(NAME, _decoded(message), kind, 9, table, awaited=True)
    line = _one_line(err.value)
    assert line.startswith(f"{NAME}: {kind} reply: ")
    says = f"field {field!r} {how}" if how != "wrong" else "field 'k' holds" if field == "k" else f"{field} holds"
    assert says in line


@settings(max_examples=300, deadline=None)
@given(schemas, st.sampled_from(KINDS), st.dictionaries(st.sampled_from(["type", "k", "msg", "commands", "record", "x"]),
                                                        values, max_size=5))
def test_any_map_is_accepted_or_refused_in_one_line(table, answer, message):
    """Whatever map comes (a type or none, any fields of any value): a reply, None, or one line
    naming the spacecraft."""
    try:
        decoded = _decoded(message)
        schema.check_reply(NAME, decoded, answer, 5, table, awaited=True)
    except SILError as err:
        assert _one_line(err).startswith((f"{NAME}: ", f"{NAME}'s flight software failed: "))


@settings(max_examples=300, deadline=None)
@given(st.lists(st.binary(max_size=64) | values.map(protocol.encode), max_size=3))
def test_any_frames_are_read_or_refused_in_one_line(frames):
    try:
        message = schema.read(NAME, frames)
    except SILError as err:
        assert _one_line(err).startswith((f"{NAME}: ", f"{NAME}'s flight software failed: "))
    else:
        assert isinstance(message, dict) and isinstance(message["type"], str)


@settings(max_examples=200, deadline=None)
@given(st.dictionaries(st.sampled_from(["type", "version", "name", "x"]), values | st.sampled_from(["hello", "sat3"]),
                       max_size=4))
def test_any_first_message_is_a_hello_or_refused_in_one_line(message):
    try:
        assert schema.check_hello(_decoded(message), ["sat1", NAME]) in ("sat1", NAME)
    except SILError as err:
        _one_line(err)


def test_the_schema_setup_carries_is_the_one_replies_are_checked_against():
    """msgpack carries the schema unchanged (setup's ``replies``); its names, shapes and dtype."""
    table = schema.replies_schema({"q": (4,), "omega": (3,)}, {"torque_b": (3,)}, {"torque_command": (3,)})
    assert protocol.decode(protocol.encode({"type": "setup", "replies": table}))["replies"] == table
    assert table["command"]["record"] == {"torque_command": {"shape": [3], "dtype": "float64"}}
    assert table["outbox"]["msg"]["q"] == {"shape": [4], "dtype": "float64"}


@pytest.mark.parametrize("frames, says", [
    ([b"\xc1"], "sat3: not a message of the SIL protocol (msgpack: FormatError)"),
    ([protocol.encode([1.0])], "sat3: not a message of the SIL protocol (a map with a 'type')"),
    ([b"\x00" * (schema.MAX_FRAME_BYTES + 1)], f"sat3: a message of {schema.MAX_FRAME_BYTES + 1} bytes (at most "
                                               f"{schema.MAX_FRAME_BYTES})"),
    ([protocol.encode({"type": "ready"})] * 2, "sat3: a message of 2 ZeroMQ frames (a message is one frame)"),
    ([protocol.encode({"type": "error", "message": "ValueError: x\n  more"})],
     "sat3's flight software failed: ValueError: x more"),
])
def test_frames_that_are_not_messages(frames, says):
    with pytest.raises(SILError) as err:
        schema.read(NAME, frames)
    assert str(err.value) == says


TABLE = schema.replies_schema({"q": (4,), "omega": (3,)}, {"torque_b": (3,)}, {"torque_command": (3,)})
GOOD = {"type": "command", "k": 5, "commands": {"torque_b": [0.0, 0.0, 0.0]}, "record": {"torque_command": [0.0, 0.0, 0.0]}}


@pytest.mark.parametrize("change, says", [
    ({"record": {}}, "record field 'torque_command' missing (expected float64 shape (3,))"),
    ({"record": {"torque_command": [0.0, 0.0]}}, "record field 'torque_command' has shape (2,) (expected float64 shape (3,))"),
    ({"commands": {"torque_b": [0.0, float("nan"), 0.0]}},
     "commands field 'torque_b' holds nan, not a finite number (expected float64 shape (3,))"),
    ({"commands": {"torque_b": [0.0, "1", 0.0]}}, "commands field 'torque_b' holds '1' (expected float64 shape (3,))"),
    ({"commands": {"torque_b": [[0.0], [0.0, 1.0], 0.0]}},
     "commands field 'torque_b' is ragged (nested lists of unequal lengths or depths) (expected float64 shape (3,))"),
    ({"record": [0.0, 0.0, 0.0]}, "record holds [0.0, 0.0, 0.0] (expected a map: torque_command float64 shape (3,))"),
    ({"k": 5.0}, "field 'k' holds 5.0 (expected the period, an integer from 0)"),
    ({"t": 0.5}, "field 't' unexpected (expected fields: type, k, commands, record)"),
])
def test_the_lines_a_malformed_command_reply_gets(change, says):
    with pytest.raises(SILError) as err:
        schema.check_reply(NAME, _decoded({**GOOD, **change}), "command", 5, TABLE, awaited=True)
    assert str(err.value) == f"sat3: command reply: {says}"


def test_integers_are_numbers_and_booleans_are_not():
    """Some msgpack writers send an integral float as an integer (JavaScript's): taken as float64."""
    reply = schema.check_reply(NAME, _decoded({**GOOD, "commands": {"torque_b": [0, 1, -2]}}), "command", 5, TABLE, True)
    assert reply["commands"]["torque_b"].tolist() == [0.0, 1.0, -2.0]
    with pytest.raises(SILError, match=r"^sat3: command reply: commands field 'torque_b' holds True "):
        schema.check_reply(NAME, _decoded({**GOOD, "commands": {"torque_b": [0.0, True, 0.0]}}), "command", 5, TABLE, True)
