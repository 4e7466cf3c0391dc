"""Turn a validated scenario into a compiled-loop :class:`~coopsat.sim.system.System`.

Design-time work happens here: degrees become radians, the graph becomes edge arrays and is
checked for a spanning tree, orbital elements become ECI states, and the sampled-data loop of
a consensus law is linearised and its stability reported (:mod:`coopsat.design.sampled_data`).
"""

import dataclasses
import math
import warnings
from dataclasses import dataclass

import numpy as np

from coopsat.astro.kepler import elements_to_rv
from coopsat.design.sampled_data import SampledDataStability, analyze_sampled_data
from coopsat.network import topology
from coopsat.scenarios.load import ScenarioError
from coopsat.scenarios.schema import ConsensusSync, ConsensusTrack, PwmThrusters, Scenario, whole_ratio


MAX_CHECKED_SPACECRAFT = 60
"""Largest formation whose sampled-data loop is checked before a run (dense 6n-state model)."""


class ConsensusWarning(UserWarning):
    """A consensus run that will not do what the law promises (unstable sampling, bad graph)."""


@dataclass(frozen=True)
class Built:
    """A scenario ready to simulate.

    Attributes
    ----------
    scenario : Scenario
    system : coopsat.sim.system.System
    names : list of str
        Spacecraft names, in state order.
    adjacency : ndarray (n, n)
        ``A[i, j]`` = weight with which i hears j, of the graph at t = 0.
    adjacencies : list of ndarray (n, n)
        Every graph of the run, in time order (one unless the topology switches).
    switch_times_s : list of float
        When each graph takes over (the first at 0).
    n_records : int
        Record intervals in the run (``n_records + 1`` samples).
    record_interval_s : float
    stability : SampledDataStability or None
        Sampled-data check of a consensus law; None without one.
    stability_note : str or None
        The check in one line (also a warning when the loop is unstable).
    warnings : list of str
        Design-time warnings, also issued as :class:`ConsensusWarning`.
    """

    scenario: Scenario
    system: object
    names: list
    adjacency: np.ndarray
    adjacencies: list
    switch_times_s: list
    n_records: int
    record_interval_s: float
    stability: SampledDataStability | None
    stability_note: str | None
    warnings: list


def inertia_matrix(inertia):
    """3×3 inertia from a diagonal triple or a full matrix, kg·m²."""
    return np.diag(inertia) if np.ndim(inertia) == 1 else np.asarray(inertia, dtype=float)


def build_adjacency(network, names, where="network"):
    """Adjacency ``A[i, j]`` (i hears j) of one graph of the scenario, shape (n, n).

    Parameters
    ----------
    network : coopsat.scenarios.schema.Graph
    names : sequence of str
    where : str
        The graph's place in the scenario, for error messages.
    """
    n = len(names)
    index = {name: k for k, name in enumerate(names)}
    kind = network.kind
    if kind == "none":
        return np.zeros((n, n))
    if kind == "edges":
        triples = []
        for k, (src, dst, w) in enumerate(network.edges):
            for end in (src, dst):
                if end not in index:
                    raise ScenarioError(f"{where}.edges[{k}]: unknown spacecraft '{end}' (known: {', '.join(names)})")
            triples.append((index[src], index[dst], w))
        try:
            return topology.adjacency_from_edges(n, triples, network.directed)
        except topology.GraphError as err:
            raise ScenarioError(str(err).replace("network", where, 1)) from None
    if kind == "adjacency":
        try:
            a = topology.validate_adjacency(network.adjacency)
        except topology.GraphError as err:
            raise ScenarioError(str(err).replace("network", where, 1)) from None
        if a.shape[0] != n:
            raise ScenarioError(f"{where}.adjacency: is {a.shape[0]}×{a.shape[0]} but there are {n} spacecraft")
        return a
    if kind == "star":
        hub = network.hub or names[0]
        if hub not in index:
            raise ScenarioError(f"{where}.hub: unknown spacecraft '{hub}' (known: {', '.join(names)})")
        return network.weight * topology.star_adjacency(n, network.directed, hub=index[hub])
    return network.weight * topology.NAMED_GRAPHS[kind](n, directed=network.directed)


def _translational_state(sc, orbit):
    if orbit is None:
        return np.zeros(3), np.zeros(3)
    if sc.elements is not None:
        el = sc.elements
        return elements_to_rv(
            el.a_m, el.e, math.radians(el.i_deg), math.radians(el.raan_deg), math.radians(el.argp_deg),
            math.radians(el.mean_anomaly_deg), orbit.mu_m3_s2,
        )
    return np.asarray(sc.r_eci_m, dtype=float), np.asarray(sc.v_eci_m_s, dtype=float)


