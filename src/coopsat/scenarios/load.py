"""Read a scenario (bundled name or TOML file), apply overrides and defaults, validate.

No code runs from a scenario file: it is parsed with :mod:`tomllib` and validated by
:class:`~coopsat.scenarios.schema.Scenario`. Every problem surfaces as one
:class:`ScenarioError` whose message names the field (``controller.alpha: …``).
"""

import math
import os
import re
import sys
import tomllib
from importlib import resources
from pathlib import Path

import tomli_w
from pydantic import ValidationError

from coopsat.core.errors import InputError
from coopsat.scenarios import hints
from coopsat.scenarios.catalogue import BUNDLED_PACKAGE, bundled_names  # noqa: F401  (public here too)
from coopsat.scenarios.schema import Scenario


class ScenarioError(InputError):
    """A scenario that cannot be loaded, validated or built; the message is one line."""


def bundled_text(name):
    """TOML text of a bundled scenario."""
    if name not in bundled_names():
        hint = hints.did_you_mean(name, bundled_names())
        raise ScenarioError(f"no bundled scenario named '{clip_echo(name)}'{hint} (coopsat list shows them)")
    return resources.files(BUNDLED_PACKAGE).joinpath(f"{name}.toml").read_text(encoding="utf-8")


MAX_SCENARIO_BYTES = 10 * 2**20
"""Largest scenario file read, bytes (a scenario is a page of text; this is far beyond one)."""


def read_scenario_text(path):
    """The text of a scenario file, or one line saying what is wrong with the file.

    Raises
    ------
    ScenarioError
        Missing, a directory, unreadable (permissions, I/O), larger than
        :data:`MAX_SCENARIO_BYTES`, binary, or not UTF-8 (e.g. UTF-16).
    """
    shown = clip_path(path)
    if not path.exists():
        raise ScenarioError(f"{shown}: no such scenario file")
    if path.is_dir():
        raise ScenarioError(f"{shown}: is a directory, not a scenario file")
    try:
        if path.stat().st_size > MAX_SCENARIO_BYTES:
            raise ScenarioError(f"{shown}: {path.stat().st_size} bytes is too large for a scenario file (at most 10 MiB)")
        data = path.read_bytes()
    except OSError as err:
        raise ScenarioError(f"{shown}: cannot be read ({err.strerror or err})") from None
    if b"\x00" in data:
        raise ScenarioError(f"{shown}: is a binary file, not TOML text (UTF-16 text also contains NUL bytes: save it as UTF-8)")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise ScenarioError(f"{shown}: is not UTF-8 text (byte {err.start}); save the scenario as UTF-8") from None


def read_raw(name_or_path, _depth=0):
    """Parse a scenario file, or a bundled scenario by name, into a plain dict.

    A top-level ``extends = "other"`` (a bundled name, or a ``.toml`` path relative to this
    file) starts from that scenario and overlays this file on it (:func:`deep_merge`), so a
    variant states only what it changes. A :class:`coopsat.Scenario` is taken as it is.

    Returns
    -------
    raw : dict
    default_name : str
        The file's stem (used when the file sets no ``name``).
    """
    from coopsat.scenarios.document import Scenario as Document

    if isinstance(name_or_path, Document):
        return name_or_path.to_dict(), name_or_path.name
    if not isinstance(name_or_path, (str, os.PathLike)):
        raise ScenarioError(f"scenario: expected a Scenario, a bundled scenario's name or a path to a .toml file, "
                            f"got {type(name_or_path).__name__}")
    path = Path(name_or_path)
    # A bare name is a bundled scenario even if a folder of that name is lying around.
    if path.suffix == ".toml" or path.is_file() or len(path.parts) > 1:
        text = read_scenario_text(path)
        origin, default_name = clip_path(path), path.stem
    else:
        text, origin, default_name = bundled_text(str(name_or_path)), clip_echo(name_or_path), str(name_or_path)
    raw = parse_toml(text, origin)
    if path.suffix == ".toml":
        _anchor_files(raw, path.parent)
    return resolve_extends(raw, path.parent if path.suffix == ".toml" else None, origin, _depth), default_name


