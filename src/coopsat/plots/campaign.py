"""Figures of a Monte Carlo campaign (``coopsat campaign report``): a metric's histogram over
the runs, a metric against the dispersed parameter it is most sensitive to, and a quantity's
envelope over time. Axis labels come from the caller, with their unit.

Pure functions from arrays to :class:`matplotlib.figure.Figure` (object-oriented API, no pyplot).
"""

import numpy as np
from matplotlib.figure import Figure


def histogram_figure(values, label, percentiles=(1.0, 50.0, 99.0)):
    """Histogram of one metric over the finished runs, with the given percentiles marked.

    Parameters
    ----------
    values : (k,)
        The metric of every run that has it (finite).
    label : str
        The metric with its unit (the x axis).
    """
    fig = Figure(figsize=(6.0, 3.6), layout="constrained")
    ax = fig.add_subplot()
    ax.hist(values, bins=min(50, max(5, int(np.sqrt(len(values))))), color="0.55")
    for p, v in zip(percentiles, np.percentile(values, percentiles)):
        ax.axvline(v, color="k", lw=0.8, ls="--")
        ax.annotate(f"P{p:g}", (v, 1.0), xycoords=("data", "axes fraction"), ha="center", va="bottom", fontsize="x-small")
    ax.set_xlabel(label)
    ax.set_ylabel("runs")
    return fig


def scatter_figure(x, y, x_label, y_label, rho):
    """One metric against one dispersed parameter over the runs (Spearman ``rho`` in the title);
    ``x``, ``y``: (runs,), NaN where a run has none; the labels with their units."""
    fig = Figure(figsize=(6.0, 3.6), layout="constrained")
    ax = fig.add_subplot()
    ax.plot(x, y, ".", ms=3, color="0.3")
    ax.set_xlabel(x_label)
    ax.set_ylabel(y_label)
    ax.set_title(f"Spearman ρ = {rho:+.2f}", fontsize="small")
    return fig


def envelope_figure(t_s, values, label, floor=None):
    """A quantity over time across the runs: mean, mean ± 3σ and the min–max envelope.

    Parameters
    ----------
    t_s : (T,)
    values : (runs, T)
    label : str
        The quantity with its unit (the y axis).
    floor : float, optional
        The least value the quantity can take (0 for a norm or a time): the −3σ line stops
        there rather than promise values it cannot have.
    """
    fig = Figure(figsize=(6.5, 3.8), layout="constrained")
    ax = fig.add_subplot()
    mean, std = np.nanmean(values, axis=0), np.nanstd(values, axis=0)
    ax.fill_between(t_s, np.nanmin(values, axis=0), np.nanmax(values, axis=0), color="0.88", label="min–max")
    ax.plot(t_s, mean, color="k", lw=1.2, label="mean")
    band = "mean ± 3σ" if floor is None else f"mean ± 3σ (stopped at {floor:g})"
    ax.plot(t_s, mean + 3 * std, color="k", lw=0.8, ls="--", label=band)
    low = mean - 3 * std
    ax.plot(t_s, low if floor is None else np.maximum(low, floor), color="k", lw=0.8, ls="--")
    ax.set_xlabel("time (s)")
    ax.set_ylabel(label)
    ax.legend(fontsize="x-small")
    return fig
