"""Plug-ins: every controller, actuator, sensor, network model and disturbance, behind one
registry.

A plug-in is a module that registers one or more :class:`Plugin` entries, each of which owns

* its scenario table: a pydantic model whose ``kind`` field is a ``Literal`` of its name
  (:mod:`coopsat.scenarios.schema` composes the scenario schema from the registered tables);
* its builder: ``build(table, ctx) -> part``, design-time NumPy/SciPy code turning the table
  into the in-loop part (a :func:`part` dataclass with pure ``init``/``step`` functions); the
  methods each role's part provides are documented once, in :mod:`coopsat.plugins.protocols`;
* optionally design-time checks ``check(table, ctx) -> DesignCheck or None`` (stability of a
  sampled-data law, an actuator's dead band…), run before the simulation;
* optionally the name of an analysis module (``coopsat.analysis.<paper>``, or any importable
  module) that adds the paper's metrics and its explanations of differences from published
  numbers.

Where kinds come from. :data:`PLUGIN_MODULES` lists coopsat's own modules (adding one is a new
module and one line there). Other installed packages add kinds through the entry-point group
``coopsat.plugins`` (:data:`ENTRY_POINT_GROUP`): each entry point names a module, and importing
that module calls :func:`register` as coopsat's own modules do (docs/plugins.md)::

    [project.entry-points."coopsat.plugins"]
    example = "coopsat_example.plugin"

The registry loads on first use (:func:`plugins`, which the scenario schema calls when it is
imported): coopsat's modules, then every entry point, sorted by distribution and name. Each
registered :class:`Plugin` carries its :class:`Origin` (the distribution and module that
registered it). Two registrations of one role and kind, a plug-in module that fails to import,
or an entry point that names something other than a module raise :class:`PluginError`, one
line naming both parties or the entry point; the offending entry point's kinds are then left
out, so the error is raised once, by the call that loaded the registry.

Plug-in modules import only light libraries at import time (pydantic, :mod:`coopsat.plugins`);
their builders import JAX and SciPy inside, so ``coopsat list`` stays quick. A plug-in module
must not import :mod:`coopsat.scenarios` (or anything that does) at import time: the scenario
schema is composed from the registry, which is still loading then.
"""

import importlib
import sys
from dataclasses import dataclass, field, replace

from coopsat.core.errors import one_line
from coopsat.plugins.protocols import (
    Actuator,
    Builder,
    BuildContext,
    Check,
    Controller,
    Disturbance,
    LocalController,
    NetworkDelivery,
    Sensor,
    protocol_problems,
)

ROLES = ("controller", "actuator", "sensor", "network", "disturbance")
"""Kinds of plug-in, in the order the scenario file's tables appear."""

PLUGIN_MODULES = (
    "coopsat.plugins.free",
    "coopsat.plugins.consensus",
    "coopsat.plugins.torque_actuators",
    "coopsat.plugins.force_actuators",
    "coopsat.plugins.wheel_actuators",
    "coopsat.plugins.pid",
    "coopsat.plugins.lvlh_consensus",
    "coopsat.plugins.cartwheel",
    "coopsat.plugins.leader_follower",
    "coopsat.plugins.formation",
    "coopsat.plugins.networks",
    "coopsat.plugins.disturbances",
    "coopsat.plugins.sensors",
    "coopsat.plugins.earth_environment",
    "coopsat.plugins.orbit_environment",
    "coopsat.plugins.observation",
)
"""Every module of coopsat that registers plug-ins (one line per module)."""

ENTRY_POINT_GROUP = "coopsat.plugins"
"""Entry-point group through which installed packages add plug-ins: each entry point names a
module that registers its kinds when imported (docs/plugins.md)."""

__all__ = [
    "ROLES", "PLUGIN_MODULES", "ENTRY_POINT_GROUP",
    "Plugin", "Origin", "register", "plugins", "plugin_for", "all_kinds",
    "PluginError", "DesignError", "DesignCheck", "Tunable", "BuildContext",
    "Controller", "LocalController", "NetworkDelivery", "Sensor", "Actuator", "Disturbance", "Builder", "Check",
    "protocol_problems",
    "Table", "Quaternion", "UnitVector", "part", "OutputSpec", "Pulse", "Inbox",
]

