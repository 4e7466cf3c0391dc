"""The bundled scenarios' names and one-line descriptions, without the schema.

``coopsat list`` needs only these: reading them through :mod:`coopsat.scenarios.load` imports
pydantic and composes the scenario schema from the plug-in registry (0.3 s of a 0.5 s
command). A description is the file's ``description``, else the one of the scenario it
``extends``.
"""

import tomllib
from importlib import resources

BUNDLED_PACKAGE = "coopsat.scenarios.bundled"

EXTENDS_MAX = 8
"""Longest ``extends`` chain followed (the loader refuses deeper ones)."""


def bundled_names():
    """Names of the bundled scenarios, sorted."""
    files = resources.files(BUNDLED_PACKAGE).iterdir()
    return sorted(f.name[: -len(".toml")] for f in files if f.name.endswith(".toml"))


def description(name, _depth=0):
    """One-line description of the bundled scenario ``name`` ("" when none is given)."""
    raw = tomllib.loads(resources.files(BUNDLED_PACKAGE).joinpath(f"{name}.toml").read_text(encoding="utf-8"))
    base = raw.get("extends")
    if "description" in raw or not isinstance(base, str) or base not in bundled_names() or _depth >= EXTENDS_MAX:
        return str(raw.get("description", ""))
    return description(base, _depth + 1)
