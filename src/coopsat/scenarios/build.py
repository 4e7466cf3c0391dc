"""Turn a validated scenario into a compiled-loop :class:`~coopsat.sim.system.System`.

Design-time work happens here: degrees become radians, graphs become edge lists,
orbital elements become ECI states, and every plug-in of the scenario (controller, network
model, sensors, actuators, disturbances) builds its in-loop part and runs its design-time
checks (:mod:`coopsat.plugins`). This module never names a kind.
"""

import warnings
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from coopsat.core.errors import CoopsatWarning
from coopsat.network.graphs import graph_edges
from coopsat.network.topology import GraphError
from coopsat.plugins import BuildContext, DesignCheck, DesignError, plugin_for
from coopsat.plugins.tables import arithmetic_message, float_errors_raise
from coopsat.scenarios.load import ScenarioError
from coopsat.scenarios.schema import Scenario, whole_ratio


class DesignWarning(CoopsatWarning):
    """A run that will not do what its design promises (unstable sampling, a graph that cannot
    agree, …): issued before the simulation."""


@dataclass(frozen=True)
class Built:
    """A scenario ready to simulate.

    Attributes
    ----------
    scenario : Scenario
    system : coopsat.sim.system.System
    names : list of str
        Spacecraft names, in state order.
    graphs : list of coopsat.network.edge_list.EdgeList
        Every graph of the run, in time order (one unless the topology switches): its links,
        memory linear in them (:attr:`adjacencies` are the dense matrices).
    switch_times_s : list of float
        When each graph takes over (the first at 0).
    n_records : int
        Record intervals in the run (``n_records + 1`` samples).
    record_interval_s : float
    checks : dict of str -> coopsat.plugins.DesignCheck
        The plug-ins' design-time checks, by name.
    plugins : list of coopsat.plugins.Plugin
        The plug-ins of this run (controller, network, sensors, actuators, disturbances).
    context : coopsat.plugins.BuildContext
        What the builders saw (for design-time analysis after the run).
    warnings : list of str
        Design-time warnings (failed checks), also issued as :class:`DesignWarning`.
    """

    scenario: Scenario
    system: object
    names: list
    graphs: list
    switch_times_s: list
    n_records: int
    record_interval_s: float
    checks: dict
    plugins: list
    context: BuildContext
    warnings: list

    @cached_property
    def adjacencies(self):
        """Every graph of the run as ``A[i, j]`` (weight with which i hears j), ndarray (n, n)
        each: n² memory, made when first asked (a formation of 1e5 spacecraft has 80 GB of them)."""
        return self.context.adjacencies

    @property
    def adjacency(self):
        """``A[i, j]`` of the graph at t = 0, ndarray (n, n) (see :attr:`adjacencies`)."""
        return self.adjacencies[0]

    @property
    def named_checks(self):
        """The checks keyed by their own names (``"sampled-data"``), as results and reports show them."""
        return {c.name: c for c in self.checks.values()}

    @property
    def design_metrics(self):
        """Numbers known before the run, from every check (control period included)."""
        m = {"control_period_s": self.scenario.control_period_s}
        for check in self.checks.values():
            m.update(check.metrics)
        return m


def inertia_matrix(inertia):
    """3×3 inertia from a diagonal triple or a full matrix, kg·m²."""
    return np.diag(inertia) if np.ndim(inertia) == 1 else np.asarray(inertia, dtype=float)


def build_graph(network, names, where="network"):
    """The links of one graph of the scenario, an :class:`~coopsat.network.edge_list.EdgeList`
    (``.toarray()``: ``A[i, j]``, i hears j): the builder of its kind
    (:data:`coopsat.network.graphs.GRAPH_KINDS`).

    Parameters
    ----------
    network : coopsat.scenarios.schema.Graph
    names : sequence of str
    where : str
        The graph's place in the scenario, for error messages.

    Raises
    ------
    ScenarioError
        A graph that names an unknown spacecraft or is malformed (the graph's own message).
    """
    try:
        return graph_edges(network, names, where)
    except GraphError as err:
        raise ScenarioError(str(err)) from None