def _anchor_files(raw, folder):
    """Files a scenario names (``[spacecraft.oem] file``) relative to its own folder, made
    absolute in place, so that they mean the same from any working folder and after ``extends``."""
    for sc in raw.get("spacecraft", []) if isinstance(raw.get("spacecraft"), list) else []:
        table = sc.get("oem") if isinstance(sc, dict) else None
        if isinstance(table, dict) and isinstance(table.get("file"), str) and not Path(table["file"]).is_absolute():
            table["file"] = str((Path(folder) / table["file"]).resolve())


def parse_toml(text, origin="scenario"):
    """A scenario's TOML text as a dict; one line naming ``origin`` when it is not TOML."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise ScenarioError(f"{origin}: not valid TOML: {clip_echo(err, 4 * ECHO_MAX)}") from None


def resolve_extends(raw, folder=None, origin="scenario", _depth=0):
    """``raw`` overlaid on the scenario its ``extends`` names (a bundled name, or a ``.toml``
    path relative to ``folder``, default the working folder); ``raw`` itself when it has none."""
    raw = dict(raw)
    base = raw.pop("extends", None)
    if base is None:
        return raw
    if not isinstance(base, str):
        raise ScenarioError(f"{origin}: extends must name a bundled scenario or a .toml file")
    if _depth >= 8:
        raise ScenarioError(f"{origin}: extends chain deeper than 8 (a cycle?)")
    base_path = Path(folder) / base if folder is not None and base.endswith(".toml") else base
    base_raw, _ = read_raw(base_path, _depth=_depth + 1)
    base_raw.pop("name", None)
    return deep_merge(base_raw, raw)


def _kind_changes(base_table, new_kind_or_table):
    """True when a table that states a ``kind`` is given another one."""
    new = new_kind_or_table.get("kind") if isinstance(new_kind_or_table, dict) else new_kind_or_table
    return base_table.get("kind") is not None and new is not None and new != base_table["kind"]


def deep_merge(base, child):
    """``child`` over ``base``: tables merge key by key, everything else (arrays too) replaces.

    A table whose ``kind`` changes replaces the base's table whole: another kind is another
    implementation, and the base's fields may mean nothing to it.
    """
    out = dict(base)
    for key, value in child.items():
        base_value = out.get(key)
        if isinstance(value, dict) and isinstance(base_value, dict) and not _kind_changes(base_value, value):
            out[key] = deep_merge(out[key], value)
        else:
            out[key] = value
    return out


def parse_value(text):
    """A ``--set`` value as TOML (numbers, booleans, arrays, quoted strings), else a bare string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def apply_override(raw, assignment):
    """Apply one ``key.path=value`` override in place (the value parsed as TOML,
    :func:`parse_value`); :func:`set_path` does the rest."""
    if "=" not in assignment:
        raise ScenarioError(f"--set {clip_echo(assignment)}: expected key.path=value")
    key, value = assignment.split("=", 1)
    set_path(raw, key, parse_value(value.strip()), what="--set ")


def set_path(raw, key, value, what=""):
    """Set the field at ``key`` (``"controller.alpha"``) of a raw scenario dict to ``value``, in place.

    ``spacecraft.2.omega_b_rad_s`` addresses the third spacecraft (indices from 0); tables
    that do not exist yet are created. Setting a table's ``kind`` to another value clears the
    table's other fields first (set them after it).

    Parameters
    ----------
    raw : dict
        The scenario as parsed from TOML.
    key : str
        Dotted path.
    value : object
        A TOML value: number, boolean, string, list, dict.
    what : str
        Prefix of error messages (``"--set "`` for the command line).

    Raises
    ------
    ScenarioError
        One line naming the key: an empty key, an index past a list's end, a value in the way.
    """
    parts = [p for p in str(key).strip().split(".") if p]
    if not parts:
        raise ScenarioError(f"{what}{clip_echo(key)}: empty key")
    node = raw
    for depth, part in enumerate(parts[:-1]):
        where = ".".join(parts[: depth + 1])
        if isinstance(node, list):
            if not part.isdigit() or int(part) >= len(node):
                raise ScenarioError(f"{what}{clip_echo(key)}: {clip_echo(where)} is not an index of a list of {len(node)}")
            node = node[int(part)]
        else:
            node = node.setdefault(part, {})
        if not isinstance(node, (dict, list)):
            raise ScenarioError(f"{what}{clip_echo(key)}: {clip_echo(where)} is a value, not a table")
    last = parts[-1]
    if last == "kind" and isinstance(node, dict) and _kind_changes(node, value):
        node.clear()  # another kind is another implementation: start its table afresh (as extends does)
    if isinstance(node, list):
        if not last.isdigit() or int(last) >= len(node):
            raise ScenarioError(f"{what}{clip_echo(key)}: {clip_echo(last)} is not an index of a list of {len(node)}")
        node[int(last)] = value
    else:
        node[last] = value


