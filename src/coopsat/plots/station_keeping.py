"""Figures of formation keeping in orbit: truth slot errors per LVLH axis, and fuel as Δv.

Pure functions from a run's dataset to :class:`matplotlib.figure.Figure` (object-oriented API,
no pyplot). Many spacecraft are drawn as thin lines without a legend.
"""

import numpy as np
from matplotlib.figure import Figure

from coopsat.analysis.papers.station_keeping import series
from coopsat.plots.low_orbit import lines_by_spacecraft

_AXES = ("along-track x", "cross-track y", "radial z (nadir)")


def slot_error_figure(ds, built):
    """True position minus the slot, relative to the first spacecraft, per LVLH axis (m)."""
    err = ds["slot_error_lvlh"].values if "slot_error_lvlh" in ds else series(ds, built)["slot_error_lvlh"].values
    t_s = ds["time"].values
    names = [str(s) for s in ds["spacecraft"].values][1:]
    fig = Figure(figsize=(7.5, 7.0), layout="constrained")
    for c, label in enumerate(_AXES):
        ax = fig.add_subplot(3, 1, c + 1)
        lines_by_spacecraft(ax, t_s, err[:, 1:, c], names)
        ax.set_ylabel(f"{label} (m)")
    ax.set_xlabel("time (s)")
    start = float(built.system.controller.start_s)
    if start > 0.0:
        for a in fig.axes:
            a.axvline(start, color="k", ls=":", lw=1)
    fig.suptitle(f"{ds.attrs.get('scenario_name', '')}: slot errors (truth, first spacecraft's LVLH)")
    return fig


def delta_v_figure(ds, built):
    """Each spacecraft's cumulative ``Σ_axes ∫|F| dt / m`` (m/s) against time."""
    masses = np.array([sc.mass_kg for sc in built.scenario.spacecraft], dtype=float)
    dv = ds["abs_force_impulse"].values.sum(axis=-1) / masses
    fig = Figure(figsize=(7.0, 4.2), layout="constrained")
    ax = fig.add_subplot()
    lines_by_spacecraft(ax, ds["time"].values, dv, [str(s) for s in ds["spacecraft"].values])
    ax.set_xlabel("time (s)")
    ax.set_ylabel("Δv, Σ axes ∫|F| dt / m (m/s)")
    ax.set_title(f"{ds.attrs.get('scenario_name', '')}: fuel")
    return fig


def figures(ds, built):
    """``{"slot_errors": Figure, "delta_v": Figure}`` (the second when thrust is recorded)."""
    out = {"slot_errors": slot_error_figure(ds, built)}
    if "abs_force_impulse" in ds:
        out["delta_v"] = delta_v_figure(ds, built)
    return out
