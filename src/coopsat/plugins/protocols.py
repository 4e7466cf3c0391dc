"""What a plug-in's in-loop part provides, role by role: the reference for every method.

A *part* is the compiled-loop half of a plug-in: a frozen dataclass registered as a JAX pytree
(:func:`coopsat.plugins.part`), whose array fields are data (traced, batched by ``vmap``,
dispersed by a campaign without recompiling) and whose ``static`` fields are hashable
configuration (part of the compiled program's key). Its builder (:class:`Builder`,
``build(table, ctx) -> part``) runs once, at design time, with NumPy; the methods below run
inside one compiled ``jax.lax.scan`` and must be **pure JAX**: no Python side effects, no host
callbacks, no Python ``if`` on traced values (``jnp.where``), no Python loops over spacecraft or
links (vectorise; a loop over a handful of static items is unrolled at trace time and fine).

Conventions shared by every role (docs/architecture.md §3):

* **Component-major arrays.** Inside the loop every per-spacecraft array is ``(k, n)``: the
  components first, the spacecraft last (``(4, n)`` quaternions, ``(3, n)`` vectors, ``(n,)``
  scalars). ``n`` is static. A part's state and its records keep the spacecraft axis last.
* **SI units**, body-frame vectors unless the name says otherwise (``_eci``, ``_lvlh``).
* **Time.** ``t`` is seconds since the run's start (a traced scalar, the control period's
  start unless said otherwise); ``tick`` counts base ticks (``t = tick * dt_s``, int64).
* **Randomness** only from ``key``: a JAX PRNG key already specific to this part and control
  period (the engine folds in the period and the part's stream number); draw spacecraft i's
  numbers from ``jax.random.fold_in(key, i)`` (:func:`coopsat.core.parts.per_spacecraft_normal`)
  so that draws do not depend on the formation's size.
* **State** is any pytree of arrays (``()`` for none) returned by ``init`` and threaded
  through every call; its shapes and dtypes never change during a run.
* **Records** are dicts ``name -> array`` taken at the control period's start; each name is
  described by the part's :meth:`output_specs` (a :class:`~coopsat.core.parts.OutputSpec`: dims
  after time and spacecraft, units, frame, long name), which is how the output appears in
  ``result.nc``. Names are unique across the parts of a run.

The plant state ``x`` that several methods receive is a
:class:`~coopsat.dynamics.plant.PlantState` with component-major fields ``q_bi`` (4, n),
``omega_b`` (3, n), ``h_wheels_b`` (3, n), ``r_eci`` (3, n), ``v_eci`` (3, n), ``angle_rad``
(3, n) (the truth; flight software never sees it). The measurements ``y`` a controller sees
are a dict of named quantities: the run's moving state quantities (``"q"`` or ``"angle"``,
``"omega"``, and ``"h_wheels"``, ``"r_eci"``, ``"v_eci"`` when they move) with each sensor's
quantity replaced by (or, for a derived quantity such as ``"rho"``, added as) its reading.

Each protocol is ``runtime_checkable``: ``isinstance(part, Actuator)`` checks that every
member exists. :func:`protocol_problems` checks the call signatures too, and the type of every
*optional* member a part defines: the attributes a caller reads only where a part has them,
each with its default, declared once in :data:`OPTIONAL` and read through :func:`optional`.
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
from typing import TYPE_CHECKING, Any, Iterable, Mapping, Protocol, runtime_checkable

from coopsat.plugins.optional_members import OPTIONAL, OptionalMember, optional  # re-exported

if TYPE_CHECKING:  # documentation only: this module imports no JAX
    from coopsat.core.parts import OutputSpec
    from coopsat.actuators.pulses import Pulse
    from coopsat.dynamics.plant import PlantState
    from coopsat.network.delivery import Inbox
    from coopsat.plugins import DesignCheck, Tunable

Array = Any
"""A JAX array (traced inside the loop)."""
State = Any
"""A part's state: any pytree of arrays, ``()`` when it has none."""


