"""Standard figures of a closed-loop run: attitude, rates, torque, synchronisation error.

Pure functions from the run's :class:`xarray.Dataset` (see
:func:`coopsat.sim.recorder.to_dataset`) to :class:`matplotlib.figure.Figure`. Figures are
built with the object-oriented API only (no pyplot), so no backend or global state is touched
and nothing needs closing; :meth:`~matplotlib.figure.Figure.savefig` renders with Agg.
"""

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from coopsat.analysis.metrics import (
    pairwise_attitude_error_deg,
    pairwise_rate_difference_rad_s,
    quat_angle_between_deg,
)

LOG_FLOOR = 1e-12
"""Errors are clipped to this floor so exact zeros (e.g. identical initial states) stay on a
log axis."""


def _values(ds, name, *dims):
    # Explicit transpose: the plotting code indexes by position.
    return ds[name].transpose(*dims).values


def _names(ds):
    return [str(s) for s in ds["spacecraft"].values]


def _title(ds, what):
    scenario = ds.attrs.get("scenario_name", "")
    return f"{scenario}: {what}" if scenario else what


MARGINS_IN = {"left": 1.3, "right": 1.75, "top": 0.45, "bottom": 0.5, "gap": 0.12}
"""Fixed margins of the stacked figures, inches: two-line axis labels on the left, the legend
on the right. Fixed rather than matplotlib's constrained layout, which measures every tick
label of every axes before drawing and was half the time of writing a run's figures (2 of
3.7 s for ``consensus-sync-a``)."""


def _legend_outside(fig, ax):
    """The legend of ``ax``'s lines in the figure's right margin, never over the data."""
    width_in, height_in = fig.get_size_inches()
    right = 1.0 - MARGINS_IN["right"] / width_in
    top = 1.0 - MARGINS_IN["top"] / height_in
    fig.legend(*ax.get_legend_handles_labels(), loc="upper left", bbox_to_anchor=(right + 0.1 / width_in, top),
               fontsize="small")


WINDOWS = 200
"""A long record is drawn as this many windows (mean line, min–max band) so that it stays
readable: a PWM torque recorded every period is otherwise a solid block of switching."""