_LAZY = {
    "Table": "coopsat.plugins.tables",
    "Quaternion": "coopsat.plugins.tables",
    "UnitVector": "coopsat.plugins.tables",
    "part": "coopsat.core.parts",
    "OutputSpec": "coopsat.core.parts",
    "Pulse": "coopsat.actuators.pulses",
    "Inbox": "coopsat.network.delivery",
}
"""What a plug-in is made with, loaded on first use: :class:`~coopsat.plugins.tables.Table`, the
base of every scenario table (unknown keys, NaN, ∞ and coerced types refused), and the field
types :data:`~coopsat.plugins.tables.Quaternion` and :data:`~coopsat.plugins.tables.UnitVector`
(unit to within 0.05, as coopsat's own ``q_bi``); and, importing JAX, the pytree decorator
:func:`~coopsat.core.parts.part`, :class:`~coopsat.core.parts.OutputSpec` (how a recorded output
appears in the dataset), :class:`~coopsat.actuators.pulses.Pulse` (what an actuator's ``plan``
returns) and :class:`~coopsat.network.delivery.Inbox` (what a network's ``deliver`` returns and
a controller's ``step`` receives)."""


def __getattr__(name):
    if name not in _LAZY:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(_LAZY[name]), name)
    globals()[name] = value
    return value


class DesignError(ValueError):
    """A scenario that a plug-in cannot build (the message is one line naming the field)."""


class PluginError(Exception):
    """A plug-in that cannot be registered (one line): two registrations of one role and kind
    (naming both distributions and modules), an entry point that fails to import or does not
    name a module, an unknown role. The ``coopsat`` command prints it and exits with status 2."""


@dataclass(frozen=True)
class DesignCheck:
    """Result of a design-time check a plug-in runs before the simulation.

    Attributes
    ----------
    name : str
        Short name (``"sampled-data"``), unique within a run.
    ok : bool
        False when the run will not do what the design promises (a warning is issued, and a
        comparison with a published number quotes ``note``).
    note : str
        The check in one line.
    metrics : dict of str -> float
        Numbers known before the run (written to metrics.json).
    detail : object
        The full result (e.g. a :class:`~coopsat.design.sampled_data.SampledDataStability`).
    """

    name: str
    ok: bool
    note: str
    metrics: dict = field(default_factory=dict)
    detail: object = None


@dataclass(frozen=True)
class Tunable:
    """A scenario field that ``coopsat tune`` may vary by gradient.

    Attributes
    ----------
    value : ndarray
        Its value in this run (the table's, or what the design computed from it).
    apply : callable
        ``(part, value) -> part``: the built part with ``value`` in place; pure JAX (traced),
        so that the run is differentiable with respect to ``value``.
    write : callable
        ``value -> dict``: the fields of the plug-in's table that the tuned scenario file sets.
    root : bool
        ``write``'s keys are override paths from the scenario's root (a field that lives in
        another table: the network's graph for its delivery model).
    """

    value: object
    apply: object
    write: object
    root: bool = False


@dataclass(frozen=True)
class Origin:
    """Where a registered kind comes from.

    Attributes
    ----------
    distribution : str or None
        ``"coopsat"`` for coopsat's own modules, the installed distribution's name for an entry
        point, None when unknown (a module registered outside any entry point).
    module : str
        The module that called :func:`register`.
    entry_point : str or None
        The entry point's name in :data:`ENTRY_POINT_GROUP` (None for coopsat's own modules).
    """

    distribution: str | None
    module: str
    entry_point: str | None = None

    def __str__(self):
        return f"{self.distribution} ({self.module})" if self.distribution else self.module