def _initial_state(place, fn, *args):
    """``fn(*args)`` of :mod:`coopsat.scenarios.initial_states` as (r, v); its one-line
    ValueError, or a floating-point failure, becomes a ScenarioError naming the field."""
    try:
        r, v = fn(*args)
    except ValueError as err:  # named by its field (initial_states)
        raise ScenarioError(f"{place}.{err}") from None
    except ArithmeticError as err:
        raise ScenarioError(f"{place}: {arithmetic_message(err, args[0])}") from None
    return np.asarray(r, dtype=float), np.asarray(v, dtype=float)


def _translational_states(spacecraft, orbit, clock):
    """Inertial (r, v) of every spacecraft, by the form its state is given in
    (:mod:`coopsat.scenarios.initial_states`); ``clock()`` the run's clock, for the forms that
    need a date."""
    from coopsat.scenarios.initial_states import absolute_state, relative_state

    if orbit is None:
        return [(np.zeros(3), np.zeros(3)) for _ in spacecraft]
    absolute = {sc.name: _initial_state(f"spacecraft[{k}]", absolute_state, sc, orbit, clock)
                for k, sc in enumerate(spacecraft) if sc.reference is None}
    return [
        absolute[sc.name] if sc.reference is None
        else _initial_state(f"spacecraft[{k}]", relative_state, sc, orbit, clock, *absolute[sc.reference])
        for k, sc in enumerate(spacecraft)
    ]


def _named_arithmetic(place, table, fn, *args):
    """``fn(*args)``; a floating-point failure in it (under :func:`build`'s raising error
    state) is a :class:`ScenarioError` naming ``place`` and the extreme numbers of ``table``."""
    try:
        return fn(*args)
    except ArithmeticError as err:
        raise ScenarioError(f"{place}: {arithmetic_message(err, table)}") from None


def scenario_tables(scenario):
    """(role, place in the file, table) of every plug-in table of the scenario."""
    acts = scenario.actuator_list
    act_places = ["actuators"] if not isinstance(scenario.actuators, list) else [f"actuators[{k}]" for k in range(len(acts))]
    return [
        ("controller", "controller", scenario.controller),
        ("network", "network.delivery", scenario.network.delivery),
        *[("sensor", f"sensors[{k}]", t) for k, t in enumerate(scenario.sensors)],
        *[("actuator", place, t) for place, t in zip(act_places, acts)],
        *[("disturbance", f"disturbances[{k}]", t) for k, t in enumerate(scenario.disturbances)],
        *[("navigation", "navigation", t) for t in [scenario.navigation] if t is not None],
    ]


def _run_check(check, table, ctx, place):
    """A plug-in's design-time check as a list of results (it may return None, one or several).

    A check whose numerics fail on extreme (but valid) input — an overflow, a singular or
    non-finite matrix — becomes a failed check that says so, not a crash: the run is then
    not known to do what its design promises.
    """
    try:
        results = check(table, ctx)
    except DesignError:
        raise
    except (ArithmeticError, np.linalg.LinAlgError, FloatingPointError, ValueError) as err:
        name = check.__name__.removeprefix("check_").replace("_", "-")
        return [DesignCheck(name, False, f"{place}: the {name} check could not be computed ({err})")]
    if results is None:
        return []
    return [results] if isinstance(results, DesignCheck) else list(results)


def state_quantities_of(scenario, actuators):
    """The quantities of a run's moving state (``q`` or ``angle``, ``omega``, and ``h_wheels``,
    ``r_eci``, ``v_eci`` where they move), as a set."""
    from coopsat.dynamics.plant import state_quantities

    gravity = "none" if scenario.orbit is None else scenario.orbit.gravity
    return set(state_quantities(scenario.sim.attitude, gravity, (a.channel for a in actuators)))


def _check_sensed_quantities(scenario, sensors, actuators):
    """Every sensor's truth comes from quantities the run's models have (``needs``)."""
    have = state_quantities_of(scenario, actuators)
    for k, s in enumerate(sensors):
        if not set(s.needs) <= have:
            raise ScenarioError(
                f"sensors[{k}]: measures '{s.quantity}', which this run does not have "
                f"(sim.attitude = {scenario.sim.attitude!r}; quantities: {', '.join(sorted(have))})"
            )


