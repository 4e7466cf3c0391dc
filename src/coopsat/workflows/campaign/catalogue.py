"""The bundled campaigns' names and one-line descriptions, read straight from their TOML.

``coopsat campaign list`` needs only these: validating the files (:mod:`.spec`) imports
pydantic and the scenario schema, and running them Dask and JAX, none of which a listing needs.
"""

import tomllib
from importlib import resources


def _folder():
    return resources.files("coopsat.workflows.campaign").joinpath("bundled")


def bundled_names():
    """Names of the bundled campaigns, sorted."""
    return sorted(f.name[: -len(".toml")] for f in _folder().iterdir() if f.name.endswith(".toml"))


def bundled_path(name):
    """The file of the bundled campaign ``name`` (a :class:`~importlib.resources.abc.Traversable`)."""
    return _folder().joinpath(f"{name}.toml")


def description(name):
    """One-line description of the bundled campaign ``name``: its ``description``, else the
    scenario it disperses."""
    raw = tomllib.loads(bundled_path(name).read_text(encoding="utf-8"))
    return str(raw.get("description") or f"disperses {raw.get('scenario', '?')}")