def _check_graphs(scenario, graphs, names, notes):
    """A consensus law needs a spanning tree in every graph; tracking laws converge on any graph."""
    ctrl = scenario.controller
    if not isinstance(ctrl, ConsensusSync) or isinstance(ctrl, ConsensusTrack) or len(names) == 1:
        return
    for where, adjacency in graphs:
        if topology.spanning_tree_roots(adjacency):
            continue
        groups = topology.describe_components(adjacency, names)
        msg = f"{where}: the graph has no spanning tree, so law (3) cannot bring every spacecraft to consensus ({groups})"
        if scenario.network.require_spanning_tree:
            raise ScenarioError(msg + "; set network.require_spanning_tree = false to run it anyway")
        notes.append(msg)


def _stability(scenario, inertia, adjacencies, notes):
    """Sampled-data check of the consensus law on each graph; the worst one is returned.

    With a switching topology the result carries the largest spectral radius over the graphs
    and the smallest of their stable periods (each graph's loop stable is necessary, not
    sufficient, for the switched loop).
    """
    ctrl = scenario.controller
    if not isinstance(ctrl, ConsensusSync) or len(inertia) == 1 and not isinstance(ctrl, ConsensusTrack):
        return None  # nothing to agree on for one spacecraft without a reference
    if len(inertia) > MAX_CHECKED_SPACECRAFT:
        notes.append(
            f"sampled-data check skipped: {len(inertia)} spacecraft is more than {MAX_CHECKED_SPACECRAFT} "
            "(its cost grows as n³)"
        )
        return None
    if isinstance(ctrl, ConsensusTrack):
        w_r = np.asarray(ctrl.omega_ref_rad_s)
        off = [s.name for s, i in zip(scenario.spacecraft, inertia) if np.linalg.norm(np.cross(w_r, i @ w_r)) > 1e-12 * (1 + np.linalg.norm(i @ w_r))]
        if off:
            notes.append(
                f"controller.omega_ref_rad_s is not along a principal axis of {', '.join(off)}: steady rotation at the "
                "reference rate needs a torque there, and the sampled-data check linearises about it regardless"
            )
        gains = (ctrl.k_p, ctrl.k_d, ctrl.omega_ref_rad_s)
    else:
        # Without a spanning tree there is no agreement to be stable about (the graph check says so).
        adjacencies = [a for a in adjacencies if topology.spanning_tree_roots(a)]
        gains = ()
    results = [analyze_sampled_data(inertia, a, ctrl.period_s, ctrl.alpha, ctrl.beta, *gains) for a in adjacencies]
    if not results:
        return None
    worst = max(results, key=lambda r: r.spectral_radius)
    return dataclasses.replace(worst, max_stable_period_s=min(r.max_stable_period_s for r in results))


def stability_message(st, names, saturates=True):
    """One line on the sampled-data check, naming the spacecraft and axis that limit it.

    Parameters
    ----------
    st : SampledDataStability
    names : sequence of str
    saturates : bool
        The actuator saturates (then an unstable loop settles into a limit cycle; without
        saturation it diverges).
    """
    sc, axis = st.dominant
    where = f"{names[sc]} {'xyz'[axis]} axis"
    if st.stable:
        return (
            f"sampled-data loop stable at T = {st.period_s:g} s: spectral radius {st.spectral_radius:.4f} "
            f"(largest stable period {st.max_stable_period_s:.4g} s, slowest mode on {where})"
        )
    return (
        f"sampled-data loop UNSTABLE at T = {st.period_s:g} s: one-period map has spectral radius "
        f"{st.spectral_radius:.3g} > 1 (largest stable period {st.max_stable_period_s:.4g} s; the unstable mode "
        f"lives on {where}); "
        + ("expect a limit cycle bounded only by actuator saturation" if saturates else "expect divergence (no saturation)")
    )