@dataclasses.dataclass(frozen=True)
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
    graphs : list of coopsat.network.edge_list.EdgeList
        Every graph of the run in time order, as its links (j → i with weight ``a_ij``: i hears
        j), memory linear in them: a builder that must scale to big formations reads these.
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
    graphs: list
    graph_places: list
    switch_ticks: object
    r_eci_m: object = None
    v_eci_m_s: object = None

    @property
    def n(self):
        return len(self.names)

    @functools.cached_property
    def adjacencies(self):
        """Every graph of the run as ``A[i, j]`` (i hears j), list of ndarray (n, n): n² memory
        each, made when first asked (eigen-analysis, routes); :attr:`graphs` scale."""
        return [g.toarray() for g in self.graphs]

    def index(self, name, where):
        """The state-order index of spacecraft ``name``.

        Raises
        ------
        coopsat.plugins.DesignError
            A name the scenario has no spacecraft of: one line naming ``where`` (the table key,
            e.g. ``"controller.chief"``) and the known names.
        """
        if name not in self.names:
            from coopsat.plugins import DesignError

            raise DesignError(f"{where}: unknown spacecraft '{name}' (known: {', '.join(self.names)})")
        return self.names.index(name)


class Builder(Protocol):
    """A plug-in's builder, :attr:`coopsat.plugins.Plugin.build`."""

    def __call__(self, table: Any, ctx: BuildContext) -> Any:
        """Turn a validated scenario table into the in-loop part (design time, NumPy/SciPy).

        Parameters
        ----------
        table : pydantic model
            The plug-in's own table, validated (``kind`` is the plug-in's).
        ctx : BuildContext
            The rest of the scenario, the spacecraft, the time base and the graphs.

        Returns
        -------
        part
            A :func:`~coopsat.core.parts.part` dataclass satisfying the role's protocol, its array
            fields laid out for the loop (component-major, spacecraft last) and converted with
            :func:`coopsat.sim.system.as_arrays` (or ``jnp.asarray``).

        Raises
        ------
        coopsat.plugins.DesignError
            A configuration it cannot build, in one line naming the field
            (``actuators.min_pulse_s (…) must be shorter than the control period``); the CLI
            prints it and exits with status 2.

        Import JAX and the part's module inside the builder, not at the plug-in module's top,
        so that ``coopsat list`` stays quick.
        """


class Check(Protocol):
    """A design-time check, one of :attr:`coopsat.plugins.Plugin.checks` (run after building)."""

    def __call__(self, table: Any, ctx: BuildContext) -> DesignCheck | Iterable[DesignCheck] | None:
        """A :class:`~coopsat.plugins.DesignCheck` (or several, or None when there is nothing
        to say). A failed check (``ok=False``) is a warning before the run and is quoted by
        the comparison with published numbers; its ``metrics`` go to metrics.json. Raise
        :class:`~coopsat.plugins.DesignError` for a configuration that must not run."""


class Tunables(Protocol):
    """A plug-in's gradient-tunable fields, :attr:`coopsat.plugins.Plugin.tunables` (``coopsat tune``)."""

    def __call__(self, table: Any, ctx: BuildContext, part: Any) -> Mapping[str, Tunable]:
        """The continuous fields of ``table`` a gradient may vary (gains, weights), by field
        name: each a :class:`~coopsat.plugins.Tunable` with its value in this run and how it
        enters the built ``part`` (pure JAX, so that the run is differentiable)."""