@dataclass(frozen=True)
class Plugin:
    """One registered kind.

    Attributes
    ----------
    role : str
        One of :data:`ROLES`.
    kind : str
        The scenario's ``kind`` value.
    table : type
        Pydantic model of its scenario table (``kind: Literal[kind]``).
    build : callable
        ``(table, ctx: BuildContext) -> part`` (:class:`~coopsat.plugins.protocols.Builder`); the
        part satisfies its role's protocol (:mod:`coopsat.plugins.protocols`).
    checks : tuple of callables
        ``(table, ctx) -> DesignCheck or None`` (:class:`~coopsat.plugins.protocols.Check`), run
        after building.
    analysis : str or None
        Module with the paper's metrics and explanations (see :mod:`coopsat.analysis.papers`).
    tunables : callable or None
        ``(table, ctx, part) -> dict of field name -> Tunable``: the continuous fields a
        gradient may vary (gains, weights), and how each enters the built part.
    thresholds : type or None
        A :class:`~coopsat.plugins.tables.Table` of the ``[analysis]`` fields its paper's
        metrics read (a settle tolerance, a convergence bound): the scenario's ``[analysis]``
        table is composed from the core fields and every installed plug-in's thresholds, so a
        paper owns its thresholds. Two plug-ins may share one such table (the same class).
    origin : Origin or None
        Set by the registry: the distribution and module that registered it.
    """

    role: str
    kind: str
    table: type
    build: object
    checks: tuple = ()
    analysis: str | None = None
    tunables: object = None
    thresholds: type | None = None
    origin: Origin | None = field(default=None, compare=False)


_REGISTRY = {role: {} for role in ROLES}
_state = "unloaded"  # "loading" while _load imports the modules, then "loaded"
_read = False  # someone has read the loaded registry (the scenario schema is composed from it)
_loading = None  # (distribution, entry point name) of the module being loaded
_ENTRY_PACKAGES = {}  # top-level package of each entry point's module -> (distribution, entry point name)


def _caller_module(depth):
    frame = sys._getframe(depth + 1)
    return frame.f_globals.get("__name__", "?")


def _origin(module):
    """The :class:`Origin` of a registration made by ``module`` now."""
    if _loading is not None:
        return Origin(_loading[0], module, _loading[1])
    top = module.split(".", 1)[0]
    if top == "coopsat":
        return Origin("coopsat", module)
    if top in _ENTRY_PACKAGES:
        return Origin(_ENTRY_PACKAGES[top][0], module, _ENTRY_PACKAGES[top][1])
    return Origin(None, module)


def register(plugin):
    """Add a plug-in (called by each plug-in module at import).

    The registry loads first (coopsat's modules and the entry points), so a kind registered by
    a script or a module imported by hand still meets every other registration of its name.
    Such a registration must come before anything reads the registry: the scenario schema is
    composed from it when :mod:`coopsat.scenarios.schema` is first imported (loading or
    validating a scenario), and would not know a later kind.

    Returns
    -------
    Plugin
        The registered entry, its :attr:`Plugin.origin` set.

    Raises
    ------
    PluginError
        An unknown role, a role and kind registered already (the message names both), a
        registration after the registry was read, or a malformed member (a table that is not a
        ``Table``, a build that cannot be called, an analysis that is not a module name…).
    """
    if _state == "unloaded":
        _load()
    origin = _origin(_caller_module(1))
    if plugin.role not in ROLES:
        raise PluginError(
            f"plug-in {plugin.kind} of {origin}: unknown role '{plugin.role}' (roles: {', '.join(ROLES)})"
        )
    known = _REGISTRY[plugin.role].get(plugin.kind)
    if known is not None:
        if known.origin == origin:
            raise PluginError(f"plug-in {plugin.role} '{plugin.kind}' is registered twice by {origin}")
        raise PluginError(f"plug-in {plugin.role} '{plugin.kind}' is registered by {known.origin} and by {origin}")
    if _read and _loading is None:
        raise PluginError(
            f"plug-in {plugin.role} '{plugin.kind}' of {origin} is registered after the plug-in registry was read "
            f"(scenarios are validated against the kinds registered then): declare the module as a "
            f"{ENTRY_POINT_GROUP} entry point, or import it before loading any scenario"
        )
    problem = _member_problem(plugin)
    if problem is not None:
        raise PluginError(f"plug-in {plugin.role} '{plugin.kind}' of {origin}: {problem}")
    plugin = replace(plugin, origin=origin)
    _REGISTRY[plugin.role][plugin.kind] = plugin
    return plugin


def _is_table(value):
    from pydantic import BaseModel

    return isinstance(value, type) and issubclass(value, BaseModel)


