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
``coopsat.plugins`` (:data:`ENTRY_POINT_GROUP`): an entry point names a module, and importing
that module calls :func:`register` as coopsat's own modules do; or it names a :class:`Plugin`
(or a list of them) in a module, registered as if that module had called :func:`register`
(docs/plugins.md)::

    [project.entry-points."coopsat.plugins"]
    example = "coopsat_example.plugin"
    pd = "coopsat_pd.plugin:PLUGIN"

The registry loads on first use (:func:`plugins`, which the scenario schema calls when it is
imported): coopsat's modules, then every entry point, sorted by distribution and name. One lock
guards it: a thread's first call waits while another thread loads it. When one of coopsat's own
modules fails to import, the error propagates and the registry stays unloaded (the next call
tries again). :func:`refresh` loads the entry points installed since, until the registry is
first read. Each registered :class:`Plugin` carries its :class:`Origin` (the distribution, the
entry point and the module that defines its table). Two registrations of one role and kind, a
plug-in module that fails to import, or an entry point that names something other than a
module or Plugins raise :class:`PluginError`, one line naming both parties or the entry point;
the offending entry point's kinds are then left out, so the error is raised once, by the call
that loaded the registry.

Plug-in modules import only light libraries at import time (pydantic, :mod:`coopsat.plugins`);
their builders import JAX and SciPy inside, so ``coopsat list`` stays quick. A plug-in module
must not import :mod:`coopsat.scenarios` (or anything that does) at import time: the scenario
schema is composed from the registry, which is still loading then.
"""

import importlib
import sys
import threading
from dataclasses import dataclass, field, replace

from coopsat.core.errors import DesignError, PluginError, one_line
from coopsat.plugins.protocols import (
    Actuator,
    Builder,
    BuildContext,
    Check,
    Controller,
    Disturbance,
    LocalController,
    Navigation,
    NetworkDelivery,
    Sensor,
    Tunables,
    plugin_problem,
    protocol_problems,
)

ROLES = ("controller", "actuator", "sensor", "network", "disturbance", "navigation")
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
    "coopsat.plugins.navigation",
    "coopsat.plugins.orbit_navigation",
)
"""Every module of coopsat that registers plug-ins (one line per module)."""

ENTRY_POINT_GROUP = "coopsat.plugins"
"""Entry-point group through which installed packages add plug-ins: each entry point names a
module that registers its kinds when imported, or a :class:`Plugin` (or a list of them) to
register (docs/plugins.md)."""

__all__ = [
    "ROLES", "PLUGIN_MODULES", "ENTRY_POINT_GROUP",
    "Plugin", "Origin", "register", "plugins", "plugin_for", "all_kinds", "refresh",
    "PluginError", "DesignError", "DesignCheck", "Tunable", "BuildContext",
    "Controller", "LocalController", "NetworkDelivery", "Sensor", "Actuator", "Disturbance", "Navigation", "Builder",
    "Check", "Tunables", "protocol_problems",
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
        The module that defines the plug-in's table (:attr:`Plugin.table`): the module that
        registers it, as a rule.
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
    build : Builder
        ``(table, ctx: BuildContext) -> part`` (:class:`~coopsat.plugins.protocols.Builder`); the
        part satisfies its role's protocol (:mod:`coopsat.plugins.protocols`).
    checks : tuple of Check
        ``(table, ctx) -> DesignCheck or None`` (:class:`~coopsat.plugins.protocols.Check`), run
        after building.
    analysis : str or None
        Module with the paper's metrics and explanations (see :mod:`coopsat.analysis.papers`).
    tunables : Tunables or None
        ``(table, ctx, part) -> dict of field name -> Tunable``
        (:class:`~coopsat.plugins.protocols.Tunables`): the continuous fields a gradient may vary
        (gains, weights), and how each enters the built part.
    thresholds : type or None
        A :class:`~coopsat.plugins.tables.Table` of the ``[analysis]`` fields its paper's
        metrics read (a settle tolerance, a convergence bound): the scenario's ``[analysis]``
        table is composed from the core fields and every installed plug-in's thresholds, so a
        paper owns its thresholds. Two plug-ins may share one such table (the same class).
    origin : Origin or None
        Set by the registry: the distribution and entry point that registered it, and the
        module that defines its table.
    """

    role: str
    kind: str
    table: type
    build: Builder
    checks: tuple[Check, ...] = ()
    analysis: str | None = None
    tunables: Tunables | None = None
    thresholds: type | None = None
    origin: Origin | None = field(default=None, compare=False)