@runtime_checkable
class Controller(Protocol):
    """Flight software of the whole formation (``[controller]``): sees every spacecraft's
    measurements at once and the messages each heard, as sums over links.

    The engine calls, every control period: ``outbox`` → the network's ``deliver`` → ``step``.
    A law written over links must only combine each spacecraft's own measurements with the
    messages addressed to it (``inbox.dst``); :class:`LocalController` makes the engine
    enforce that. A formation-wide law may also offer its per-spacecraft form (``reads``,
    ``outbox_one`` and ``step_one`` as :class:`LocalController`'s, equal to :meth:`step` per
    spacecraft): software in the loop runs that, one process per spacecraft (docs/sil.md).
    """

    commands: tuple[str, ...]
    """The commands ``step`` issues (``("torque_b",)``; ``()`` for none). Each actuator
    executes one of them (its ``command``); the scenario is refused otherwise. Commands are
    per spacecraft ``(3, n)``: ``torque_b`` N·m body, ``force_lvlh`` / ``force_b`` /
    ``force_eci`` N, ``dipole_b`` A·m² body."""

    def init(self, n: int) -> State:
        """The state at t = 0 (integrators, observers, a planner's target), spacecraft axis
        last; ``()`` for a stateless law. ``n``: number of spacecraft (static)."""

    def outbox(self, y: Mapping[str, Array], state: State) -> dict[str, Array]:
        """What each spacecraft broadcasts this period: ``{name: (k, n)}`` (e.g. its measured
        ``q`` (4, n) and ``omega`` (3, n)). Called before ``step``, with the same ``y``; the
        first call's result also fills the network's delay lines (``init``)."""

    def step(
        self, t: Array, y: Mapping[str, Array], inbox: Inbox, state: State, key: Array
    ) -> tuple[dict[str, Array], State, dict[str, Array]]:
        """The period's commands, held for the whole period (zero-order hold).

        Parameters
        ----------
        t : scalar
            Start of the control period, s.
        y : dict of str -> array
            Measurements, component-major (see the module docstring).
        inbox : Inbox
            Per link the message as delivered: ``msg[name]`` ``(k, E)`` for an edge list
            sorted by receiver, or ``(k, d, n)`` for a padded in-neighbour table; ``weight``
            ``a_ij`` ``(E,)`` / ``(d, n)`` (0 for a link absent now, failed, or whose message
            was lost); ``dst`` the receiver of each link, same shape; ``own`` the receiver's
            own outbox from the message's instant. A law supports both layouts by summing per
            receiver: ``jax.ops.segment_sum`` over ``dst`` (edge list) or ``.sum(axis=-2)``
            (padded table; ``dst.ndim == 2``).
        state : pytree
        key : PRNG key

        Returns
        -------
        commands : dict of str -> (3, n)
            One entry per name in :attr:`commands`.
        state : pytree
            The new state.
        record : dict of str -> array
            What to record at this instant (``(k, n)`` per spacecraft, or per instant when its
            :class:`~coopsat.core.parts.OutputSpec` says ``per_spacecraft=False``).
        """

    def output_specs(self) -> dict[str, OutputSpec]:
        """How each name ``step`` records appears in the dataset."""


@runtime_checkable
class LocalController(Protocol):
    """One spacecraft's flight software (a controller part with ``local = True``): the engine
    runs one copy per spacecraft (``vmap``), giving it only its own readings of what it
    ``reads``, only the links addressed to it, and its own state slice
    (:mod:`coopsat.sim.flight_software`). Anything else it knows arrives over the network."""

    local: bool
    """True."""
    reads: tuple[str, ...]
    """The measured quantities it reads (``("q", "omega")``, ``("rho",)``)."""
    commands: tuple[str, ...]
    """As :attr:`Controller.commands`."""

    def init(self, n: int) -> State:
        """The whole formation's state at t = 0, the spacecraft axis last (each copy gets its
        column)."""

    def outbox_one(self, i: Array, y_i: Mapping[str, Array], state_i: State) -> dict[str, Array]:
        """Spacecraft ``i``'s message ``{name: (k,)}`` from its own readings ``y_i``
        (``{quantity: (k,)}``, only those in :attr:`reads`) and its state."""

    def step_one(
        self, i: Array, t: Array, y_i: Mapping[str, Array], inbox_i: Inbox, state_i: State, key_i: Array
    ) -> tuple[dict[str, Array], State, dict[str, Array]]:
        """Spacecraft ``i``'s commands ``{name: (3,)}``, new state and record ``{name: (k,)}``.
        ``inbox_i`` has one flat link axis ``(E,)`` whatever the network's layout, every link
        not addressed to ``i`` zeroed (message and weight), and no ``own`` unless the part has
        ``reads_own = True`` (then per link its own outbox of the instant the link's message
        was sent, zeroed as ``msg``); ``key_i`` is ``fold_in(key, i)``."""

    def output_specs(self) -> dict[str, OutputSpec]:
        """How each name ``step_one`` records appears in the dataset (per spacecraft)."""