def _check_command(controller, actuator, place):
    """An actuator executes a command its controller issues (a controller that commands
    nothing leaves its actuators at rest)."""
    issued = getattr(controller, "commands", ())
    if issued and actuator.command not in issued:
        raise ScenarioError(
            f"{place}: executes the command '{actuator.command}' but the controller issues {', '.join(issued)}"
        )


def build(scenario):
    """Build the :class:`Built` run of a validated scenario (design-time checks included).

    Raises
    ------
    ScenarioError
        On a graph that references unknown spacecraft, a plug-in that cannot be built as
        configured (the plug-in's own message), or another inconsistency that needs more than one
        table to see.
    """
    from coopsat.core import runtime

    runtime.enable()  # float64 before any design-time JAX array (coopsat.core.runtime: the documented change)
    # Overflow, invalid values and division by zero raise (one line naming the place where it is
    # known, the scenario otherwise) rather than print a RuntimeWarning and compute on.
    with float_errors_raise():
        ctx, switch_times, rv = _named_arithmetic("scenario", scenario, _context, scenario)
        parts, used, checks = _build_parts(scenario, ctx)
        system = _named_arithmetic("scenario", scenario, _system, scenario, ctx, rv, parts)
    notes = [c.note for c in checks.values() if not c.ok]
    for note in notes:
        warnings.warn(note, DesignWarning, stacklevel=2)
    return Built(
        scenario=scenario,
        system=system,
        names=ctx.names,
        graphs=ctx.graphs,
        switch_times_s=switch_times,
        n_records=whole_ratio(scenario.sim.t_final_s, scenario.record_interval_s),
        record_interval_s=scenario.record_interval_s,
        checks=checks,
        plugins=used,
        context=ctx,
        warnings=notes,
    )


def _context(scenario):
    """What every plug-in's builder sees (:class:`~coopsat.plugins.BuildContext`): names,
    inertias, periods, the graphs and when they switch, the initial ECI states; the switch
    times, s (the first graph's at 0); and every spacecraft's ECI (r, v)."""
    names = [sc.name for sc in scenario.spacecraft]
    inertia = np.stack([inertia_matrix(sc.inertia_kgm2) for sc in scenario.spacecraft])
    from coopsat.plugins.earth_environment import run_clock, run_epoch_of

    try:
        if scenario.orbit is not None:
            run_epoch_of(scenario.orbit)  # an epoch that cannot be placed on TT fails here, not after the run
        rv = _translational_states(scenario.spacecraft, scenario.orbit, lambda: run_clock(scenario.orbit, scenario.sim.t_final_s))
    except DesignError as err:
        raise ScenarioError(str(err)) from None
    places = ["network"] + [f"network.switches[{k}]" for k in range(len(scenario.network.switches))]
    graphs = [scenario.network, *scenario.network.switches]
    graphs = [build_graph(g, names, where) for g, where in zip(graphs, places)]
    switch_times = [0.0] + [sw.t_s for sw in scenario.network.switches]
    dt = scenario.sim.dt_s
    ctx = BuildContext(
        scenario=scenario, names=names, inertia_kgm2=inertia, dt_s=dt, period_s=scenario.control_period_s,
        graphs=graphs, graph_places=places,
        switch_ticks=np.array([round(t / dt) for t in switch_times], dtype=np.int64),
        r_eci_m=np.array([r for r, _ in rv], dtype=float), v_eci_m_s=np.array([v for _, v in rv], dtype=float),
    )
    return ctx, switch_times, rv


def _build_parts(scenario, ctx):
    """Every plug-in's in-loop part, by role, in the order of :func:`scenario_tables`, the
    plug-ins themselves, and their design-time checks by name."""
    parts = {"controller": [], "network": [], "sensor": [], "actuator": [], "disturbance": [], "navigation": []}
    used, checks = [], {}
    for role, place, table in scenario_tables(scenario):
        plugin = plugin_for(role, table)
        try:
            parts[role].append(_named_arithmetic(place, table, plugin.build, table, ctx))
            if role == "actuator":  # the controller is built first
                _check_command(parts["controller"][0], parts[role][-1], place)
            for check in plugin.checks:
                for result in _run_check(check, table, ctx, place):
                    checks[result.name] = result
        except DesignError as err:
            raise ScenarioError(str(err)) from None
        used.append(plugin)
    _check_sensed_quantities(scenario, parts["sensor"], parts["actuator"])
    if parts["navigation"]:
        parts["controller"] = [_navigated(parts["navigation"][0], parts["controller"][0], scenario.controller.kind)]
    return parts, used, checks