_LOCK = threading.RLock()
"""Guards loading and registering: a thread's first call waits while another thread loads the
registry. Re-entrant, because the loading thread's plug-in modules call :func:`register`."""
_REGISTRY = {role: {} for role in ROLES}
_state = "unloaded"  # "loading" while _discover imports the modules, then "loaded"
_read = False  # someone has read the loaded registry (the scenario schema is composed from it)
_loading = None  # (distribution, entry point name) of the module being loaded
_ENTRY_PACKAGES = {}  # top-level package of each entry point's module -> (distribution, entry point name)
_TRIED = set()  # (distribution, name, value) of each entry point imported once: refresh() skips them


def _defining_module(plugin):
    """The module that defines the plug-in's table (its builder's when the table is not a class):
    the module that registers it, as a rule. The table rather than the builder, because a
    package may pair its own table with a builder it imports (coopsat's, say)."""
    owner = plugin.table if isinstance(plugin.table, type) else plugin.build
    return getattr(owner, "__module__", None) or "?"


def _origin(module):
    """The :class:`Origin` of a registration of a plug-in defined in ``module``, made now."""
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
        The registered entry, its :attr:`Plugin.origin` set: the entry point being loaded (or
        the one whose package defines the table, or coopsat), and the module that defines the
        plug-in's table.

    Raises
    ------
    PluginError
        An unknown role, a role and kind registered already (the message names both), a
        registration after the registry was read, or a malformed member (a table that is not a
        ``Table``, a build that cannot be called, an analysis that is not a module name…); and,
        when this call loads the registry, what :func:`plugins` raises.
    """
    with _LOCK:
        if _state == "unloaded":
            _load()
        return _add(plugin)


def _add(plugin):
    """Register ``plugin`` in the loaded or loading registry (the caller holds the lock).

    Raises
    ------
    PluginError
        As :func:`register`.
    """
    origin = _origin(_defining_module(plugin))
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
    problem = plugin_problem(plugin)
    if problem is not None:
        raise PluginError(f"plug-in {plugin.role} '{plugin.kind}' of {origin}: {problem}")
    plugin = replace(plugin, origin=origin)
    _REGISTRY[plugin.role][plugin.kind] = plugin
    return plugin


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


def _as_plugins(value, where):
    """The :class:`Plugin` objects an entry point's ``module:attribute`` names: one, or a list
    or tuple of them.

    Raises
    ------
    PluginError
        It names anything else: one line saying what an entry point may name.
    """
    named = tuple(value) if isinstance(value, (list, tuple)) else (value,)
    if not all(isinstance(p, Plugin) for p in named):
        raise PluginError(
            f"{where}: names an object that is not a Plugin ({type(value).__name__}); a {ENTRY_POINT_GROUP} entry "
            "point names a module, whose import registers its kinds, or a coopsat.plugins.Plugin or a list of them"
        )
    return named


def _import_entry_point(dist, ep):
    """Import an entry point's module (which may register kinds) and register the Plugins its
    attribute names, if it names one; the one-line reason it failed (None when it loaded)."""
    where = f"plug-in entry point '{ep.name}' of {dist} ({ep.value})"
    try:
        value = ep.load()  # the module, or the object its attribute names
        if ep.attr:
            for plugin in _as_plugins(value, where):
                _add(plugin)
    except PluginError as err:  # a clash (names both), an unknown role, an object that is not a Plugin
        return str(err)
    except Exception as err:  # noqa: BLE001 (any error of a foreign module: reported in one line)
        return f"{where} failed to import: {one_line(err)}"
    return None


def _load_entry_point(dist, ep):
    """Load one entry point; on failure remove what it registered and return the one-line
    reason (None when it loaded)."""
    global _loading
    before = {role: set(reg) for role, reg in _REGISTRY.items()}
    _loading = (dist, ep.name)
    try:
        failure = _import_entry_point(dist, ep)
    finally:
        _loading = None
    if failure is not None:
        for role, reg in _REGISTRY.items():
            for kind in set(reg) - before[role]:
                del reg[kind]
    return failure


def _load_new_entry_points(tried):
    """Load every entry point not loaded before, appending its module to ``tried``; the
    one-line reason of each that failed."""
    failures = []
    for dist, ep in _entry_points():
        key = (dist, ep.name, ep.value)
        if key in _TRIED:
            continue
        _TRIED.add(key)
        tried.append(ep.module)
        _ENTRY_PACKAGES.setdefault(ep.module.split(".", 1)[0], (dist, ep.name))
        failure = _load_entry_point(dist, ep)
        if failure is not None:
            failures.append(failure)
    return failures


def _import_own(modules):
    """Import coopsat's plug-in modules (each registers its kinds)."""
    global _loading
    for module in modules:
        _loading = ("coopsat", None)
        try:
            importlib.import_module(module)
        finally:
            _loading = None


def _saved():
    """What :func:`_restore` puts back: the state, the kinds, the entry points' packages and
    tries, and the names of the modules imported so far."""
    kinds = {role: dict(reg) for role, reg in _REGISTRY.items()}
    return _state, kinds, dict(_ENTRY_PACKAGES), set(_TRIED), set(sys.modules)