@runtime_checkable
class NetworkDelivery(Protocol):
    """The network model (``[network.delivery]``): turns this period's outboxes into what each
    link delivers — delays (a delay line of past outboxes in the state), losses, relaying,
    switching graphs (:attr:`BuildContext.switch_ticks`)."""

    def init(self, outbox0: Mapping[str, Array]) -> State:
        """The state at t = 0, given the first outbox ``{name: (k, n)}`` (the history before
        t = 0 is that outbox: a constant initial function)."""

    def deliver(
        self, tick: Array, outbox: Mapping[str, Array], state: State, key: Array
    ) -> tuple[Inbox, State, dict[str, Array]]:
        """This period's :class:`~coopsat.network.delivery.Inbox` (see :meth:`Controller.step`
        for its fields), the new state and the record.

        Parameters
        ----------
        tick : int64 scalar
            Base tick at the period's start.
        outbox : dict of str -> (k, n)
            Every spacecraft's message this period.
        state, key
            As everywhere.
        """

    def output_specs(self) -> dict[str, OutputSpec]:
        """How each name ``deliver`` records appears in the dataset."""


@runtime_checkable
class Sensor(Protocol):
    """One ``[[sensors]]`` entry: replaces one measured quantity by what the sensor reads (or
    adds a derived one). Its reading updates every :attr:`every` periods and is held between
    (the engine holds it; ``measure`` is still called every period)."""

    quantity: str
    """The key of ``y`` it sets: a state quantity (``"q"``, ``"omega"``, ``"r_eci"``, …) or a
    derived one (``"rho"``, ``"sun_b"``, ``"b_b"``)."""
    needs: tuple[str, ...]
    """The state quantities its truth comes from (checked against the run when it is built)."""
    every: int
    """Static, ≥ 1: control periods between updates."""

    def truth(self, y: Mapping[str, Array], x: PlantState, t: Array) -> Array:
        """The true value of what it reads, from the true quantities ``y`` or the plant state
        ``x`` at time ``t`` (a state quantity's sensor returns ``y[quantity]``); ``(k, n)``."""

    def init(self, truth_value: Array, n: int) -> State:
        """The state at t = 0 (a gyro's bias), given the truth at t = 0."""

    def measure(self, truth_value: Array, x: PlantState, state: State, key: Array) -> tuple[Array, State]:
        """The reading (shaped as ``truth_value``) and the new state."""

    def output_specs(self) -> dict[str, OutputSpec]:
        """Its own records; a derived quantity also describes ``measured_<quantity>`` (a state
        quantity's reading is described by the engine)."""


