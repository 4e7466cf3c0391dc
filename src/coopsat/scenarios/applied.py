"""Runs built once: the fields the compiled loop reads only as data, applied as arrays.

A campaign or a batch of runs usually differs from one scenario only in its seed and its
initial state. Building every run (validation, context, every plug-in's builder and design
checks: 3–5 ms a run) repeats work whose result is the same for all of them but for a few
leaves of the :class:`~coopsat.sim.system.System`. Here the first run is built as usual, and
every other run's values of the fields in :data:`APPLIED_FIELDS` are written into a batched
copy of its system, all runs at once.

A field belongs in :data:`APPLIED_FIELDS` only when it reaches the build through one leaf of
the system and nothing else: no plug-in's builder or design check, no structure, no
validator that reads other fields. That is true of the fields registered here by what
:func:`coopsat.scenarios.build.build` does with them; it is also checked on every batch
(:func:`applied_runs` builds, for each applied field, one run that differs in it the usual way
and compares every leaf and check bit for bit), so that a plug-in that starts reading one of
them at build time sends its batches back to per-run builds (one line says which leaf
differed) instead of changing their results.
Any other dispersed field (an inertia, a gain, a delay) enters a design step or the structure:
its runs are built one by one (:func:`applicable` says why, in one line).
"""

import dataclasses
import re
from dataclasses import dataclass
from functools import lru_cache
from typing import Annotated, Callable, NamedTuple

import numpy as np

from coopsat.core.errors import CoopsatError
from coopsat.scenarios.load import ScenarioError


@dataclass(frozen=True)
class AppliedField:
    """One field applied as data.

    Attributes
    ----------
    pattern : str
        Regular expression of the field's dotted path in the scenario model
        (``spacecraft.(\\d+).omega_b_rad_s``); its groups are passed to ``apply``.
    apply : callable
        ``apply(system, groups, values) -> system``: ``system`` batched with NumPy leaves
        ``(B, ...)``, ``values`` the B runs' values stacked, ``(B, ...)``.
    """

    pattern: str
    apply: Callable


def _keys(system, _groups, seeds):
    """Each run's random key, as :func:`~coopsat.scenarios.build.build` makes it from its seed."""
    import jax

    keys = jax.vmap(jax.random.PRNGKey)(np.asarray(seeds, dtype=np.int64))
    return dataclasses.replace(system, key=np.asarray(keys))


def _initial(attr, unit=False):
    """Applier of one spacecraft's initial-state field ``attr`` of
    :class:`~coopsat.dynamics.plant.PlantState`; ``unit``: normalised as the build does (a
    quaternion)."""

    def apply(system, groups, values):
        i = int(groups[0])
        rows = np.asarray(values, dtype=float)
        if unit:
            rows = rows / np.linalg.norm(rows, axis=-1, keepdims=True)
        column = np.array(getattr(system.x0, attr), copy=True)
        column[:, i] = rows
        return dataclasses.replace(system, x0=system.x0._replace(**{attr: column}))

    return apply


APPLIED_FIELDS = (
    AppliedField(r"seed", _keys),
    AppliedField(r"spacecraft\.(\d+)\.omega_b_rad_s", _initial("omega_b")),
    AppliedField(r"spacecraft\.(\d+)\.q_bi", _initial("q_bi", unit=True)),
    AppliedField(r"spacecraft\.(\d+)\.h_wheels_b_nms", _initial("h_wheels_b")),
    AppliedField(r"spacecraft\.(\d+)\.angle_rad", _initial("angle_rad")),
)
"""The fields applied as data (:class:`AppliedField`), by their path in the scenario model."""


def _field_of(path):
    """(AppliedField, match groups) of a dotted path, or None."""
    for f in APPLIED_FIELDS:
        m = re.fullmatch(f.pattern, path)
        if m:
            return f, m.groups()
    return None


def applicable(paths):
    """None when every path is applied as data; else one line naming the first that is not."""
    for path in paths:
        if _field_of(path) is None:
            return (f"{path} enters the build (a design step or the structure), so each run is built on its own; "
                    "only the seed and the spacecraft's initial q_bi, omega_b_rad_s, h_wheels_b_nms and angle_rad "
                    "are applied as arrays to one build")
    return None


def changed_paths(a, b, prefix=""):
    """Dotted paths at which two raw scenario dicts (as TOML gives them) differ; a list whose
    length differs, or a key present in one only, is one path."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for k in dict.fromkeys([*a, *b]):
            if k not in a or k not in b:
                out.append(f"{prefix}{k}")
            else:
                out += changed_paths(a[k], b[k], f"{prefix}{k}.")
        return out
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b) and any(isinstance(v, (dict, list)) for v in a):
        out = []
        for k, (x, y) in enumerate(zip(a, b)):
            out += changed_paths(x, y, f"{prefix}{k}.")
        return out
    return [] if a == b else [prefix.rstrip(".")]


def model_value(model, path):
    """The value at a dotted path of a scenario model (list entries by index)."""
    node = model
    for part in path.split("."):
        node = node[int(part)] if isinstance(node, list) else getattr(node, part)
    return node


@lru_cache(maxsize=None)
def _adapter(cls, name):
    from pydantic import TypeAdapter

    info = cls.model_fields[name]
    return TypeAdapter(Annotated[(info.annotation, *info.metadata)])


def _place(path):
    """``spacecraft.1.omega_b_rad_s`` as the schema's messages name it: ``spacecraft[1].omega_b_rad_s``."""
    return re.sub(r"\.(\d+)(?=\.|$)", r"[\1]", path)


