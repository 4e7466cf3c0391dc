"""Figures of the cartwheel keeping runs (SPEC §2): truth position and velocity errors per
LVLH axis of each deputy (paper Figs. 8–9), and the impulse bits fired against time.

Pure functions from a dataset and its built scenario to :class:`matplotlib.figure.Figure`
(object-oriented API, no pyplot).
"""

import numpy as np
from matplotlib.figure import Figure

from coopsat.analysis.papers.cartwheel_keeping import truth_errors

_AXES = ("x (along-track)", "y (−orbit normal)", "z (nadir)")


def error_figure(ds, built, which):
    """One panel per deputy: the truth error along each LVLH axis against time (``which`` 0:
    position, m, Fig. 8; 1: velocity, m/s, Fig. 9)."""
    errors = truth_errors(ds, built)
    err, names = errors[which], errors[2]
    t = ds["time"].values
    fig = Figure(figsize=(7.5, 2.2 * len(names) + 0.6), layout="constrained")
    axes = fig.subplots(len(names), 1, sharex=True, squeeze=False)[:, 0]
    unit = ("m", "m/s")[which]
    for ax, name, e in zip(axes, names, np.moveaxis(err, 1, 0)):
        for c in range(3):
            ax.plot(t, e[:, c], lw=0.8, label=_AXES[c])
        ax.set_ylabel(f"{name} ({unit})")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize="small", ncols=3)
    axes[-1].set_xlabel("time (s)")
    fig.suptitle(f"{ds.attrs.get('scenario_name', '')}: truth {('position', 'velocity')[which]} error, chief's LVLH")
    return fig


def bits_figure(ds, built):
    """Cumulative impulse bits fired by each deputy (all axes) against time."""
    t = ds["time"].values
    bits = ds["impulse_bits"].values.sum(axis=-1)
    fig = Figure(figsize=(7.0, 4.0), layout="constrained")
    ax = fig.add_subplot()
    for k, name in enumerate(built.names):
        if k != int(built.system.controller.chief):
            ax.plot(t, bits[:, k], label=name)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("impulse bits fired (1e-5 N·s each)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small")
    ax.set_title(f"{ds.attrs.get('scenario_name', '')}: impulse bits")
    return fig


def figures(ds, built):
    """The paper's figures of one run, keyed by file stem."""
    return {"position_error": error_figure(ds, built, 0), "velocity_error": error_figure(ds, built, 1), "impulse_bits": bits_figure(ds, built)}