def _member_problem(plugin):
    """What is wrong with a :class:`Plugin`'s members, in a few words (None when nothing is):
    checked at registration, so that a malformed plug-in fails before any scenario runs."""
    if not _is_table(plugin.table) or "kind" not in plugin.table.model_fields:
        return "table must be a coopsat.plugins.Table subclass with a 'kind' field"
    if not callable(plugin.build):
        return "build must be a function (table, ctx) -> part"
    if not isinstance(plugin.checks, (tuple, list)) or not all(callable(c) for c in plugin.checks):
        return "checks must be a tuple of functions (table, ctx) -> DesignCheck or None"
    if plugin.analysis is not None and not (isinstance(plugin.analysis, str)
                                            and all(p.isidentifier() for p in plugin.analysis.split("."))):
        return f"analysis must be the name of a module, not {plugin.analysis!r}"
    if plugin.tunables is not None and not callable(plugin.tunables):
        return "tunables must be a function (table, ctx, part) -> dict of name -> Tunable"
    if plugin.thresholds is not None and not _is_table(plugin.thresholds):
        return "thresholds must be a coopsat.plugins.Table subclass"
    return None


def _entry_points():
    """This group's entry points, each once (a distribution found twice on ``sys.path`` is one),
    sorted by distribution and name."""
    from importlib.metadata import entry_points

    found = {}
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        dist = getattr(ep, "dist", None)
        name = dist.name if dist is not None else "an unknown distribution"
        found.setdefault((name, ep.name, ep.value), ep)
    return [(key[0], ep) for key, ep in sorted(found.items(), key=lambda kv: kv[0])]


def _load_entry_point(dist, ep):
    """Import one entry point's module; on failure remove what it registered and return the
    one-line reason (None when it loaded)."""
    global _loading
    where = f"plug-in entry point '{ep.name}' of {dist} ({ep.value})"
    if ep.attr:
        return f"{where}: names an object; a {ENTRY_POINT_GROUP} entry point names a module, whose import registers its kinds"
    before = {role: set(reg) for role, reg in _REGISTRY.items()}
    _loading = (dist, ep.name)
    try:
        importlib.import_module(ep.module)
    except PluginError as err:  # a clash with a kind registered already, an unknown role: names both
        failure = str(err)
    except Exception as err:  # noqa: BLE001 (any error of a foreign module: reported in one line)
        failure = f"{where} failed to import: {one_line(err)}"
    else:
        failure = None
    finally:
        _loading = None
    if failure is not None:
        for role, reg in _REGISTRY.items():
            for kind in set(reg) - before[role]:
                del reg[kind]
    return failure


def _load():
    """Import coopsat's plug-in modules, then every entry point of :data:`ENTRY_POINT_GROUP`.

    Raises
    ------
    PluginError
        Once, from the call that loads: one line per failed entry point, joined by "; ". The
        kinds of a failed entry point are left out; every other kind is registered.
    """
    global _state, _loading
    if _state == "loaded":
        return
    if _state == "loading":
        if _loading is None or _loading[1] is None:
            who = " (while importing coopsat's plug-in modules)"
        else:
            who = f" (while importing {_loading[0]}'s entry point '{_loading[1]}')"
        raise PluginError(
            f"the plug-in registry was read while it loads{who}: a plug-in module must not read it, nor import "
            "coopsat.scenarios (which reads it), at import time"
        )
    _state = "loading"
    failures = []
    try:
        for module in PLUGIN_MODULES:
            _loading = ("coopsat", None)
            try:
                importlib.import_module(module)
            finally:
                _loading = None
        for dist, ep in _entry_points():
            _ENTRY_PACKAGES.setdefault(ep.module.split(".", 1)[0], (dist, ep.name))
            failure = _load_entry_point(dist, ep)
            if failure is not None:
                failures.append(failure)
    finally:
        _state = "loaded"
    if failures:
        raise PluginError("; ".join(failures))


def plugins(role):
    """The registered plug-ins of a role, by kind (registration order)."""
    global _read
    _load()
    _read = True
    return dict(_REGISTRY[role])


def plugin_for(role, table):
    """The plug-in that owns a validated scenario table."""
    return plugins(role)[table.kind]


def all_kinds():
    """Every registered kind name (any role)."""
    global _read
    _load()
    _read = True
    return {kind for reg in _REGISTRY.values() for kind in reg}