@runtime_checkable
class Actuator(Protocol):
    """One actuator (``[actuators]`` / ``[[actuators]]``): turns one command into one pulse per
    control period on one wrench channel, and counts what it did."""

    command: str
    """Static: the controller command it executes (a key of the controller's commands; zeros
    when the controller issues none)."""
    channel: str
    """The wrench channel it acts through (:data:`coopsat.dynamics.plant.WRENCH_CHANNELS`):
    ``torque_b`` (N·m, body), ``wheel_torque_b`` (N·m, the wheels' momentum rate),
    ``force_eci``, ``force_b``, ``force_lvlh`` (N)."""
    pulsed: bool
    """True when its pulses switch off inside the period (``t_off_s < period``): the engine
    then integrates each tick piecewise between the switch instants, so on-times are exact.
    False: ``t_off_s`` is the whole period."""
    mean_output: tuple[str, str]
    """``(name, counter)``: the recorded mean output over each record interval (``"torque"``)
    and the signed counter of :meth:`account` it is computed from (``"angular_impulse"``,
    level × seconds)."""

    def init(self, n: int) -> State:
        """The state at t = 0 (a carried remainder, a delay line of commands, wheel speeds)."""

    def plan(
        self, command: Array, x: PlantState, state: State, period_s: Array, key: Array, t: Array
    ) -> tuple[Pulse, State]:
        """This period's pulse and the new state.

        Parameters
        ----------
        command : (3, n)
            The controller's command this period (units of the command).
        x : PlantState
            The true state at the period's start (for models that depend on it: a wheel's
            speed, the Earth's field).
        state, key
            As everywhere.
        period_s : scalar
            Control period, s.
        t : scalar
            Period start, s.

        Returns
        -------
        pulse : Pulse
            ``level_nm`` (3, n): the level on :attr:`channel` while on (N·m or N, despite the
            field's name); ``t_off_s`` (3, n): when each axis switches off, s after the
            period's start, in ``[0, period_s]`` (the level acts from the period's start).
        state : pytree
        """

    def record(self, x: PlantState, state: State) -> dict[str, Array]:
        """What to record at the period's start, from the state before :meth:`plan`."""

    def account(self, pulse: Pulse) -> dict[str, Array]:
        """This period's increments of its counters ``{name: (k, n)}`` (impulse, on-time,
        firings…): the engine sums them over the run and records the running totals. Names
        are unique across the run's actuators and include ``mean_output[1]``."""

    def output_specs(self) -> dict[str, OutputSpec]:
        """How its records, its counters and ``mean_output[0]`` appear in the dataset."""


@runtime_checkable
class Disturbance(Protocol):
    """One ``[[disturbances]]`` entry: an environment torque or force."""

    def init(self, n: int) -> State:
        """The state at t = 0 (``()`` for a model of the state alone)."""

    def update(self, t: Array, x: PlantState, state: State, key: Array) -> State:
        """Once per control period, at its start: the new state (a random torque's draw for
        the period)."""

    def wrench(self, t: Array, x: PlantState, state: State) -> dict[str, Array]:
        """``{channel: (3, n)}`` at every integration stage (``t`` and ``x`` the stage's time
        and state), summed with the actuators' channels: keep it cheap."""

    def record(self, t: Array, x: PlantState, state: State) -> dict[str, Array]:
        """What to record at the period's start."""

    def output_specs(self) -> dict[str, OutputSpec]:
        """How each name ``record`` returns appears in the dataset."""


@runtime_checkable
class Navigation(Protocol):
    """One spacecraft's navigation filter (``[navigation]``), run in its flight software before
    the law (:mod:`coopsat.control.navigated`): the law reads the estimate of the quantities it
    ``provides`` (``("x_lvlh",)``) instead of its readings; it ``reads`` measured quantities
    (``("gnss",)``); ``reads_own`` as :attr:`LocalController.reads_own`. Per spacecraft."""

    provides: tuple[str, ...]
    reads: tuple[str, ...]
    reads_own: bool

    def init(self, n: int) -> State:
        """Every spacecraft's filter state before its first period, spacecraft axis last."""

    def check_law(self, law: Any, kind: str) -> str | None:
        """Why ``law`` cannot fly on this filter, or None (design time)."""

    def estimate_of(self, i: Array, state_i: State) -> dict[str, Array]:
        """The estimate in ``state_i`` as the law reads it, ``{quantity: (k,)}``."""

    def outbox_one(self, i: Array, y_i: Mapping[str, Array], state_i: State) -> dict[str, Array]:
        """What spacecraft ``i``'s filter broadcasts (names distinct from the law's)."""

    def update_one(self, i: Array, t: Array, y_i: Mapping[str, Array], inbox_i: Inbox, state_i: State, key_i: Array):
        """The measurement updates at t: (state, ``estimate_of`` the posterior, record)."""

    def predict_one(self, i: Array, state_i: State, commands: Mapping[str, Array]) -> State:
        """The prior at the next period's start under the law's commands ``{name: (3,)}``."""

    def output_specs(self) -> dict[str, OutputSpec]:
        """How each name ``update_one`` records appears in the dataset (per spacecraft)."""

    def true_state(self, r_eci: Any, v_eci: Any) -> Any:
        """The truth of the estimate from recorded ECI states (T, n, 3): (T, n, k) NumPy."""

    def estimated(self, n: int) -> list[int]:
        """The spacecraft whose estimates are judged against the truth."""


