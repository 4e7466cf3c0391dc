"""Figures of a Monte Carlo campaign (``coopsat campaign report``): a metric's histogram over
the runs, and a metric against the dispersed parameter it is most sensitive to.

Pure functions from arrays to :class:`matplotlib.figure.Figure` (object-oriented API, no pyplot).
"""

import numpy as np
from matplotlib.figure import Figure


def histogram_figure(values, name, percentiles=(1.0, 50.0, 99.0)):
    """Histogram of one metric over the finished runs, with the given percentiles marked.

    Parameters
    ----------
    values : (k,)
        The metric of every run that has it (finite).
    """
    fig = Figure(figsize=(6.0, 3.6), layout="constrained")
    ax = fig.add_subplot()
    ax.hist(values, bins=min(50, max(5, int(np.sqrt(len(values))))), color="0.55")
    for p, v in zip(percentiles, np.percentile(values, percentiles)):
        ax.axvline(v, color="k", lw=0.8, ls="--")
        ax.annotate(f"P{p:g}", (v, 1.0), xycoords=("data", "axes fraction"), ha="center", va="bottom", fontsize="x-small")
    ax.set_xlabel(name)
    ax.set_ylabel("runs")
    return fig


def scatter_figure(x, y, x_name, y_name, rho):
    """One metric against one dispersed parameter over the runs (Spearman ``rho`` in the title)."""
    fig = Figure(figsize=(6.0, 3.6), layout="constrained")
    ax = fig.add_subplot()
    ax.plot(x, y, ".", ms=3, color="0.3")
    ax.set_xlabel(x_name)
    ax.set_ylabel(y_name)
    ax.set_title(f"Spearman ρ = {rho:+.2f}", fontsize="small")
    return fig


def envelope_figure(t_s, values, name):
    """A quantity over time across the runs: mean, mean ± 3σ and the min–max envelope.

    Parameters
    ----------
    t_s : (T,)
    values : (runs, T)
    """
    fig = Figure(figsize=(6.5, 3.8), layout="constrained")
    ax = fig.add_subplot()
    mean, std = np.nanmean(values, axis=0), np.nanstd(values, axis=0)
    ax.fill_between(t_s, np.nanmin(values, axis=0), np.nanmax(values, axis=0), color="0.88", label="min–max")
    ax.plot(t_s, mean, color="k", lw=1.2, label="mean")
    ax.plot(t_s, mean + 3 * std, color="k", lw=0.8, ls="--", label="mean ± 3σ")
    ax.plot(t_s, mean - 3 * std, color="k", lw=0.8, ls="--")
    ax.set_xlabel("time (s)")
    ax.set_ylabel(name)
    ax.legend(fontsize="x-small")
    return fig
