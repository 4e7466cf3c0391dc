"""Figures of a navigation filter: estimate error with the filter's ±3σ, and its consistency
(NEES against the χ² band).

Pure functions from a run's dataset to :class:`matplotlib.figure.Figure` (object-oriented API,
no pyplot).
"""

import numpy as np
from matplotlib.figure import Figure

from coopsat.analysis.papers.navigation import chi2_band, effective_count, series_of

_AXES = {"LVLH": ("along-track x", "cross-track y", "radial z (nadir)"), "ECI": ("x", "y", "z")}


def estimate_error_figure(ds, built, velocity=False):
    """Estimate minus truth per axis (position, or velocity) of each spacecraft the filter
    judges, with ±3σ."""
    have = series_of(ds, built)
    t_s = ds["time"].values
    off, unit, what = (3, "m/s", "velocity") if velocity else (0, "m", "position")
    judged = built.system.controller.navigation.estimated(ds.sizes["spacecraft"])
    fig = Figure(figsize=(7.5, 7.0), layout="constrained")
    frame = have["nav_error"].attrs.get("frame", "LVLH")
    for c, label in enumerate(_AXES.get(frame, _AXES["ECI"])):
        ax = fig.add_subplot(3, 1, c + 1)
        for i, name in enumerate(ds["spacecraft"].values):
            if i not in judged:
                continue
            err = have["nav_error"].values[:, i, off + c]
            three = 3.0 * have["nav_sigma"].values[:, i, off + c]
            (line,) = ax.plot(t_s, err, lw=0.8, label=f"{name}: error")
            ax.plot(t_s, three, color=line.get_color(), ls="--", lw=0.8, label=f"{name}: ±3σ")
            ax.plot(t_s, -three, color=line.get_color(), ls="--", lw=0.8)
        ax.set_ylabel(f"{label} ({unit})")
    fig.axes[0].legend(fontsize="small", loc="upper right")
    ax.set_xlabel("time (s)")
    fig.suptitle(f"{ds.attrs.get('scenario_name', '')}: {what} estimate error ({frame})")
    return fig


def nees_figure(ds, built):
    """NEES of each deputy against time, its mean over the deputies, and the 95 % χ² band of
    one sample's value and of the run's mean."""
    have = series_of(ds, built)
    t_s = ds["time"].values
    values = have["nees"].values
    deputies = [i for i in range(values.shape[1]) if not np.all(np.isnan(values[:, i]))]
    fig = Figure(figsize=(7.0, 4.2), layout="constrained")
    ax = fig.add_subplot()
    for i in deputies:
        ax.plot(t_s, values[:, i], lw=0.6, alpha=0.7, label=str(ds["spacecraft"].values[i]))
    low, high = chi2_band(6, 1)
    ax.axhspan(low, high, color="0.85", zorder=0, label="95 % band of one value, χ²(6)")
    mean_low, mean_high = chi2_band(6, sum(effective_count(values[1:, i]) for i in deputies))
    mean = float(np.nanmean(values[1:, deputies]))
    ax.axhline(mean, color="k", lw=1.2, label=f"run mean {mean:.2f} (95 % band {mean_low:.2f}–{mean_high:.2f})")
    ax.set_yscale("log")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("NEES (1)")
    ax.legend(fontsize="small")
    ax.set_title(f"{ds.attrs.get('scenario_name', '')}: filter consistency")
    return fig


def figures(ds, built):
    """``{"nav_position_error", "nav_velocity_error", "nees"}``."""
    return {
        "nav_position_error": estimate_error_figure(ds, built),
        "nav_velocity_error": estimate_error_figure(ds, built, velocity=True),
        "nees": nees_figure(ds, built),
    }