def _navigated(navigation, law, kind):
    """The flight software that flies ``law`` on ``navigation``'s estimate
    (:mod:`coopsat.control.navigated`)."""
    from coopsat.control.navigated import Navigated

    provides = ", ".join(navigation.provides)
    if not all(hasattr(law, a) for a in ("reads", "outbox_one", "step_one")) or not set(navigation.provides) & set(law.reads):
        raise ScenarioError(
            f"navigation: controller kind '{kind}' does not read {provides} in a per-spacecraft form, so it cannot fly on "
            f"the filter's estimate"
        )
    why = navigation.check_law(law, kind)
    if why:
        raise ScenarioError(f"navigation: {why}")
    return Navigated(navigation, law)


def _system(scenario, ctx, rv, parts):
    """The compiled loop's :class:`~coopsat.sim.system.System`: structure, initial state (``rv``:
    ECI (r, v) of every spacecraft), plant parameters and the plug-ins' parts."""
    import jax

    from coopsat.dynamics.plant import PlantState
    from coopsat.sim.system import Structure, System, as_arrays

    orbit, period, dt = scenario.orbit, scenario.control_period_s, scenario.sim.dt_s
    structure = Structure(
        n_spacecraft=len(ctx.names),
        gravity="none" if orbit is None else orbit.gravity,
        attitude=scenario.sim.attitude,
        ticks_per_period=whole_ratio(period, dt),
        periods_per_record=whole_ratio(scenario.record_interval_s, period),
        substeps=scenario.sim.substeps,
    )
    q0 = np.array([sc.q_bi for sc in scenario.spacecraft], dtype=float)
    q0 /= np.linalg.norm(q0, axis=1, keepdims=True)
    x0 = PlantState(
        q_bi=q0,
        omega_b=np.array([sc.omega_b_rad_s for sc in scenario.spacecraft], dtype=float),
        h_wheels_b=np.array([sc.h_wheels_b_nms for sc in scenario.spacecraft], dtype=float),
        r_eci=np.array([r for r, _ in rv], dtype=float),
        v_eci=np.array([v for _, v in rv], dtype=float),
        angle_rad=np.array([sc.angle_rad for sc in scenario.spacecraft], dtype=float),
    )
    return System(
        structure,
        *as_arrays((dt, jax.random.PRNGKey(scenario.seed), x0, _plant(scenario, ctx.inertia_kgm2))),
        controller=parts["controller"][0],
        network=parts["network"][0],
        sensors=tuple(parts["sensor"]),
        actuators=tuple(parts["actuator"]),
        disturbances=tuple(parts["disturbance"]),
    )


def _plant(scenario, inertia):
    """The plant's parameters: inertias (diagonal when every spacecraft's are), gravity, masses."""
    from coopsat.dynamics.plant import PlantParams

    orbit = scenario.orbit
    if not np.any(inertia[:, ~np.eye(3, dtype=bool)]):
        # Principal axes = body axes for every spacecraft: the loop takes the cheaper diagonal path.
        inertia_in, inertia_inv = np.diagonal(inertia, axis1=1, axis2=2), 1.0 / np.diagonal(inertia, axis1=1, axis2=2)
    else:
        inertia_in, inertia_inv = inertia, np.linalg.inv(inertia)
    return PlantParams(
        inertia_kgm2=inertia_in,
        inertia_inv=inertia_inv,
        mu_m3_s2=0.0 if orbit is None else orbit.mu_m3_s2,
        j2=0.0 if orbit is None else orbit.j2,
        r_body_m=1.0 if orbit is None else orbit.r_body_m,
        mass_kg=np.array([np.nan if sc.mass_kg is None else sc.mass_kg for sc in scenario.spacecraft]),
        chief=0,
    )