def _restore(saved, tried):
    """Put the registry back as :func:`_saved` found it, and forget the modules of ``tried``
    imported since: otherwise the next load would find them imported and their kinds would
    never be registered again."""
    global _state
    _state, kinds, packages, entry_points, modules = saved
    for role, reg in _REGISTRY.items():
        reg.clear()
        reg.update(kinds[role])
    _ENTRY_PACKAGES.clear()
    _ENTRY_PACKAGES.update(packages)
    _TRIED.clear()
    _TRIED.update(entry_points)
    for module in tried:
        if module not in modules:
            sys.modules.pop(module, None)


def _discover(own_modules):
    """Import ``own_modules`` (coopsat's, on the first load) and every entry point not loaded
    before, the registry marked as loading meanwhile (the caller holds the lock).

    Raises
    ------
    PluginError
        After every other kind is registered: one line per failed entry point, joined by "; "
        (the kinds of a failed entry point are left out).
    BaseException
        Whatever else an import raised (one of coopsat's modules, an interrupt): the registry
        is put back as it was, so that the next call tries again.
    """
    global _state
    saved = _saved()
    tried = list(own_modules)  # they import one another: any of them may be imported by this call
    _state = "loading"
    try:
        _import_own(own_modules)
        failures = _load_new_entry_points(tried)
    except BaseException:
        _restore(saved, tried)
        raise
    _state = "loaded"
    if failures:
        raise PluginError("; ".join(failures))


def _reentered():
    """The error of a registry asked for by the thread that is loading it."""
    if _loading is None or _loading[1] is None:
        who = " (while importing coopsat's plug-in modules)"
    else:
        who = f" (while importing {_loading[0]}'s entry point '{_loading[1]}')"
    return PluginError(
        f"the plug-in registry was read while it loads{who}: a plug-in module must not read it, nor import "
        "coopsat.scenarios (which reads it), at import time"
    )


def _load():
    """Load the registry unless it is loaded: coopsat's plug-in modules, then every entry point
    of :data:`ENTRY_POINT_GROUP`. Another thread loading it is waited for.

    Raises
    ------
    PluginError
        This thread is loading it (a plug-in module read it at import time); or, once, from the
        call that loads: one line per failed entry point, joined by "; ". The kinds of a failed
        entry point are left out; every other kind is registered.
    BaseException
        Whatever importing one of coopsat's own modules raised: the registry stays unloaded.
    """
    with _LOCK:
        if _state == "loading":
            raise _reentered()
        if _state == "unloaded":
            _discover(PLUGIN_MODULES)


def refresh():
    """Load the entry points of :data:`ENTRY_POINT_GROUP` installed since the registry loaded
    (or load the registry, when nothing has).

    Only until the registry is first read: the scenario schema is composed from it when
    :mod:`coopsat.scenarios.schema` is first imported (loading or validating a scenario), and
    would not know a later kind; after that, a new kind needs a new Python process.

    Returns
    -------
    tuple of Plugin
        The kinds it registered, role by role (empty when nothing new was installed).

    Raises
    ------
    PluginError
        The registry was read already (one line saying so; nothing is loaded); this thread is
        loading it; or one line per new entry point that failed, joined by "; " (its kinds are
        left out, every other kind is registered).
    """
    importlib.invalidate_caches()  # the import system caches folder listings: see what was installed since
    with _LOCK:
        if _read:
            raise PluginError(
                "the plug-in registry cannot be refreshed after it was read (scenarios are validated against the "
                "kinds registered then): call coopsat.plugins.refresh() before loading any scenario, or start a "
                "new Python process"
            )
        known = {(role, kind) for role, reg in _REGISTRY.items() for kind in reg}
        if _state == "loaded":
            _discover(())
        else:
            _load()
        return tuple(p for role, reg in _REGISTRY.items() for kind, p in reg.items() if (role, kind) not in known)


def plugins(role):
    """The registered plug-ins of a role, by kind (registration order); the registry loads on
    the first call (another thread's load is waited for).

    Raises
    ------
    PluginError
        This thread is loading the registry (a plug-in module read it at import time); or, from
        the call that loads it, one line per failed entry point, joined by "; " (every other
        kind is registered). What importing one of coopsat's own modules raised propagates, the
        registry left unloaded.
    """
    global _read
    with _LOCK:
        _load()
        _read = True
        return dict(_REGISTRY[role])


def plugin_for(role, table):
    """The plug-in that owns a validated scenario table."""
    return plugins(role)[table.kind]


def all_kinds():
    """Every registered kind name (any role); the registry loads as for :func:`plugins`, which
    lists what is raised."""
    global _read
    with _LOCK:
        _load()
        _read = True
        return {kind for reg in _REGISTRY.values() for kind in reg}
