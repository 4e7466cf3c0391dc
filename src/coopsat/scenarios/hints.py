"""What a misspelt name was probably meant to be: ``did you mean `alpha`?``.

Pure helpers for the one-line messages of :mod:`coopsat.scenarios.load`: the valid field
names of the table at an error's location (read from the schema's models, plug-in tables
included), and the closest of a list of valid names (:func:`difflib.get_close_matches`).
"""

import difflib
import re
import types
import typing

from pydantic import BaseModel

HINT_NAMES_MAX = 10
"""Most valid names listed when none is close to a misspelt one."""


def closest(word, candidates, limit=2):
    """The (at most ``limit``) candidates close to ``word``, closest first; [] when none is."""
    return difflib.get_close_matches(str(word), [str(c) for c in candidates], n=limit, cutoff=0.6)


def did_you_mean(word, candidates):
    """``"; did you mean `alpha`?"`` (or ```alpha` or `beta```) for the candidates close to
    ``word``; "" when none is close."""
    close = closest(word, candidates)
    return f"; did you mean {' or '.join(f'`{c}`' for c in close)}?" if close else ""


def name_list(names, limit=HINT_NAMES_MAX):
    """``a, b, c, …``: the first ``limit`` names, in order."""
    names = list(names)
    return ", ".join(names[:limit]) + (", …" if len(names) > limit else "")


def unknown_field(key, valid):
    """The message for a key that no field of its table has: the closest valid names, or (none
    being close) the table's fields."""
    hint = did_you_mean(key, valid)
    if hint or not valid:
        return f"unknown field{hint}"
    return f"unknown field (none of this table's fields is close: {name_list(valid)})"


def quoted_names(expected):
    """The names in pydantic's ``'a', 'b' or 'c'`` list of expected values."""
    return re.findall(r"'([^']*)'", expected)


def _tables_in(annotation):
    """The tables (pydantic models) a field's type can hold, through ``Annotated``, unions,
    ``None`` and lists."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    origin = typing.get_origin(annotation)
    if origin in (typing.Annotated, typing.Union, types.UnionType, list, tuple):
        return [t for arg in typing.get_args(annotation) for t in _tables_in(arg)]
    return []


def _kind_of(table):
    """The one ``kind`` that selects a plug-in table (its ``Literal``), else None."""
    field = table.model_fields.get("kind")
    values = typing.get_args(field.annotation) if field is not None else ()
    return values[0] if len(values) == 1 else None


def _tables_at(model, loc):
    """The tables (pydantic models) that may sit at ``loc`` (a pydantic error location) under
    ``model``: one, or several where the location does not tell them apart (a plug-in table is
    told by its kind, which pydantic puts in the location)."""
    tables = [model]
    for part in loc:
        if isinstance(part, int) or "[" in part:  # a list index, or pydantic's own label
            continue
        tagged = [t for t in tables if _kind_of(t) == part]
        if tagged:
            tables = tagged
            continue
        tables = [t for table in tables if part in table.model_fields for t in _tables_in(table.model_fields[part].annotation)]
    return tables


def fields_at(model, loc):
    """Field names of the table at ``loc`` (the unknown key left out) under ``model``, in
    declaration order (several tables' together where the location does not tell them apart)."""
    return list(dict.fromkeys(name for table in _tables_at(model, loc) for name in table.model_fields))


def kinds_at(model, loc):
    """The kinds that select a plug-in table at ``loc`` under ``model`` (``[[sensors]]``: every
    sensor's), in registration order."""
    return [k for k in dict.fromkeys(_kind_of(t) for t in _tables_at(model, loc)) if k is not None]