def _merge_defaults(raw):
    """Give each ``[[spacecraft]]`` the ``[spacecraft_defaults]`` it does not set, and a name.

    The caller's ``raw`` is left as it was: the top-level table is copied and each spacecraft's
    table made anew, nothing nested is changed in place (a deep copy was a fifth of the load
    of 1e4 spacecraft)."""
    raw = dict(raw)
    defaults = raw.pop("spacecraft_defaults", {}) or {}
    if not isinstance(defaults, dict):
        raise ScenarioError("spacecraft_defaults: must be a table")
    from coopsat.scenarios.schema import SpacecraftDefaults

    try:
        SpacecraftDefaults.model_validate(defaults)
    except ValidationError as err:
        raise ScenarioError(format_validation_error(err, prefix="spacecraft_defaults", model=SpacecraftDefaults)) from None
    sc_list = raw.get("spacecraft", [])
    if not isinstance(sc_list, list):
        raise ScenarioError("spacecraft: must be an array of tables [[spacecraft]]")
    merged = []
    for k, sc in enumerate(sc_list):
        if not isinstance(sc, dict):
            raise ScenarioError(f"spacecraft[{k}]: must be a table")
        entry = {**defaults, **sc}
        entry.setdefault("name", f"sat{k + 1}")
        merged.append(entry)
    raw["spacecraft"] = merged
    return raw


ECHO_MAX = 80
"""Longest piece of the user's input (a key, a value) echoed in an error message, characters."""


def clip_echo(text, limit=ECHO_MAX):
    """``text`` cut to ``limit`` characters (with how much was cut), so that an error message
    never repeats unbounded input."""
    text = str(text)
    return text if len(text) <= limit else f"{text[:limit]}… ({len(text)} characters)"


def clip_path(path, limit=4 * ECHO_MAX):
    """A path for a message: its end (the file's name) kept when it is long."""
    text = str(path)
    return text if len(text) <= limit else f"…{text[-limit:]}"


_NUMBER_ERRORS = {"finite_number", "float_type", "int_type", "int_from_float"}
"""pydantic's errors of a value where a number belongs."""

_TOML_TYPE = {bool: "a boolean", str: "a string", int: "an integer", float: "a number", list: "an array", dict: "a table"}


ROOT_KEYS = ("extends", "spacecraft_defaults")
"""Top-level keys read before validation (so not fields of the schema's Scenario)."""


def format_validation_error(err, prefix="", model=None):
    """One line naming each failing field: ``controller.alpha: Input should be greater than 0``.

    A wrong type says what was found (``controller.alpha: Input should be a valid number, got a
    boolean (true)``); an unknown key, kind or choice the closest valid names at its place
    (``controller.alpah: unknown field; did you mean `alpha`?``, from ``model``, default the
    scenario's schema); keys and values from the file are cut to :data:`ECHO_MAX` characters.
    """
    from coopsat.plugins import all_kinds

    tags = all_kinds()  # pydantic puts the kind of a tagged union in the error's location
    errors = err.errors()
    # A field that takes a table or an array of tables ([actuators] or [[actuators]]) fails
    # once per form: keep the failures of the form that was given, not "should be a list".
    wrong_form = {"list_type", "model_type", "dict_type", "model_attributes_type"}
    if any(e["type"] not in wrong_form for e in errors):
        errors = [e for e in errors if e["type"] not in wrong_form]
    # An unknown key first: a misspelt one is also why its field is "required" (and so elsewhere).
    errors.sort(key=lambda e: e["type"] != "extra_forbidden")
    msgs = [f"{_where(e['loc'], prefix, tags)}: {_error_text(e, model)}" for e in errors]
    extra = f" (+{len(msgs) - 3} more)" if len(msgs) > 3 else ""
    return "; ".join(msgs[:3]) + extra


