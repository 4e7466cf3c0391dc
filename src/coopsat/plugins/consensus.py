"""Consensus attitude laws (3) and (4) of the 2010 paper (SPEC §1) as controller plug-ins.

Design-time checks: a graph without a spanning tree cannot synchronise under law (3); and the
sampled-data loop (the law held over a control period) is linearised about consensus and its
one-period map's spectral radius reported (:mod:`coopsat.design.sampled_data`). The paper's
metrics and explanations live in :mod:`coopsat.analysis.papers.consensus_2010`.
"""

import dataclasses
from typing import Literal

import numpy as np
from pydantic import Field

from coopsat.plugins import DesignCheck, DesignError, Plugin, Tunable, register
from coopsat.plugins.tables import MAX_GAIN, MAX_RATE_RAD_S, Bounded3, Quat, Table

MAX_CHECKED_SPACECRAFT = 60
"""Largest formation whose sampled-data loop is checked before a run (dense 6n-state model)."""

ANALYSIS = "coopsat.analysis.papers.consensus_2010"


class ConsensusSync(Table):
    """``kind = "consensus-sync"``: law (3) of the 2010 consensus paper."""

    kind: Literal["consensus-sync"]
    period_s: float = Field(gt=0, le=1e5, description="Control period (zero-order hold; PWM period), s.")
    alpha: float = Field(gt=0, le=MAX_GAIN, description="Attitude consensus gain α, N·m.")
    beta: float = Field(gt=0, le=MAX_GAIN, description="Rate consensus gain β, N·m·s/rad.")
    short_way: bool = Field(False, description="Error quaternions on the q0 >= 0 hemisphere (paper: false).")


class ConsensusTrack(ConsensusSync):
    """``kind = "consensus-track"``: law (4), law (3) plus tracking of a reference."""

    kind: Literal["consensus-track"]
    k_p: float = Field(gt=0, le=MAX_GAIN, description="Reference attitude gain K, N·m.")
    k_d: float = Field(gt=0, le=MAX_GAIN, description="Reference rate gain D, N·m·s/rad.")
    omega_ref_rad_s: Bounded3(MAX_RATE_RAD_S, "rad/s") = Field(description="Constant reference body rate ω_r, rad/s.")
    q_ref0: Quat = Field([1.0, 0.0, 0.0, 0.0], description="Reference attitude at t = 0, scalar first.")


def _build(table, ctx):
    from coopsat.control.consensus import ConsensusLaw
    from coopsat.sim.system import as_arrays

    if ctx.scenario.sim.attitude != "rigid-body":
        raise DesignError(f"controller: {table.kind} acts on quaternions; it needs sim.attitude = \"rigid-body\"")
    track = table.kind == "consensus-track"
    q_ref0 = np.asarray(table.q_ref0 if track else [1.0, 0.0, 0.0, 0.0], dtype=float)
    return ConsensusLaw(
        *as_arrays((
            table.alpha, table.beta, table.k_p if track else 0.0, table.k_d if track else 0.0,
            q_ref0 / np.linalg.norm(q_ref0), np.asarray(table.omega_ref_rad_s if track else np.zeros(3), dtype=float),
        )),
        track=track,
        short_way=table.short_way,
    )


def check_spanning_tree(table, ctx):
    """Law (3) needs a spanning tree in every graph; tracking laws converge on any graph.

    Raises :class:`DesignError` when ``network.require_spanning_tree`` (the default), else
    returns a failed check to warn with.
    """
    from coopsat.network import topology

    if table.kind == "consensus-track" or ctx.n == 1:
        return None
    problems = []
    for where, graph in zip(ctx.graph_places, ctx.graphs):  # linear in the links: every formation's size
        if topology.spanning_tree_roots(graph):
            continue
        groups = topology.describe_components(graph, ctx.names)
        msg = f"{where}: the graph has no spanning tree, so law (3) cannot bring every spacecraft to consensus ({groups})"
        if ctx.scenario.network.require_spanning_tree:
            raise DesignError(msg + "; set network.require_spanning_tree = false to run it anyway")
        problems.append(msg)
    return DesignCheck("spanning-tree", False, "; ".join(problems)) if problems else None


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


