"""Figures of the deep-space formation runs (SPEC §4): planar trajectories (paper Fig. 4),
fuel against time (Fig. 5), formation error, and the fuel–settling-time trade-off.

Pure functions from datasets or tables to :class:`matplotlib.figure.Figure` (object-oriented
API, no pyplot).
"""

import numpy as np
from matplotlib.figure import Figure

from coopsat.analysis.papers.deep_space_2008 import formation_error_m


def _design(built):
    from coopsat.plugins.formation import PLANES

    table = built.scenario.controller
    target = np.asarray(table.target_m, dtype=float)
    # target_m has any origin: the slots about their centroid, as the paths are drawn
    return PLANES[table.plane], target - target.mean(axis=0)


def trajectory_figure(ds, built):
    """Each spacecraft's path in the design plane relative to where the initial centroid would
    be with no thrust (the centroid's own orbit: c(t) − Δc(t), Δc the drift the thrust caused,
    :func:`~coopsat.analysis.papers.deep_space_2008.centroid_drift_m`), as in Fig. 4:
    × start, ○ end, + target, □ the centroid at the end."""
    from coopsat.analysis.papers.deep_space_2008 import centroid_drift_m

    axes, target = _design(built)
    r = ds["r_eci"].values
    drift = centroid_drift_m(ds["time"].values, ds["force_impulse"].values, float(built.scenario.spacecraft[0].mass_kg))
    natural = r.mean(axis=1) - drift  # (T, 3)
    rel = r - natural[:, None, :]
    fig = Figure(figsize=(6.4, 6.0), layout="constrained")
    ax = fig.add_subplot()
    i, j = axes[0], axes[1]
    for k, name in enumerate(str(s) for s in ds["spacecraft"].values):
        line, = ax.plot(rel[:, k, i], rel[:, k, j], label=name)
        ax.plot(rel[0, k, i], rel[0, k, j], "x", color=line.get_color())
        ax.plot(rel[-1, k, i], rel[-1, k, j], "o", mfc="none", color=line.get_color())
        ax.plot(target[k, 0], target[k, 1], "+", ms=12, color=line.get_color())
    ax.plot(0.0, 0.0, "+", color="k")
    ax.plot(drift[-1, i], drift[-1, j], "s", mfc="none", color="k", label="centroid at the end")
    ax.set_xlabel(f"{'xyz'[i]} (m, inertial, Sun along −x)")
    ax.set_ylabel(f"{'xyz'[j]} (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(fontsize="small")
    ax.set_title(f"{ds.attrs.get('scenario_name', '')}: trajectories (× start, ○ end, + target)")
    return fig


def fuel_figure(ds, built):
    """Fuel ``Σ_i ∫|u_i| dt`` against time (Fig. 5): per axis, the L1 total and the 2-norm."""
    t = ds["time"].values
    fig = Figure(figsize=(7.0, 4.2), layout="constrained")
    ax = fig.add_subplot()
    per_axis = ds["abs_force_impulse"].values.sum(axis=1)  # (T, 3)
    for c in range(3):
        if np.any(per_axis[:, c] > 0):
            ax.plot(t, per_axis[:, c], label=f"Σ∫|u_{'xyz'[c]}| dt")
    ax.plot(t, per_axis.sum(axis=1), "k", lw=2, label="L1 total")
    if "norm_force_impulse" in ds:
        ax.plot(t, ds["norm_force_impulse"].values.sum(axis=1), "k--", label="Σ∫‖u‖₂ dt")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("fuel (N s)")
    ax.legend(fontsize="small")
    ax.set_title(f"{ds.attrs.get('scenario_name', '')}: fuel")
    return fig


def error_figure(ds, built):
    """Formation error (translation removed) against time, log scale, with the tolerance."""
    axes, target = _design(built)
    t = ds["time"].values
    err = formation_error_m(ds["r_eci"].values, target, axes)
    fig = Figure(figsize=(7.0, 4.0), layout="constrained")
    ax = fig.add_subplot()
    ax.semilogy(t, np.maximum(err, 1e-6))
    tol = built.scenario.analysis.formation_tolerance_m
    ax.axhline(tol, color="k", ls=":", label=f"tolerance {tol:g} m")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("largest slot error (m)")
    ax.legend(fontsize="small")
    ax.set_title(f"{ds.attrs.get('scenario_name', '')}: formation error")
    return fig


def figures(ds, built):
    """The paper's figures of one run, keyed by file stem."""
    return {"trajectories": trajectory_figure(ds, built), "fuel": fuel_figure(ds, built), "formation_error": error_figure(ds, built)}


def tradeoff_figure(rows, comparisons, fuel="fuel_l1_ns", bound=None):
    """Fuel against settling time of every series, each with its Pareto front (line), the
    matched settling times of the comparison (vertical ticks) and, when given, a lower bound
    ``bound = (settle_s, fuel_ns)`` (dotted)."""
    from coopsat.analysis.tradeoff import pareto_front

    fig = Figure(figsize=(7.5, 5.0), layout="constrained")
    ax = fig.add_subplot()
    markers = {"lmi": "o", "lqr": "s", "tuned": "^"}
    styles = {"hub": "-", "orthonormal": "--"}
    for key in dict.fromkeys((r["design"], r["coordinates"], r["scenario"]) for r in rows):
        series = [r for r in rows if (r["design"], r["coordinates"], r["scenario"]) == key]
        s = np.array([np.nan if r["settling_time_s"] is None else r["settling_time_s"] for r in series], dtype=float)
        f = np.array([r.get(fuel, np.nan) for r in series], dtype=float)
        pts = ax.plot(s, f, markers[key[0]], mfc="none", label=f"{key[0].upper()} {key[1]} ({key[2]})")[0]
        front = pareto_front(s, f)
        ax.plot(s[front], f[front], styles[key[1]], color=pts.get_color())
    for c in comparisons:
        for t in c["settle_s"]:
            ax.axvline(t, color="0.85", lw=0.8, zorder=0)
    if bound is not None:
        ax.plot(bound[0], bound[1], ":", color="k", label="rest-to-rest bound (bang-coast-bang)")
    ax.set_xlabel("settling time (s)")
    ax.set_ylabel(f"fuel {'Σ∫|u| dt (L1)' if fuel == 'fuel_l1_ns' else fuel} (N s)")
    ax.legend(fontsize="small")
    ax.set_title("fuel against settling time; lines: each series' Pareto front")
    return fig


def fuel_time_figure(series):
    """Fuel against time of several runs on one figure (Fig. 5 for both designs): per run the
    L1 total (solid) and the 2-norm reading (dashed), and per axis (thin).

    Parameters
    ----------
    series : list of (row, history)
        ``row`` as in :func:`coopsat.workflows.deep_space_tradeoff.sweep` (design, coordinates, force scale);
        ``history`` with ``t_s``, ``fuel_l1_ns`` (T, 3) and ``fuel_l2_ns`` (T,) or None.
    """
    fig = Figure(figsize=(7.5, 4.8), layout="constrained")
    ax = fig.add_subplot()
    for row, h in series:
        label = f"{row['design'].upper()} {row['coordinates']} ({row['force_scale_n']:g} N)"
        line = ax.plot(h["t_s"], h["fuel_l1_ns"].sum(axis=1), lw=2, label=f"{label}: L1")[0]
        for c in range(3):
            if np.any(h["fuel_l1_ns"][:, c] > 0):
                ax.plot(h["t_s"], h["fuel_l1_ns"][:, c], lw=0.7, color=line.get_color())
        if h["fuel_l2_ns"] is not None:
            ax.plot(h["t_s"], h["fuel_l2_ns"], "--", color=line.get_color(), label=f"{label}: 2-norm")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("fuel Σ∫|u| dt (N s); thin: per axis")
    ax.legend(fontsize="x-small")
    ax.set_title("fuel against time")
    return fig
