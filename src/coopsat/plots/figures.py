"""Standard figures of a closed-loop run, drawn from the catalogue of its time series.

Only what the run has (:func:`coopsat.analysis.series.run_series`): attitude as error angles in
degrees (never raw quaternion components), rates, the torque of the first spacecraft (applied
and commanded, both inside the axes), synchronisation error, wheels when there are wheels,
thrusters when there are thrusters, relative motion when positions are simulated.

Pure functions from the run's :class:`xarray.Dataset` (see
:func:`coopsat.sim.recorder.to_dataset`) to :class:`matplotlib.figure.Figure`. Figures are
built with the object-oriented API only (no pyplot), so no backend or global state is touched
and nothing needs closing; :meth:`~matplotlib.figure.Figure.savefig` renders with Agg. Every
axis label gives its unit in parentheses, ``time (s)`` (:func:`axis_label`), as the paper
modules' figures do.
"""

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from coopsat.analysis.series import run_series, series_by_name

LOG_FLOOR = 1e-12
"""Errors are clipped to this floor so exact zeros (e.g. identical initial states) stay on a
log axis."""


def axis_label(what, unit):
    """The one unit style of every axis: ``what (unit)``; a count (unit ``1``) has none."""
    return what if unit in ("1", "") else f"{what} ({unit})"


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
    """The legend of ``ax``'s lines in the figure's right margin beside ``ax``, never over the
    data."""
    width_in, _ = fig.get_size_inches()
    right = 1.0 - MARGINS_IN["right"] / width_in
    fig.legend(*ax.get_legend_handles_labels(), loc="upper left", bbox_to_anchor=(right + 0.1 / width_in, ax.get_position().y1),
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
    axes[-1].set_xlabel(axis_label("time", ds["time"].attrs.get("units", "s")))
    fig.suptitle(_title(ds, what))
    return fig, axes


def _draw(ax, series, label=None, **select):
    """One series on ``ax``: a line per spacecraft (per wheel once a spacecraft is selected), a
    single line for a formation-wide series; log scale, floor and threshold as the series says.

    Parameters
    ----------
    series : coopsat.analysis.series.Series
    label : str, optional
        Axis label in place of the series' own (the unit is added).
    **select
        Positions to pick along dims, e.g. ``component=0`` or ``spacecraft=1``.
    """
    values = series.values.isel(select) if select else series.values
    t = values["time"].values
    y = values.transpose("time", ...).values.reshape(len(t), -1)
    names = [str(v) for v in values[values.dims[1]].values] if values.ndim > 1 else [None]
    # A log axis only where the values span a decade or more: a few degrees read better linear.
    log = series.log_scale and np.nanmax(y) >= 10.0 * max(np.nanmin(y), 0.0)
    if log:
        y = np.maximum(y, LOG_FLOOR)
    for k, name in enumerate(names):
        ax.plot(t, y[:, k], label=name)
    ax.set_ylabel(axis_label(label or series.label, series.unit))
    if series.threshold is not None:
        ax.axhline(series.threshold, ls=":", color="k")
        ax.annotate(f"threshold {series.threshold:g} {series.unit}", (1.0, series.threshold),
                    xycoords=("axes fraction", "data"), ha="right", va="bottom", fontsize="small")
    if log:
        _log_y(ax)


def _panels(ds, what, rows, legend_rows=(0,)):
    """A stacked figure with one panel per (series, label, select) row; the legend of each panel
    in ``legend_rows`` beside it."""
    fig, axes = _stacked(ds, len(rows), what)
    for ax, (series, label, select) in zip(axes, rows):
        _draw(ax, series, label, **select)
    for k in legend_rows:
        if axes[k].get_legend_handles_labels()[1]:
            _legend_outside(fig, axes[k])
    return fig


ATTITUDE_ERRORS = ("attitude_error_reference_deg", "attitude_error_desired_deg", "attitude_error_formation_deg")
"""The per-spacecraft attitude errors the attitude figure draws, those the run has, in order."""


def attitude_figure(ds, series):
    """Attitude of every spacecraft as error angles against time.

    Parameters
    ----------
    ds : xarray.Dataset
        Run record (time axis, names, title).
    series : dict of str -> Series
        The run's catalogue (:func:`coopsat.analysis.series.run_series`, by name).

    Returns
    -------
    matplotlib.figure.Figure
        One log-scale panel per attitude error the run has (to the reference, to the desired
        attitude, to the formation's mean; deg), one line per spacecraft; in the small-angle
        model, three panels θ_x, θ_y, θ_z (deg).
    """
    errors = [series[n] for n in ATTITUDE_ERRORS if n in series]
    if errors:
        return _panels(ds, "attitude error", [(s, s.label.replace(" to ", "\nto "), {}) for s in errors])
    angle = series["attitude_angle_deg"]
    return _panels(ds, "attitude angle", [(angle, f"θ_{c}", {"component": k}) for k, c in enumerate("xyz")])


def rate_figure(ds, series):
    """Body angular rates of every spacecraft against time: three panels ω_x, ω_y, ω_z (rad/s),
    one line per spacecraft, and the rate error to the desired rate when the run has one."""
    rows = [(series["rate_rad_s"], f"ω_{c}", {"component": k}) for k, c in enumerate("xyz")]
    if "rate_error_rad_s" in series:
        rows.append((series["rate_error_rad_s"], "rate error\nto desired", {}))
    return _panels(ds, "body angular rate", rows)


COMMAND_OVERLAY_MAX = 2.0
"""The command shares the applied torque's axes while its peak is at most this many times the
applied peak; a larger command (saturated, or a sampled-data instability) gets its own panels,
where it would otherwise squash the applied torque into a flat line."""


def _torque_panel(ax, t, values, *, step, color, label):
    """Mean line of ``values`` (T,) per window, with its min–max band when windowed; returns
    the (low, high) drawn."""
    t_w, mean, low, high = _windowed(t, values)
    windowed = len(t_w) < len(t)
    if windowed:
        ax.fill_between(t_w, low, high, step="post" if step else None, color=color, alpha=0.25, lw=0,
                        label=f"{label} min–max")
    ax.plot(t_w, mean, drawstyle="steps-post" if step else "default", color=color, lw=1.5 if step else 0.8,
            ls="-" if step else "--", label=f"{label} mean" if windowed else label)
    return low.min(), high.max()


def torque_figure(ds, series, spacecraft=0):
    """Applied and commanded torque of one spacecraft against time, both inside the axes.

    Parameters
    ----------
    ds : xarray.Dataset
        Run record (time axis, names, title).
    series : dict of str -> Series
        The run's catalogue; ``torque_n_m`` and, when a controller commands torque,
        ``torque_command_n_m`` (time, spacecraft, component), N m.
    spacecraft : int or str
        Index along ``spacecraft`` or the spacecraft's name.

    Returns
    -------
    matplotlib.figure.Figure
        Three panels (x, y, z): the applied torque as steps (it is the mean over the record
        interval *starting* at each sample) and the command dashed, y-limits from both. A
        command more than :data:`COMMAND_OVERLAY_MAX` times the applied peak is drawn in three
        panels of its own below. A record longer than :data:`WINDOWS` samples is drawn per
        window: the mean and a band from the smallest to the largest sample.
    """
    names = _names(ds)
    i = names.index(spacecraft) if isinstance(spacecraft, str) else int(spacecraft)
    t = ds["time"].values
    drawn = [(series[n].values.isel(spacecraft=i).transpose("time", "component").values, n == "torque_n_m")
             for n in ("torque_n_m", "torque_command_n_m") if n in series]
    peaks = [np.abs(v).max() for v, _ in drawn]
    own_panels = len(drawn) == 2 and peaks[1] > COMMAND_OVERLAY_MAX * peaks[0]
    windows = len(t) // len(_windowed(t, t)[0])
    what = f"torque of {names[i]}" + (f" ({windows}-sample windows)" if windows > 1 else "")
    fig, axes = _stacked(ds, 6 if own_panels else 3, what)
    peak = {}  # axes -> largest |torque| drawn on it, band included: the limits hold every line
    for values, applied in drawn:
        word = "applied" if applied else "command"
        panels = axes[3:] if own_panels and not applied else axes[:3]
        for k, (ax, comp) in enumerate(zip(panels, "xyz")):
            low, high = _torque_panel(ax, t, values[:, k], step=applied, color="C0" if applied else "k", label=word)
            peak[ax] = max(peak.get(ax, 0.0), abs(low), abs(high))
            ax.set_ylabel(axis_label(f"τ_{comp}" + (f"\n{word}" if own_panels else ""), "N m"))
    for ax, p in peak.items():
        if p > 0.0:  # symmetric about zero: a torque and its opposite read alike
            ax.set_ylim(-1.15 * p, 1.15 * p)
    _legend_outside(fig, axes[0])
    if own_panels:
        _legend_outside(fig, axes[3])
    return fig


def sync_error_figure(ds, series):
    """Synchronisation error of the formation against time on log axes: the largest pairwise
    attitude error (deg) and rate difference (rad/s), with the ``[analysis]`` thresholds
    dotted. Values are clipped below at :data:`LOG_FLOOR`."""
    rows = [(series[n], s, {}) for n, s in (("attitude_spread_deg", "max pairwise\nattitude error"),
                                            ("rate_spread_rad_s", "max pairwise\nrate difference")) if n in series]
    return _panels(ds, "synchronisation error", rows, legend_rows=())


def wheel_figure(ds, series):
    """Reaction wheels against time: each spacecraft's wheel speeds (rad/s, a line per wheel),
    then the wheels' momentum ‖h‖ of every spacecraft (N m s)."""
    speed = series.get("wheel_speed_rad_s")
    rows = [(speed, f"{name}\nwheel speed", {"spacecraft": k}) for k, name in enumerate(_names(ds))] if speed else []
    if "wheel_momentum_n_m_s" in series:
        rows.append((series["wheel_momentum_n_m_s"], "wheel\nmomentum ‖h‖", {}))
    return _panels(ds, "reaction wheels", rows, legend_rows=(0, len(rows) - 1) if speed else (0,))


def thruster_figure(ds, series):
    """Thrusters against time: cumulative firings and on-time of every spacecraft (all its
    thrusters)."""
    rows = [(series[n], s, {}) for n, s in (("thruster_firings", "firings"), ("thruster_on_time_s", "on-time"))
            if n in series]
    return _panels(ds, "thrusters (cumulative)", rows)


def relative_motion_figure(ds, series):
    """Relative motion against time: each spacecraft's distance (m) and speed (m/s) relative to
    the formation's centroid."""
    rows = [(series[n], s, {}) for n, s in (("distance_to_centroid_m", "distance\nto centroid"),
                                            ("speed_to_centroid_m_s", "speed\nto centroid")) if n in series]
    return _panels(ds, "relative motion", rows)


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


def figure_makers(ds, analysis=None, series=None):
    """Every standard figure the run has, keyed by file stem, not yet drawn.

    Parameters
    ----------
    ds : xarray.Dataset
        Run record.
    analysis : object, optional
        The scenario's ``[analysis]`` table (thresholds), as :func:`run_series` takes it.
    series : list of Series, optional
        The run's catalogue, if already made.

    Returns
    -------
    dict of str to callable
        ``stem -> () -> Figure``: ``attitude``, ``rates``, ``torque_<first spacecraft>``,
        ``sync_error``, ``wheels``, ``thrusters``, ``relative_motion``, each only when the run
        has its series.
    """
    s = series_by_name(run_series(ds, analysis) if series is None else series)
    wanted = {
        "attitude": ATTITUDE_ERRORS + ("attitude_angle_deg",),
        "rates": ("rate_rad_s",),
        f"torque_{_names(ds)[0]}": ("torque_n_m", "torque_command_n_m"),
        "sync_error": ("attitude_spread_deg", "rate_spread_rad_s"),
        "wheels": ("wheel_speed_rad_s", "wheel_momentum_n_m_s"),
        "thrusters": ("thruster_firings", "thruster_on_time_s"),
        "relative_motion": ("distance_to_centroid_m", "speed_to_centroid_m_s"),
    }
    draw = dict(zip(wanted, (attitude_figure, rate_figure, torque_figure, sync_error_figure, wheel_figure,
                             thruster_figure, relative_motion_figure)))
    return {stem: (lambda f=draw[stem]: f(ds, s)) for stem, names in wanted.items() if any(n in s for n in names)}


def standard_figures(ds, analysis=None, series=None):
    """All standard figures of a run, keyed by file stem (:func:`figure_makers`, drawn)."""
    return {stem: make() for stem, make in figure_makers(ds, analysis, series).items()}


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