def build(scenario):
    """Build the :class:`Built` run of a validated scenario (design-time checks included).

    Raises
    ------
    ScenarioError
        On a graph that references unknown spacecraft, has no spanning tree for a consensus
        law, or another inconsistency that needs more than one field to see.
    """
    from coopsat.dynamics.plant import PlantParams, PlantState
    from coopsat.sim.system import Structure, System, as_arrays

    names = [sc.name for sc in scenario.spacecraft]
    n = len(names)
    inertia = np.stack([inertia_matrix(sc.inertia_kgm2) for sc in scenario.spacecraft])
    q0 = np.array([sc.q_bi for sc in scenario.spacecraft], dtype=float)
    q0 /= np.linalg.norm(q0, axis=1, keepdims=True)
    rv = [_translational_state(sc, scenario.orbit) for sc in scenario.spacecraft]
    graphs = [("network", build_adjacency(scenario.network, names))] + [
        (f"network.switches[{k}]", build_adjacency(sw, names, f"network.switches[{k}]"))
        for k, sw in enumerate(scenario.network.switches)
    ]
    adjacencies = [a for _, a in graphs]
    notes = []
    _check_graphs(scenario, graphs, names, notes)
    links = topology.links_for_schedule(adjacencies)
    switch_times = [0.0] + [sw.t_s for sw in scenario.network.switches]

    ctrl, act = scenario.controller, scenario.actuators
    period = scenario.control_period_s
    dt = scenario.sim.dt_s
    if isinstance(ctrl, ConsensusSync):
        ctrl_params = {"alpha": ctrl.alpha, "beta": ctrl.beta}
        if isinstance(ctrl, ConsensusTrack):
            q_ref0 = np.asarray(ctrl.q_ref0, dtype=float)
            ctrl_params.update(
                k_p=ctrl.k_p, k_d=ctrl.k_d, omega_ref_b=np.asarray(ctrl.omega_ref_rad_s, dtype=float),
                q_ref0=q_ref0 / np.linalg.norm(q_ref0),
            )
    else:
        ctrl_params = {}
    act_params = {"torque_max_nm": act.torque_max_nm}
    if isinstance(act, PwmThrusters):
        act_params["min_pulse_s"] = act.min_pulse_s

    orbit = scenario.orbit
    structure = Structure(
        n_spacecraft=n,
        gravity="none" if orbit is None else orbit.gravity,
        controller=ctrl.kind,
        actuator=act.kind,
        short_way=bool(getattr(ctrl, "short_way", False)),
        ticks_per_period=whole_ratio(period, dt),
        periods_per_record=whole_ratio(scenario.record_interval_s, period),
        substeps=scenario.sim.substeps,
    )
    x0 = PlantState(
        q_bi=q0,
        omega_b=np.array([sc.omega_b_rad_s for sc in scenario.spacecraft], dtype=float),
        h_wheels_b=np.array([sc.h_wheels_b_nms for sc in scenario.spacecraft], dtype=float),
        r_eci=np.array([r for r, _ in rv], dtype=float),
        v_eci=np.array([v for _, v in rv], dtype=float),
    )
    if all(np.count_nonzero(m - np.diag(np.diag(m))) == 0 for m in inertia):
        # Principal axes = body axes for every spacecraft: the loop takes the cheaper diagonal path.
        inertia_in, inertia_inv = np.diagonal(inertia, axis1=1, axis2=2), 1.0 / np.diagonal(inertia, axis1=1, axis2=2)
    else:
        inertia_in, inertia_inv = inertia, np.linalg.inv(inertia)
    plant = PlantParams(
        inertia_kgm2=inertia_in,
        inertia_inv=inertia_inv,
        mu_m3_s2=0.0 if orbit is None else orbit.mu_m3_s2,
        j2=0.0 if orbit is None else orbit.j2,
        r_body_m=1.0 if orbit is None else orbit.r_body_m,
    )
    system = System(
        structure,
        *as_arrays(
            (
                dt, x0, plant, links.src, links.dst, links.weight,
                np.array([round(t / dt) for t in switch_times], dtype=np.int64), ctrl_params, act_params,
            )
        ),
    )
    stability = _stability(scenario, inertia, adjacencies, notes)
    stability_note = None
    if stability is not None:
        stability_note = stability_message(stability, names, saturates=bool(np.isfinite(act.torque_max_nm)))
        if not stability.stable:
            notes.append(stability_note)
    for note in notes:
        warnings.warn(note, ConsensusWarning, stacklevel=2)
    return Built(
        scenario=scenario,
        system=system,
        names=names,
        adjacency=adjacencies[0],
        adjacencies=adjacencies,
        switch_times_s=switch_times,
        n_records=whole_ratio(scenario.sim.t_final_s, scenario.record_interval_s),
        record_interval_s=scenario.record_interval_s,
        stability=stability,
        stability_note=stability_note,
        warnings=notes,
    )