def _where(loc, prefix, tags):
    """``spacecraft[0].q_bi``: a pydantic error location as the file's path (kinds and
    pydantic's own labels left out); ``scenario`` for the whole."""
    parts = [prefix] if prefix else []
    for p in loc:
        if isinstance(p, int):
            parts[-1:] = [f"{parts[-1]}[{p}]"] if parts else [f"[{p}]"]
        elif p not in tags and "[" not in p:  # "tagged-union[…]", "list[…]": pydantic's own labels
            parts.append(clip_echo(p))
    return ".".join(parts) or "scenario"


def _error_text(e, model):
    """The message of one pydantic error, in the file's terms (see :func:`format_validation_error`)."""
    text = clip_echo(e["msg"].removeprefix("Value error, "), 4 * ECHO_MAX)
    given = e.get("input")
    if e["type"] == "extra_forbidden":
        valid = hints.fields_at(Scenario if model is None else model, e["loc"][:-1])
        return hints.unknown_field(e["loc"][-1], valid + list(ROOT_KEYS if model is None and len(e["loc"]) == 1 else ()))
    if e["type"] == "union_tag_invalid":
        expected = e["ctx"]["expected_tags"]
        hint = hints.did_you_mean(e["ctx"]["tag"], hints.quoted_names(expected))
        return f"unknown kind '{clip_echo(e['ctx']['tag'])}'{hint} (kinds: {expected})"
    if e["type"] == "union_tag_not_found":
        kinds = hints.kinds_at(Scenario if model is None else model, e["loc"])
        return f"needs a kind (one of: {', '.join(kinds)})" if kinds else "needs a kind"
    if e["type"] == "literal_error" and isinstance(given, str):
        return text + hints.did_you_mean(given, hints.quoted_names(e["ctx"]["expected"]))
    if e["type"] == "float_type" and isinstance(given, int) and not isinstance(given, bool) and abs(given) > sys.float_info.max:
        return f"{text}, got an integer that overflows float64 (at most {sys.float_info.max:.3g} in magnitude)"
    if e["type"] in _NUMBER_ERRORS and isinstance(given, float) and math.isinf(given):
        # TOML reads a literal beyond the float range (1e400) as inf: say so.
        return f"{text}, got {given} (a value beyond {sys.float_info.max:.3g} in magnitude overflows float64)"
    if e["type"].endswith("_type") and type(given) in _TOML_TYPE:
        shown = str(given).lower() if isinstance(given, bool) else repr(given)
        text += f", got {_TOML_TYPE[type(given)]} ({clip_echo(shown, 40)})"
    return text


def load_scenario(name_or_path, overrides=()):
    """Load, override and validate a scenario.

    Parameters
    ----------
    name_or_path : str or Path
        Bundled scenario name or path to a TOML file.
    overrides : iterable of str
        ``key.path=value`` assignments applied before validation.

    Returns
    -------
    Scenario
    """
    raw, default_name = read_raw(name_or_path)
    for assignment in overrides:
        apply_override(raw, assignment)
    raw.setdefault("name", default_name)
    raw = _merge_defaults(raw)
    try:
        return Scenario.model_validate(raw)
    except ValidationError as err:
        raise ScenarioError(format_validation_error(err)) from None


def resolved_toml(scenario):
    """The validated scenario with every default filled in, as TOML text (replayable)."""
    return _inline_vectors(tomli_w.dumps(_plain(scenario.model_dump(exclude_none=True))))


_SCALAR_ARRAY = re.compile(r"\[\n((?:[ \t]*[^\[\]\n]+,\n)+)[ \t]*\]")


def _inline_vectors(text):
    """Arrays of scalars on one line (``[0.5, 0.0, 0.5]``); tomli_w writes one element per line.
    Arrays of arrays keep one inner array per line."""
    return _SCALAR_ARRAY.sub(lambda m: "[" + ", ".join(x.strip().rstrip(",") for x in m.group(1).splitlines()) + "]", text)


def _plain(obj):
    """Tuples to lists, and infinite defaults dropped (they mean "unset": no saturation)."""
    if isinstance(obj, dict):
        return {k: _plain(v) for k, v in obj.items() if not (isinstance(v, float) and v == float("inf"))}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    return obj