def _saturates(scenario):
    """Every actuator of the run saturates (its torque is bounded)."""
    acts = scenario.actuator_list
    return bool(acts) and all(np.all(np.isfinite(getattr(a, "torque_max_nm", np.inf))) for a in acts)


def check_sampled_data(table, ctx):
    """Sampled-data check of the consensus law on each graph; the worst one is reported
    (with, for tracking, a warning when the reference rate is off a principal axis).

    With a switching topology the result carries the largest spectral radius over the graphs
    and the smallest of their stable periods (each graph's loop stable is necessary, not
    sufficient, for the switched loop).
    """
    from coopsat.design.sampled_data import analyze_sampled_data
    from coopsat.network import topology

    track = table.kind == "consensus-track"
    inertia = ctx.inertia_kgm2
    if ctx.n == 1 and not track:
        return None  # nothing to agree on for one spacecraft without a reference
    if ctx.n > MAX_CHECKED_SPACECRAFT:
        return DesignCheck(
            "sampled-data", True,
            f"sampled-data check skipped: {ctx.n} spacecraft is more than {MAX_CHECKED_SPACECRAFT} (its cost grows as n³)",
        )
    checks = []
    adjacencies = ctx.adjacencies
    if track:
        w_r = np.asarray(table.omega_ref_rad_s)
        off = [
            name for name, i in zip(ctx.names, inertia)
            if np.linalg.norm(np.cross(w_r, i @ w_r)) > 1e-12 * (1 + np.linalg.norm(i @ w_r))
        ]
        if off:
            checks.append(DesignCheck(
                "reference-axis", False,
                f"controller.omega_ref_rad_s is not along a principal axis of {', '.join(off)}: steady rotation at the "
                "reference rate needs a torque there, and the sampled-data check linearises about it regardless",
            ))
        gains = (table.k_p, table.k_d, table.omega_ref_rad_s)
    else:
        # Without a spanning tree there is no agreement to be stable about (the graph check says so).
        adjacencies = [a for a in adjacencies if topology.spanning_tree_roots(a)]
        gains = ()
    results = [analyze_sampled_data(inertia, a, table.period_s, table.alpha, table.beta, *gains) for a in adjacencies]
    if not results:
        return checks
    worst = max(results, key=lambda r: r.spectral_radius)
    worst = dataclasses.replace(worst, max_stable_period_s=min(r.max_stable_period_s for r in results))
    note = stability_message(worst, ctx.names, saturates=_saturates(ctx.scenario))
    metrics = {
        "spectral_radius": worst.spectral_radius,
        "max_stable_period_s": worst.max_stable_period_s,
        "continuous_max_real_1_s": worst.continuous_max_real,
    }
    return [*checks, DesignCheck("sampled-data", worst.stable, note, metrics, worst)]


def tunables(table, ctx, part):
    """α and β (and K, D for tracking) enter the law as they are."""
    from dataclasses import replace

    names = ("alpha", "beta", "k_p", "k_d") if table.kind == "consensus-track" else ("alpha", "beta")
    return {
        name: Tunable(float(getattr(table, name)), lambda p, v, name=name: replace(p, **{name: v}), lambda v, name=name: {name: float(v)})
        for name in names
    }


class SpinDownThreshold(Table):
    """``[analysis]`` threshold of the consensus paper's spin-down metric (SPEC §1)."""

    spin_rate_rad_s: float = Field(
        0.1, gt=0, le=MAX_RATE_RAD_S,
        description="Spin-down: the excess rate along the initial spin axis counts as removed below this, rad/s.",
    )


for _kind, _table in (("consensus-sync", ConsensusSync), ("consensus-track", ConsensusTrack)):
    register(Plugin("controller", _kind, _table, _build, (check_spanning_tree, check_sampled_data), ANALYSIS, tunables,
                    thresholds=SpinDownThreshold))