PROTOCOLS = {
    "controller": Controller,
    "actuator": Actuator,
    "sensor": Sensor,
    "network": NetworkDelivery,
    "disturbance": Disturbance,
    "navigation": Navigation,
}
"""Each role's protocol (a controller part with ``local = True`` follows :class:`LocalController`)."""


def protocol_of(part: Any, role: str) -> type:
    """The protocol a part of ``role`` follows."""
    if role == "controller" and optional(part, "local"):
        return LocalController
    return PROTOCOLS[role]


def members(protocol: type) -> list[str]:
    """A protocol's members (attributes and methods), in definition order."""
    names = list(getattr(protocol, "__annotations__", {}))
    names += [k for k, v in vars(protocol).items() if inspect.isfunction(v)]
    return [k for k in dict.fromkeys(names) if not k.startswith("_")]


def protocol_problems(part: Any, role: str) -> list[str]:
    """What keeps ``part`` from being a part of ``role``; empty when nothing does.

    Checks that it is a frozen dataclass registered as a JAX pytree (:func:`coopsat.plugins.part`),
    that every member of its protocol exists, that each method accepts the protocol's
    positional arguments (the engine passes them by position; extra parameters need defaults),
    and that each optional member of its role it defines (:data:`OPTIONAL`) has its type.

    Returns
    -------
    list of str
        One line per problem (``"ColdGas.plan(command, x, state) cannot be called as
        plan(command, x, state, period_s, key, t)"``, ``"Net.hold is 'yes', not a bool
        (optional member of a network part)"``).
    """
    import jax

    protocol = protocol_of(part, role)
    name = type(part).__name__
    out = []
    if not (dataclasses.is_dataclass(part) and type(part).__dataclass_params__.frozen):
        out.append(f"{name} is not a frozen dataclass (decorate it with coopsat.plugins.part)")
    elif any(leaf is part for leaf in jax.tree_util.tree_leaves(part)):
        out.append(f"{name} is not registered as a JAX pytree (decorate it with coopsat.plugins.part)")
    for member in members(protocol):
        if not hasattr(part, member):
            out.append(f"{name} has no {member} ({protocol.__name__} protocol)")
            continue
        reference = vars(protocol).get(member)
        if not inspect.isfunction(reference):
            continue
        wanted = list(inspect.signature(reference).parameters)[1:]
        try:
            inspect.signature(getattr(part, member)).bind(*wanted)
        except TypeError:
            try:
                have = str(inspect.signature(getattr(part, member)))
            except (TypeError, ValueError):
                have = "(…)"
            out.append(f"{name}.{member}{have} cannot be called as {member}({', '.join(wanted)})")
    return out + _optional_problems(part, role)


def _optional_problems(part, role):
    """A line per optional member of ``role`` that ``part`` defines with a value of another type."""
    out = []
    for member, spec in OPTIONAL.items():
        if role in spec.roles and hasattr(part, member):
            value = getattr(part, member)
            if not isinstance(value, spec.types):
                out.append(f"{type(part).__name__}.{member} is {value!r}, not {spec.what} (optional member of a {role} part)")
    return out


def _is_table(value):
    from pydantic import BaseModel

    return isinstance(value, type) and issubclass(value, BaseModel)


def plugin_problem(plugin: Any) -> str | None:
    """What is wrong with a :class:`~coopsat.plugins.Plugin`'s members, in a few words (None when
    nothing is): checked at registration, so that a malformed plug-in fails before any scenario
    runs."""
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
