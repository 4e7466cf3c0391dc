"""Plug-ins: every controller, actuator, sensor, network model and disturbance, behind one
registry.

A plug-in is a module that registers one or more :class:`Plugin` entries, each of which owns

* its scenario table: a pydantic model whose ``kind`` field is a ``Literal`` of its name
  (:mod:`coopsat.scenarios.schema` composes the scenario schema from the registered tables);
* its builder: ``build(table, ctx) -> part``, design-time NumPy/SciPy code turning the table
  into the in-loop part (a :func:`coopsat._parts.part` dataclass with pure ``init``/``step``
  functions; docs/architecture.md §4 lists each role's methods);
* optionally design-time checks ``check(table, ctx) -> DesignCheck or None`` (stability of a
  sampled-data law, an actuator's dead band…), run before the simulation;
* optionally the name of an analysis module (``coopsat.analysis.<paper>``) that adds the
  paper's metrics and its explanations of differences from published numbers.

:data:`PLUGIN_MODULES` lists the modules; adding a plug-in is a new module and one line
there. Plug-in modules import only light libraries at import time (pydantic); their builders
import JAX and SciPy inside, so ``coopsat list`` stays quick.
"""

import importlib
from dataclasses import dataclass, field

ROLES = ("controller", "actuator", "sensor", "network", "disturbance")
"""Kinds of plug-in, in the order the scenario file's tables appear."""

PLUGIN_MODULES = (
    "coopsat.plugins.free",
    "coopsat.plugins.consensus",
    "coopsat.plugins.torque_actuators",
    "coopsat.plugins.force_actuators",
    "coopsat.plugins.wheel_actuators",
    "coopsat.plugins.pid",
    "coopsat.plugins.cartwheel",
    "coopsat.plugins.leader_follower",
    "coopsat.plugins.formation",
    "coopsat.plugins.networks",
    "coopsat.plugins.disturbances",
    "coopsat.plugins.sensors",
    "coopsat.plugins.earth_environment",
    "coopsat.plugins.observation",
)
"""Every module that registers plug-ins (one line per module)."""


class DesignError(ValueError):
    """A scenario that a plug-in cannot build (the message is one line naming the field)."""


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
class BuildContext:
    """What a builder may read besides its own table (design-time, NumPy).

    Attributes
    ----------
    scenario : coopsat.scenarios.schema.Scenario
        The whole validated scenario (for cross-table facts: the controller's period, the
        actuator's saturation…).
    names : list of str
        Spacecraft names in state order.
    inertia_kgm2 : ndarray (n, 3, 3)
    dt_s, period_s : float
        Base tick and control period, s.
    adjacencies : list of ndarray (n, n)
        Every graph of the run in time order (``A[i, j]``: i hears j).
    graph_places : list of str
        Each graph's place in the scenario (``"network"``, ``"network.switches[0]"``).
    switch_ticks : ndarray of int (G,)
        First tick of each graph.
    r_eci_m, v_eci_m_s : ndarray (n, 3)
        Initial ECI positions, m, and velocities, m/s (zeros for a run without ``[orbit]``).
    """

    scenario: object
    names: list
    inertia_kgm2: object
    dt_s: float
    period_s: float
    adjacencies: list
    graph_places: list
    switch_ticks: object
    r_eci_m: object = None
    v_eci_m_s: object = None

    @property
    def n(self):
        return len(self.names)


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
        ``(table, ctx: BuildContext) -> part``.
    checks : tuple of callables
        ``(table, ctx) -> DesignCheck or None``, run after building.
    analysis : str or None
        Module with the paper's metrics and explanations (see :mod:`coopsat.analysis.papers`).
    tunables : callable or None
        ``(table, ctx, part) -> dict of field name -> Tunable``: the continuous fields a
        gradient may vary (gains, weights), and how each enters the built part.
    """

    role: str
    kind: str
    table: type
    build: object
    checks: tuple = ()
    analysis: str | None = None
    tunables: object = None


_REGISTRY = {role: {} for role in ROLES}
_loaded = False


def register(plugin):
    """Add a plug-in (called by each plug-in module at import)."""
    if plugin.role not in ROLES:
        raise ValueError(f"plug-in {plugin.kind}: unknown role '{plugin.role}' (roles: {', '.join(ROLES)})")
    if plugin.kind in _REGISTRY[plugin.role]:
        raise ValueError(f"plug-in {plugin.role} '{plugin.kind}' is registered twice")
    _REGISTRY[plugin.role][plugin.kind] = plugin
    return plugin


def _load():
    global _loaded
    if not _loaded:
        _loaded = True
        for module in PLUGIN_MODULES:
            importlib.import_module(module)


def plugins(role):
    """The registered plug-ins of a role, by kind (registration order)."""
    _load()
    return dict(_REGISTRY[role])


def plugin_for(role, table):
    """The plug-in that owns a validated scenario table."""
    return plugins(role)[table.kind]


def all_kinds():
    """Every registered kind name (any role)."""
    _load()
    return {kind for reg in _REGISTRY.values() for kind in reg}