def with_value(model, path, value):
    """``model`` with the field at ``path`` replaced by ``value``, validated as that field
    (its type and bounds: the fields of :data:`APPLIED_FIELDS` enter no validator of another
    field), without validating the whole scenario again.

    Raises
    ------
    ScenarioError
        The value is not valid for the field (one line naming it).
    """
    from pydantic import ValidationError

    def put(node, parts):
        head, rest = parts[0], parts[1:]
        if isinstance(node, list):
            out = list(node)
            out[int(head)] = put(node[int(head)], rest)
            return out
        if rest:
            return node.model_copy(update={head: put(getattr(node, head), rest)})
        try:
            return node.model_copy(update={head: _adapter(type(node), head).validate_python(value)})
        except ValidationError as err:
            raise ScenarioError(f"{_place(path)}: {err.errors()[0]['msg'].removeprefix('Value error, ')}") from None

    return put(model, path.split("."))


class AppliedRuns(NamedTuple):
    """Runs built once (:func:`applied_runs`)."""

    builds: list
    """Per run, its :class:`~coopsat.scenarios.build.Built`: the first run's, with the run's own
    scenario and system (NumPy leaves)."""
    system: object
    """All runs' systems as one batch (JAX leaves, leading run axis), ready for the engine."""


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def _first_difference(built, reference):
    """The first leaf or design check in which ``built`` differs from ``reference`` (built the
    usual way), as a phrase; None when every one is equal bit for bit."""
    import jax

    mine, theirs = jax.tree_util.tree_flatten_with_path(built.system), jax.tree_util.tree_flatten_with_path(reference.system)
    if mine[1] != theirs[1]:
        return "the system's structure"
    for (path, a), (_, b) in zip(mine[0], theirs[0]):
        if not _same(a, b):
            return f"the system's leaf {jax.tree_util.keystr(path)}"
    for name, check in reference.named_checks.items():
        ours = built.named_checks.get(name)
        if ours is None or (ours.ok, ours.note, ours.metrics) != (check.ok, check.note, check.metrics):
            return f"the design check '{name}'"
    return None


def _checked_runs(values):
    """The runs built the usual way to check an applied batch: in order, each run that differs
    from the first in a field that no earlier checked run differed in (at most one per field;
    a campaign's runs differ in every dispersed field, so one). ``values``: path -> (B, ...)."""
    covered, out = set(), []
    n = len(next(iter(values.values()))) if values else 0
    for k in range(1, n):
        differ = {p for p, v in values.items() if not np.array_equal(v[k], v[0])}
        if differ - covered:
            out.append(k)
            covered |= differ
    return out


class NotApplicable(CoopsatError):
    """A batch whose applied build differs from the usual one (:func:`applied_runs`); its message
    says where. Callers catch it and build those runs one by one: it never reaches a user."""


def applied_runs(base, models, paths, build_one):
    """Every run of ``models`` from one build: ``base`` (the build of ``models[0]``) with each
    run's values of ``paths`` applied as arrays.

    Parameters
    ----------
    base : Built
        ``build_one(models[0])``.
    models : sequence of coopsat.scenarios.schema.Scenario
        Validated scenarios equal to ``models[0]`` but at ``paths``.
    paths : sequence of str
        Model paths, each in :data:`APPLIED_FIELDS` (:func:`applicable`).
    build_one : callable
        The usual build (:func:`coopsat.workflows.pipeline.prepare`), used on the runs of
        :func:`_checked_runs` to check the applied build against it.

    Returns
    -------
    AppliedRuns

    Raises
    ------
    NotApplicable
        The check found a leaf or design check that the applied build does not reproduce.
    """
    import jax

    n = len(models)
    one = jax.tree_util.tree_map(np.asarray, base.system)
    batched = jax.tree_util.tree_map(lambda leaf: np.broadcast_to(leaf, (n, *np.shape(leaf))), one)
    values = {path: np.stack([np.asarray(model_value(m, path)) for m in models]) for path in paths}
    for path in paths:
        field, groups = _field_of(path)
        batched = field.apply(batched, groups, values[path])
    leaves, treedef = jax.tree_util.tree_flatten(batched)
    builds = [
        dataclasses.replace(base, scenario=m, system=jax.tree_util.tree_unflatten(treedef, [leaf[k] for leaf in leaves]),
                            context=dataclasses.replace(base.context, scenario=m))
        for k, m in enumerate(models)
    ]
    for k in _checked_runs(values):
        why = _first_difference(builds[k], build_one(models[k]))
        if why is not None:
            raise NotApplicable(f"built once, {why} differs from the run's own build, so each run is built on its own")
    system = jax.tree_util.tree_unflatten(treedef, [jax.device_put(np.ascontiguousarray(leaf)) for leaf in leaves])
    return AppliedRuns(builds, system)
