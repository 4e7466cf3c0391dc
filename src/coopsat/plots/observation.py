"""Figures of the Earth-observation runs (SPEC §5): attitude error against time (paper Figs. 5, 8),
control torque (Figs. 6–7), the pair's relative error and image-plane mismatch (Figs. 8b, 9),
wheel speeds and magnetorquer dipoles, and the target's elevation. Where a wheel drive held a
wheel at its rated speed (cutting the torque that would have taken it further) the error and
wheel figures shade the interval, and the wheel speeds have their limits as dashed lines.

Pure functions from a dataset and its built scenario to :class:`matplotlib.figure.Figure`
(object-oriented API, no pyplot); the error series come from
:func:`coopsat.analysis.papers.observation_2019.series`, already in the dataset.
"""

import numpy as np
from matplotlib.figure import Figure

_AXES = ("x", "y", "z")


def _title(ds, what):
    return f"{ds.attrs.get('scenario_name', '')}: {what}"


def _stare_lines(ax, ds, k):
    staring = ds["staring"].values[:, k] > 0.5
    if staring.any():
        ax.axvline(ds["time"].values[np.argmax(staring)], color="0.5", lw=0.8, ls="--")


def limited_spans(ds, k):
    """Record intervals ``(t_start, t_end)`` (s) in which spacecraft ``k``'s drive held some
    wheel at its rated speed: where ``wheel_speed_limited_time`` grew, consecutive intervals
    merged; empty without wheels."""
    if "wheel_speed_limited_time" not in ds:
        return []
    t = ds["time"].values
    grew = np.diff(ds["wheel_speed_limited_time"].values[:, k].sum(axis=-1)) > 0.0
    # Edges of the runs of True: +1 where one starts, -1 after one ends.
    edges = np.diff(np.concatenate([[0], grew.astype(int), [0]]))
    return [(t[a], t[b]) for a, b in zip(np.flatnonzero(edges > 0), np.flatnonzero(edges < 0))]


def _shade_limited(ax, ds, k):
    for start, end in limited_spans(ds, k):
        ax.axvspan(start, end, color="tab:red", alpha=0.15, lw=0)


def error_figure(ds, built):
    """Per spacecraft: the attitude and pointing errors (deg, log scale) against time."""
    t = ds["time"].values
    fig = Figure(figsize=(7.5, 2.4 * len(built.names) + 0.6), layout="constrained")
    axes = fig.subplots(len(built.names), 1, sharex=True, squeeze=False)[:, 0]
    for k, (ax, name) in enumerate(zip(axes, built.names)):
        ax.semilogy(t, np.degrees(ds["attitude_error"].values[:, k]), lw=0.8, label="attitude error")
        ax.semilogy(t, np.degrees(ds["pointing_error"].values[:, k]), lw=0.8, label="pointing error (+z to target)")
        _stare_lines(ax, ds, k)
        _shade_limited(ax, ds, k)
        ax.set_ylabel(f"{name} (deg)")
        ax.grid(alpha=0.3, which="both")
    axes[0].legend(fontsize="small")
    axes[-1].set_xlabel("time (s)")
    fig.suptitle(_title(ds, "truth attitude error\n(dashed: staring starts; shaded: a wheel held at its rated speed)"))
    return fig


def torque_figure(ds, built):
    """Per spacecraft: the commanded body torque per axis, mN·m."""
    t = ds["time"].values
    fig = Figure(figsize=(7.5, 2.2 * len(built.names) + 0.6), layout="constrained")
    axes = fig.subplots(len(built.names), 1, sharex=True, squeeze=False)[:, 0]
    for k, (ax, name) in enumerate(zip(axes, built.names)):
        for c in range(3):
            ax.plot(t, 1e3 * ds["torque_command"].values[:, k, c], lw=0.7, label=_AXES[c])
        ax.set_ylabel(f"{name} (mN·m)")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize="small", ncols=3)
    axes[-1].set_xlabel("time (s)")
    fig.suptitle(_title(ds, "commanded control torque"))
    return fig


