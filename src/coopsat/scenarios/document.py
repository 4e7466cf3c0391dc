"""The public scenario: an immutable document that Python code loads, changes and runs.

:class:`Scenario` holds a scenario as its TOML file would (a plain dict, ``extends`` already
resolved); each change returns a new one, validated at once, so a bad value fails where it is
set with the one-line :class:`~coopsat.scenarios.load.ScenarioError` the command line prints.
Every workflow (``coopsat.run``, ``run_batch``, ``sweep``, ``pair``, ``tune``) takes one wherever
it takes a bundled name or a file (:func:`coopsat.scenarios.load.read_raw`).
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from functools import cached_property
from pathlib import Path
from typing import Any

from coopsat.scenarios.load import (
    _merge_defaults,
    apply_override,
    bundled_names,
    format_validation_error,
    parse_toml,
    read_raw,
    resolve_extends,
    resolved_toml,
    set_path,
)
from coopsat.scenarios.load import ScenarioError as ScenarioError


class Scenario:
    """A scenario: spacecraft, network, controller, actuators, sensors, disturbances, run length.

    Build one with :meth:`load`, :meth:`from_dict` or :meth:`from_toml`; change it with
    :meth:`set` or :meth:`update`, each of which returns a new, validated scenario (this one
    is never modified). docs/scenarios.md documents every field, with units.

    Examples
    --------
    >>> import coopsat
    >>> s = coopsat.Scenario.load("consensus-sync-a-stable").set("sim.t_final_s", 20.0)
    >>> s.name, s["sim.t_final_s"], s.model.controller.alpha
    ('consensus-sync-a-stable', 20.0, 1.0)
    """

    def __init__(self, raw: Mapping[str, Any], name: str | None = None):
        """Use :meth:`load`, :meth:`from_dict` or :meth:`from_toml`; ``raw`` is taken as given
        (``extends`` resolved) and validated."""
        self._adopt(copy.deepcopy(dict(raw)), name)
        self.model  # noqa: B018  (validate now: a bad scenario fails where it is made)

    def _adopt(self, raw, name):
        """Take ``raw`` (this scenario's own copy) and its name."""
        self._name = str(raw.get("name") or name or "scenario")
        raw.setdefault("name", self._name)
        self._raw = raw

    # --- construction -------------------------------------------------------------------------

    @staticmethod
    def bundled() -> list[str]:
        """Names of the bundled scenarios, sorted (``coopsat list``)."""
        return bundled_names()

    @classmethod
    def load(cls, name_or_path: str | Path) -> Scenario:
        """A bundled scenario by name (``coopsat list``) or a TOML file by path.

        Raises
        ------
        ScenarioError
            No such scenario or file, not TOML, or not a valid scenario (one line).
        """
        raw, default_name = read_raw(name_or_path)
        return cls(raw, default_name)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], *, base_dir: str | Path | None = None) -> Scenario:
        """A scenario from a dict shaped as its TOML file (tables as dicts, arrays of tables as
        lists of dicts); ``extends`` names a bundled scenario or a ``.toml`` path relative to
        ``base_dir`` (default the working folder)."""
        if not isinstance(data, Mapping):
            raise ScenarioError(f"scenario: must be a table (a dict), got {type(data).__name__}")
        return cls(resolve_extends(copy.deepcopy(dict(data)), base_dir))

    @classmethod
    def from_toml(cls, text: str, *, base_dir: str | Path | None = None) -> Scenario:
        """A scenario from the text of a TOML file (see :meth:`from_dict` for ``extends``)."""
        return cls.from_dict(parse_toml(text), base_dir=base_dir)

    # --- changes ------------------------------------------------------------------------------

    def set(self, path: str, value: Any) -> Scenario:
        """A new scenario with the field at ``path`` set to ``value``.

        Parameters
        ----------
        path : str
            Dotted field path, as ``--set`` takes it: ``"controller.alpha"``,
            ``"spacecraft.1.omega_b_rad_s"`` (list entries by index from 0).
        value : float, int, bool, str, list or dict
            The value itself, as TOML would give it (no string parsing: ``[0.0, 0.0, 0.1]``,
            ``{"kind": "gyro", "sigma_rad_s": 1e-4}``). Setting a table's ``kind`` to another
            value clears that table's other fields: use :meth:`update` to set them together.

        Raises
        ------
        ScenarioError
            The path cannot be set, or the result is not a valid scenario (one line naming the
            field).
        """
        return self.update({path: value})

    def update(self, changes: Mapping[str, Any]) -> Scenario:
        """A new scenario with several fields set in order (``{path: value}``), validated once."""
        raw = copy.deepcopy(self._raw)
        for path, value in changes.items():
            set_path(raw, path, copy.deepcopy(value))
        out = type(self).__new__(type(self))
        out._adopt(raw, self._name)
        model = self._applied_model(changes)
        if model is not None:
            out.__dict__["model"] = model  # the cached_property's value
        out.model  # noqa: B018  (validate now: a bad scenario fails where it is made)
        return out

    def _applied_model(self, changes):
        """This scenario's model with ``changes`` set field by field
        (:func:`coopsat.scenarios.applied.with_value`), when every changed path is one that
        no validator of another field reads (the seed, initial attitudes, rates and wheel
        momenta: :data:`~coopsat.scenarios.applied.APPLIED_FIELDS`), so that ``with_seed`` on
        a batch of runs does not validate the whole scenario each time; else None (validated
        whole). A value refused here is validated whole too, for the usual message."""
        from coopsat.scenarios.applied import applicable, with_value

        if "model" not in self.__dict__ or applicable(list(changes)) is not None:
            return None
        model = self.model
        try:
            for path, value in changes.items():
                model = with_value(model, path, value)
        except ScenarioError:
            return None
        return model

    def with_seed(self, seed: int) -> Scenario:
        """The same scenario with another seed (every random draw of the run follows from it)."""
        return self.set("seed", int(seed))

    # --- views --------------------------------------------------------------------------------

    @property
    def name(self) -> str:
        """The scenario's name (run folders and metrics use it)."""
        return self._name

    @cached_property
    def model(self):
        """The validated scenario (:class:`coopsat.scenarios.schema.Scenario`, a pydantic model;
        read-only by convention)."""
        from pydantic import ValidationError

        from coopsat.scenarios.schema import Scenario as Model

        try:
            return Model.model_validate(_merge_defaults(self._raw))
        except ValidationError as err:
            raise ScenarioError(format_validation_error(err)) from None

    def __getitem__(self, path: str) -> Any:
        """The value at a dotted path, as given (not defaults: see :meth:`resolved`)."""
        node: Any = self._raw
        for part in str(path).split("."):
            try:
                node = node[int(part)] if isinstance(node, list) else node[part]
            except (KeyError, IndexError, ValueError):
                raise KeyError(path) from None
        return copy.deepcopy(node)

    def to_dict(self) -> dict:
        """The scenario as its TOML file would give it (a deep copy)."""
        return copy.deepcopy(self._raw)

    def to_toml(self) -> str:
        """The scenario as TOML text (as given; :meth:`resolved` first for every default)."""
        import tomli_w

        return tomli_w.dumps(self._raw)

    def resolved(self) -> Scenario:
        """The same scenario with every default filled in (``coopsat show --resolved``)."""
        return type(self).from_toml(resolved_toml(self.model))

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Scenario) and self._raw == other._raw

    __hash__ = None  # equal by content, and a dict inside: not hashable

    def __repr__(self) -> str:
        return f"Scenario({self._name!r})"


def with_overrides(ref, overrides=()):
    """A :class:`Scenario` from a bundled name, a path or a Scenario, with the command line's
    ``key.path=value`` overrides (values parsed as TOML) applied, validated once."""
    raw, name = read_raw(ref)
    for assignment in overrides:
        apply_override(raw, assignment)
    return Scenario(raw, name)
