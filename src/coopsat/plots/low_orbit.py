"""Figures of the low-orbit environment: what each spacecraft met along the orbit, and how the
formation moved relative to its first spacecraft.

Pure functions from a run's dataset to :class:`matplotlib.figure.Figure` (object-oriented API,
no pyplot). Many spacecraft are drawn as thin lines without a legend.
"""

from matplotlib.figure import Figure

from coopsat.analysis.papers.low_orbit import series


def lines_by_spacecraft(ax, t_s, values, names):
    """One line per spacecraft (columns of ``values``); thin and without a legend above eight."""
    many = len(names) > 8
    for k, name in enumerate(names):
        ax.plot(t_s, values[:, k], lw=0.6 if many else 1.2, label=None if many else name)
    if not many and names:
        ax.legend(fontsize="small")


def environment_figure(ds, built):
    """Air density, drag and radiation-pressure force, and sunlight against time, per spacecraft
    (the panels the run recorded)."""
    import numpy as np

    t_s = ds["time"].values
    names = [str(s) for s in ds["spacecraft"].values]
    panels = [(v, label, log) for v, label, log in (
        ("air_density", "air density (kg/m³)", True),
        ("drag_force", "|drag| (N)", True),
        ("srp_force", "|radiation pressure| (N)", False),
        ("sunlight_fraction", "sunlight fraction", False),
    ) if v in ds]
    fig = Figure(figsize=(7.5, 2.2 * max(len(panels), 1) + 0.6), layout="constrained")
    for k, (var, label, log) in enumerate(panels):
        ax = fig.add_subplot(len(panels), 1, k + 1)
        values = ds[var].values
        if values.ndim == 3:
            values = np.linalg.norm(values, axis=-1)
        lines_by_spacecraft(ax, t_s, values, names if var != "sunlight_fraction" else names[:1])
        if log:
            ax.set_yscale("log")
        ax.set_ylabel(label)
    if panels:
        ax.set_xlabel("time (s)")
    fig.suptitle(f"{ds.attrs.get('scenario_name', '')}: the environment along the orbit")
    return fig


def relative_motion_figure(ds, built):
    """Each spacecraft's true position relative to the first, along-track and radial (m)."""
    rel = ds["relative_position_lvlh"].values if "relative_position_lvlh" in ds else series(ds, built)[
        "relative_position_lvlh"].values
    t_s = ds["time"].values
    names = [str(s) for s in ds["spacecraft"].values][1:]
    fig = Figure(figsize=(7.5, 5.5), layout="constrained")
    for k, (c, label) in enumerate(((0, "along-track x (m)"), (2, "radial z, to nadir (m)"))):
        ax = fig.add_subplot(2, 1, k + 1)
        lines_by_spacecraft(ax, t_s, rel[:, 1:, c], names)
        ax.set_ylabel(label)
    ax.set_xlabel("time (s)")
    fig.suptitle(f"{ds.attrs.get('scenario_name', '')}: positions relative to {ds['spacecraft'].values[0]} (truth, its LVLH)")
    return fig


def figures(ds, built):
    """``{"environment": Figure}``, and ``"relative_motion"`` with two or more spacecraft."""
    out = {"environment": environment_figure(ds, built)}
    if ds.sizes["spacecraft"] >= 2:
        out["relative_motion"] = relative_motion_figure(ds, built)
    return out