def _windowed(t, values):
    """(t_start, mean, low, high) over consecutive windows along the first axis; the samples
    themselves when there are fewer than :data:`WINDOWS`."""
    n = len(t)
    size = max(1, n // WINDOWS)
    if size == 1:
        return t, values, values, values
    cut = n - n % size
    shaped = values[:cut].reshape(cut // size, size, *values.shape[1:])
    return t[:cut:size], shaped.mean(axis=1), shaped.min(axis=1), shaped.max(axis=1)


def _stacked(ds, n_axes, what):
    width_in, height_in = 8.0, 1.8 * n_axes + 0.6
    fig = Figure(figsize=(width_in, height_in))
    m = MARGINS_IN
    axes = fig.subplots(n_axes, 1, sharex=True, squeeze=False, gridspec_kw=dict(
        left=m["left"] / width_in, right=1.0 - m["right"] / width_in, top=1.0 - m["top"] / height_in,
        bottom=m["bottom"] / height_in, hspace=m["gap"] * n_axes / (height_in - m["top"] - m["bottom"])))[:, 0]
    axes[-1].set_xlabel(f"time [{ds['time'].attrs.get('units', 's')}]")
    fig.suptitle(_title(ds, what))
    return fig, axes


def attitude_figure(ds):
    """Attitude quaternion components of every spacecraft against time.

    Parameters
    ----------
    ds : xarray.Dataset
        Run record with ``q`` (time, spacecraft, q_component), dimensionless, scalar first;
        ``q_ref`` (time, q_component) is drawn as a thick black "reference" line if present.

    Returns
    -------
    matplotlib.figure.Figure
        Four stacked axes, q0..q3, one line per spacecraft. Quaternions are plotted as
        recorded (q and −q are the same attitude; no sign is chosen here).
    """
    q = _values(ds, "q", "time", "spacecraft", "q_component")
    q_ref = _values(ds, "q_ref", "time", "q_component") if "q_ref" in ds else None
    t = ds["time"].values
    fig, axes = _stacked(ds, 4, "attitude quaternion")
    for k, (ax, comp) in enumerate(zip(axes, ds["q_component"].values)):
        if q_ref is not None:
            ax.plot(t, q_ref[:, k], color="k", lw=2.5, label="reference")
        for i, name in enumerate(_names(ds)):
            ax.plot(t, q[:, i, k], label=name)
        ax.set_ylabel(f"{comp} [{ds['q'].attrs['units']}]")
    _legend_outside(fig, axes[0])
    return fig


def _per_axis_figure(ds, name, symbol, what):
    values = _values(ds, name, "time", "spacecraft", "component")
    t = ds["time"].values
    fig, axes = _stacked(ds, 3, what)
    for k, (ax, comp) in enumerate(zip(axes, ds["component"].values)):
        for i, sc in enumerate(_names(ds)):
            ax.plot(t, values[:, i, k], label=sc)
        ax.set_ylabel(f"{symbol}_{comp} [{ds[name].attrs['units']}]")
    _legend_outside(fig, axes[0])
    return fig


def rate_figure(ds):
    """Body angular rates of every spacecraft against time.

    Parameters
    ----------
    ds : xarray.Dataset
        Run record with ``omega`` (time, spacecraft, component), rad/s.

    Returns
    -------
    matplotlib.figure.Figure
        Three stacked axes, ω_x, ω_y, ω_z, one line per spacecraft.
    """
    return _per_axis_figure(ds, "omega", "ω", "body angular rate")


def angle_figure(ds):
    """Small attitude angles of every spacecraft against time (small-angle model).

    Parameters
    ----------
    ds : xarray.Dataset
        Run record with ``angle`` (time, spacecraft, component), rad.

    Returns
    -------
    matplotlib.figure.Figure
        Three stacked axes, θ_x, θ_y, θ_z, one line per spacecraft.
    """
    return _per_axis_figure(ds, "angle", "θ", "attitude angle")


def torque_figure(ds, spacecraft=0):
    """Applied and commanded torque of one spacecraft against time.

    Parameters
    ----------
    ds : xarray.Dataset
        Run record with ``torque`` and, when a controller commands torque, ``torque_command``
        (time, spacecraft, component), N·m.
    spacecraft : int or str
        Index along ``spacecraft`` or the spacecraft's name.

    Returns
    -------
    matplotlib.figure.Figure
        Three stacked axes (x, y, z). The applied torque is a step plot (it is the mean over
        the record interval *starting* at each sample); the command is a thin dashed line. A
        record longer than :data:`WINDOWS` samples is drawn per window: the mean applied torque
        and a band from its smallest to its largest sample, and the mean command. The view is
        scaled to the applied torque: a saturated command runs off the axes, as a thruster's
        demand does beyond its authority.
    """
    names = _names(ds)
    i = names.index(spacecraft) if isinstance(spacecraft, str) else int(spacecraft)
    torque = _values(ds, "torque", "time", "spacecraft", "component")[:, i]
    command = _values(ds, "torque_command", "time", "spacecraft", "component")[:, i] if "torque_command" in ds else None
    t = ds["time"].values
    t_w, mean, low, high = _windowed(t, torque)
    windowed = len(t_w) < len(t)
    fig, axes = _stacked(ds, 3, f"torque of {names[i]}" + (f" ({len(t) // len(t_w)}-sample windows)" if windowed else ""))
    limit = 1.15 * np.abs(torque).max()
    for k, (ax, comp) in enumerate(zip(axes, ds["component"].values)):
        if windowed:
            ax.fill_between(t_w, low[:, k], high[:, k], step="post", color="C0", alpha=0.25, lw=0, label="applied, min–max")
        ax.plot(t_w, mean[:, k], drawstyle="steps-post", color="C0", label="applied, mean" if windowed else "applied")
        if command is not None:
            ax.plot(t_w, _windowed(t, command)[1][:, k], "--", lw=0.8, color="k",
                    label="commanded, mean" if windowed else "commanded")
        if limit > 0.0:
            ax.set_ylim(-limit, limit)
        ax.set_ylabel(f"τ_{comp} [{ds['torque'].attrs['units']}]")
    _legend_outside(fig, axes[0])
    return fig


def sync_error_figure(ds, attitude_threshold_deg=None, rate_threshold_rad_s=None):
    """Synchronisation (and, if tracking, reference) errors against time on log axes.

    Parameters
    ----------
    ds : xarray.Dataset
        Run record with ``q`` and ``omega``; optional ``q_ref`` adds a third axis.
    attitude_threshold_deg : float, optional
        Drawn as a dotted horizontal line on the attitude axes, deg.
    rate_threshold_rad_s : float, optional
        Drawn as a dotted horizontal line on the rate axis, rad/s.

    Returns
    -------
    matplotlib.figure.Figure
        Axes: largest pairwise attitude error (deg); largest pairwise rate difference
        (rad/s); with ``q_ref``, each spacecraft's attitude error to the reference (deg).
        Values are clipped below at :data:`LOG_FLOOR`.
    """
    q = _values(ds, "q", "time", "spacecraft", "q_component")
    omega = _values(ds, "omega", "time", "spacecraft", "component")
    t = ds["time"].values
    tracking = "q_ref" in ds
    fig, axes = _stacked(ds, 3 if tracking else 2, "synchronisation error")
    axes[0].plot(t, np.maximum(pairwise_attitude_error_deg(q), LOG_FLOOR))
    axes[0].set_ylabel("max pairwise\nattitude error [deg]")
    axes[1].plot(t, np.maximum(pairwise_rate_difference_rad_s(omega), LOG_FLOOR))
    axes[1].set_ylabel("max pairwise\nrate difference [rad/s]")
    attitude_axes = [axes[0]]
    if tracking:
        q_ref = _values(ds, "q_ref", "time", "q_component")
        error = quat_angle_between_deg(q, q_ref[:, None, :])
        for i, name in enumerate(_names(ds)):
            axes[2].plot(t, np.maximum(error[:, i], LOG_FLOOR), label=name)
        axes[2].set_ylabel("error to\nreference [deg]")
        _legend_outside(fig, axes[2])
        attitude_axes.append(axes[2])
    if attitude_threshold_deg is not None:
        for ax in attitude_axes:
            ax.axhline(attitude_threshold_deg, ls=":", color="k")
            ax.annotate(f"threshold {attitude_threshold_deg:g}°", (1.0, attitude_threshold_deg), xycoords=("axes fraction", "data"),
                        ha="right", va="bottom", fontsize="small")
    if rate_threshold_rad_s is not None:
        axes[1].axhline(rate_threshold_rad_s, ls=":", color="k")
        axes[1].annotate(f"threshold {rate_threshold_rad_s:g} rad/s", (1.0, rate_threshold_rad_s),
                         xycoords=("axes fraction", "data"), ha="right", va="bottom", fontsize="small")
    for ax in axes:
        _log_y(ax)
    return fig


_SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def decade_label(value, _pos=None):
    """Tick label of a log axis: ``10⁻³`` at a power of ten, nothing elsewhere. Plain Unicode:
    matplotlib's own log labels are mathtext, whose parser alone took 0.5 s of a run's figures."""
    exponent = np.log10(value) if value > 0 else 0.5
    if abs(exponent - round(exponent)) > 1e-9:
        return ""
    return "10" + f"{int(round(exponent)):d}".translate(_SUPERSCRIPT)


def _log_y(ax):
    """Log scale on the y axis, labelled at the decades by :func:`decade_label` when the data
    cross two powers of ten or more (else matplotlib's own labels, which also mark values
    between)."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    ax.set_yscale("log")
    low, high = ax.dataLim.intervaly
    if low > 0 and np.floor(np.log10(high)) - np.ceil(np.log10(low)) >= 1:
        ax.yaxis.set_major_locator(LogLocator(base=10.0))
        ax.yaxis.set_major_formatter(FuncFormatter(decade_label))
        ax.yaxis.set_minor_formatter(NullFormatter())


def standard_figures(ds, attitude_threshold_deg=None, rate_threshold_rad_s=None):
    """All standard figures of a run, keyed by file stem.

    Parameters
    ----------
    ds : xarray.Dataset
        Run record (see :func:`attitude_figure` … :func:`sync_error_figure`).
    attitude_threshold_deg : float, optional
        Passed to :func:`sync_error_figure`, deg.
    rate_threshold_rad_s : float, optional
        Passed to :func:`sync_error_figure`, rad/s.

    Returns
    -------
    dict of str to matplotlib.figure.Figure
        ``attitude`` (quaternions, or angles in the small-angle model), ``rates``,
        ``torque_<first spacecraft name>`` (when a torque acts), ``sync_error`` (quaternions).
    """
    small_angle = "q" not in ds
    figures = {"attitude": angle_figure(ds) if small_angle else attitude_figure(ds), "rates": rate_figure(ds)}
    if "torque" in ds:
        figures[f"torque_{_names(ds)[0]}"] = torque_figure(ds, 0)
    if not small_angle:
        figures["sync_error"] = sync_error_figure(ds, attitude_threshold_deg, rate_threshold_rad_s)
    return figures


def save_figures(figures, directory, dpi=120):
    """Write each figure as ``<stem>.png`` into a directory.

    Parameters
    ----------
    figures : dict of str to matplotlib.figure.Figure
        File stem -> figure, e.g. from :func:`standard_figures`.
    directory : str or pathlib.Path
        Output directory, created if missing.
    dpi : int
        Resolution, dots per inch.

    Returns
    -------
    list of pathlib.Path
        The written files, in the order of ``figures``.
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    paths = [directory / f"{stem}.png" for stem in figures]
    for path, fig in zip(paths, figures.values()):
        fig.savefig(path, dpi=dpi)
    return paths