def relative_figure(ds, built):
    """The pair: relative attitude error and image-plane mismatch against the reference, deg."""
    t = ds["time"].values
    ref = int(built.system.controller.reference)
    fig = Figure(figsize=(7.5, 4.2), layout="constrained")
    ax = fig.add_subplot()
    for k, name in enumerate(built.names):
        if k == ref:
            continue
        ax.semilogy(t, np.degrees(ds["relative_attitude_error"].values[:, k]), lw=0.8, label=f"{name}: relative attitude error")
        ax.semilogy(t, np.degrees(ds["image_mismatch"].values[:, k]), lw=0.8, label=f"{name}: image-plane mismatch")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("error to the reference (deg)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize="small")
    ax.set_title(_title(ds, f"against {built.names[ref]} (law: {built.scenario.controller.law})"))
    return fig


def _wheel_limits_rpm(built):
    """The distinct rated speeds of the run's reaction wheels, rpm, (k,)."""
    wheels = next(a for a in built.scenario.actuator_list if a.kind == "reaction-wheels")
    return np.unique(np.asarray(wheels.max_speed_rpm, dtype=float))


def actuator_figure(ds, built):
    """Wheel speeds (rpm) and, with magnetorquers, dipole commands (A·m²) per spacecraft."""
    t = ds["time"].values
    have_wheels = "wheel_speed" in ds
    fig = Figure(figsize=(7.5, 2.2 * len(built.names) + 0.6), layout="constrained")
    axes = fig.subplots(len(built.names), 2, sharex=True, squeeze=False)
    for k, name in enumerate(built.names):
        if have_wheels:
            for w, label in enumerate(ds["wheel"].values):
                axes[k, 0].plot(t, ds["wheel_speed"].values[:, k, w] * 60.0 / (2.0 * np.pi), lw=0.8, label=str(label))
            for rpm in _wheel_limits_rpm(built):
                for sign in (-1.0, 1.0):
                    axes[k, 0].axhline(sign * rpm, color="0.4", lw=0.8, ls="--")
            _shade_limited(axes[k, 0], ds, k)
        axes[k, 0].set_ylabel(f"{name} wheels (rpm)")
        for c in range(3):
            axes[k, 1].plot(t, ds["dipole_command"].values[:, k, c], lw=0.8, label=_AXES[c])
        axes[k, 1].set_ylabel("dipole (A·m²)")
        for ax in axes[k]:
            ax.grid(alpha=0.3)
    if have_wheels:
        axes[0, 0].legend(fontsize="small", ncols=2)
    axes[0, 1].legend(fontsize="small", ncols=3)
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
    fig.suptitle(_title(ds, "wheel speeds and momentum-dumping dipole\n"
                            "(dashed: rated speeds; shaded: a wheel held at one)"))
    return fig


def elevation_figure(ds, built):
    """The target's elevation above its horizon as seen from each spacecraft, deg."""
    t = ds["time"].values
    fig = Figure(figsize=(7.0, 3.6), layout="constrained")
    ax = fig.add_subplot()
    for k, name in enumerate(built.names):
        ax.plot(t, np.degrees(ds["target_elevation"].values[:, k]), label=name)
    ax.axhline(built.scenario.controller.min_elevation_deg, color="0.5", lw=0.8, ls="--")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("elevation (deg)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small")
    ax.set_title(_title(ds, "target elevation (dashed: staring threshold)"))
    return fig


def figures(ds, built):
    """The paper's figures of one run, keyed by file stem."""
    out = {
        "attitude_error": error_figure(ds, built),
        "control_torque": torque_figure(ds, built),
        "actuators": actuator_figure(ds, built),
        "target_elevation": elevation_figure(ds, built),
    }
    if len(built.names) > 1:
        out["relative_error"] = relative_figure(ds, built)
    return out
