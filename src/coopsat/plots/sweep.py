"""The figure of a parameter sweep (``coopsat sweep --plot X:Y``): one quantity against another
over the sweep's points, as the cartwheel paper's Figs. 10–11 draw keeping error against fuel.

A pure function from arrays to :class:`matplotlib.figure.Figure` (object-oriented API, no pyplot).
"""

import numpy as np
from matplotlib.figure import Figure

LOG_SPAN = 100.0
"""An axis whose positive values span this ratio or more is drawn on a log scale."""


def _spread(values):
    """Per point (row) the mean over seeds, and its distance to the min and to the max (NaN
    when a run has none, as in the sweep's table)."""
    mean = values.mean(axis=1)
    return mean, np.vstack([mean - values.min(axis=1), values.max(axis=1) - mean])


def _log_if_wide(ax, axis, values):
    finite = values[np.isfinite(values)]
    if finite.size and finite.min() > 0 and finite.max() / finite.min() >= LOG_SPAN:
        getattr(ax, f"set_{axis}scale")("log")


def sweep_figure(x, y, x_label, y_label, title=""):
    """``y`` against ``x`` over a sweep's points, joined in sweep order: the mean over the
    seeds of each point, with bars from its min to its max (on both axes).

    Parameters
    ----------
    x, y : array (points, seeds)
        Each run's value; NaN where a run has none (e.g. a time never reached): a point with
        such a run is left out, as its mean is null in the sweep's table.
    x_label, y_label : str
        Axis labels (the metric or field names).
    title : str
        First line of the title (the second says how seeds are summarised).

    Returns
    -------
    matplotlib.figure.Figure
    """
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    (mx, ex), (my, ey) = _spread(x), _spread(y)
    fig = Figure(figsize=(6.4, 4.6), layout="constrained")
    ax = fig.add_subplot()
    seeds = x.shape[1]
    ax.errorbar(mx, my, xerr=ex if seeds > 1 else None, yerr=ey if seeds > 1 else None, fmt="o-", capsize=3)
    _log_if_wide(ax, "x", mx)
    _log_if_wide(ax, "y", my)
    ax.set_xlabel(x_label)
    ax.set_ylabel(y_label)
    note = f"mean of {seeds} seeds, bars from min to max" if seeds > 1 else ""
    ax.set_title("\n".join(t for t in (title, note) if t), fontsize="medium")
    ax.grid(True, alpha=0.3)
    return fig
