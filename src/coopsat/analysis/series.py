"""The catalogue of a run's time series: every quantity over time that the run actually has.

One list, built from the record alone (a :class:`xarray.Dataset` from ``result.nc``), that the
standard figures (:mod:`coopsat.plots.figures`), ``coopsat pair`` (B − A over time) and the
HTML report all draw from, so that they agree on names, labels and units:

>>> from coopsat.analysis.series import run_series
>>> for s in run_series(ds):                       # doctest: +SKIP
...     print(s.name, s.values.dims, s.unit)
attitude_error_formation_deg ('time', 'spacecraft') deg
...

A series the run does not have is not in the list: no such variable (no wheels, no
thrusters, no orbit), a quantity that is not simulated (attitude in a translation-only run,
:func:`coopsat.analysis.metrics.attitude_moves`), or one that is zero (or NaN) at every sample
(an actuator that never acted). Units are SI but for attitude angles, in degrees; unit strings
are written as the figures print them, ``N m``, ``rad/s``, ``1`` for counts.

Pure NumPy on the recorded samples (xarray only to label the values; no matplotlib).
"""

from dataclasses import dataclass

import numpy as np

from coopsat.analysis.metrics import (
    attitude_moves,
    pairwise_attitude_error_deg,
    pairwise_rate_difference_rad_s,
    quat_angle_between_deg,
)


@dataclass(frozen=True)
class Series:
    """One time series of a run.

    Attributes
    ----------
    name : str
        Stable key, unit at the end (``attitude_error_formation_deg``); a figure, a pair file
        and a report refer to the series by it.
    label : str
        What it is, in words, without the unit ("attitude error to the formation's mean").
    unit : str
        Unit of ``values`` as printed on an axis: ``deg``, ``rad/s``, ``N m``, ``N m s``, ``m``,
        ``m/s``, ``N``, ``N s``, ``s``, ``1`` (a count or a ratio).
    values : xarray.DataArray
        Dims ``("time",)``, ``("time", "spacecraft")`` or ``("time", "spacecraft", <component>)``
        with ``<component>`` one of ``component`` (x, y, z), ``wheel``; coordinates as in the
        record.
    log_scale : bool
        A magnitude that may span decades (errors that converge): draw it on a log axis.
    threshold : float or None
        A level the scenario's ``[analysis]`` judges it against (synchronisation thresholds),
        in ``unit``.
    """

    name: str
    label: str
    unit: str
    values: object
    log_scale: bool = False
    threshold: float | None = None


def formation_mean_quaternion(q):
    """The formation's mean attitude: each quaternion signed to the first spacecraft's
    hemisphere (q and −q are one attitude), averaged and normalised (the chordal mean).

    Parameters
    ----------
    q : ndarray, shape (T, n, 4)

    Returns
    -------
    ndarray, shape (T, 4)
    """
    sign = np.where(np.sum(q * q[:, :1], axis=-1, keepdims=True) < 0.0, -1.0, 1.0)
    mean = (sign * q).sum(axis=1)
    return mean / np.linalg.norm(mean, axis=-1, keepdims=True)


def pairwise_angle_difference_deg(angle_rad):
    """Largest ``|θ_i − θ_j|`` over pairs of spacecraft (small-angle model), deg.

    Parameters
    ----------
    angle_rad : ndarray, shape (T, n, 3)

    Returns
    -------
    ndarray, shape (T,)
    """
    return np.degrees(pairwise_rate_difference_rad_s(angle_rad))  # the same pairwise norm, of angles


def _norm(values, dim="component"):
    """Euclidean norm over ``dim``; (T, n, 3) -> (T, n), labels kept."""
    return np.sqrt((values**2).sum(dim))


def _attitude(ds, analysis):
    """(name, label, unit, values, log, threshold) of the attitude and rate series."""
    import xarray as xr  # deferred: the catalogue is used only once a record is in memory

    n = ds.sizes["spacecraft"]
    t, sc = ds["time"], ds["spacecraft"]
    omega = ds["omega"].transpose("time", "spacecraft", "component")
    att_deg = getattr(analysis, "sync_attitude_deg", None)
    rate_rad_s = getattr(analysis, "sync_rate_rad_s", None)
    rows = []
    if "q" in ds:
        q = ds["q"].transpose("time", "spacecraft", "q_component").values
        for ref, name, words in (("q_ref", "attitude_error_reference_deg", "the reference"),
                                 ("q_desired", "attitude_error_desired_deg", "the desired attitude")):
            if ref in ds:
                # q_ref is one attitude for all (time, q_component); q_desired one per spacecraft
                target = ds[ref].broadcast_like(ds["q"]).transpose("time", "spacecraft", "q_component").values
                err = quat_angle_between_deg(q, target)
                rows.append((name, f"attitude error to {words}", "deg",
                             xr.DataArray(err, coords={"time": t, "spacecraft": sc}), True, None))
        if n > 1:
            err = quat_angle_between_deg(q, formation_mean_quaternion(q)[:, None, :])
            rows.append(("attitude_error_formation_deg", "attitude error to the formation's mean", "deg",
                         xr.DataArray(err, coords={"time": t, "spacecraft": sc}), True, None))
            rows.append(("attitude_spread_deg", "largest pairwise attitude error", "deg",
                         xr.DataArray(pairwise_attitude_error_deg(q), coords={"time": t}), True, att_deg))
    else:
        angle = ds["angle"].transpose("time", "spacecraft", "component")
        rows.append(("attitude_angle_deg", "attitude angle", "deg", np.degrees(angle), False, None))
        if n > 1:
            rows.append(("attitude_spread_deg", "largest pairwise angle difference", "deg",
                         xr.DataArray(pairwise_angle_difference_deg(angle.values), coords={"time": t}), True, att_deg))
    rows.append(("rate_rad_s", "body rate", "rad/s", omega, False, None))
    if n > 1:
        rows.append(("rate_spread_rad_s", "largest pairwise rate difference", "rad/s",
                     xr.DataArray(pairwise_rate_difference_rad_s(omega.values), coords={"time": t}), True, rate_rad_s))
    if "rate_error" in ds:
        rows.append(("rate_error_rad_s", "rate error to the desired rate", "rad/s", _norm(ds["rate_error"]), True, None))
    return rows


def _actuators(ds):
    """(name, label, unit, values, log, threshold) of the torque, wheel and thruster series."""
    rows = []
    for var, name, label in (("torque_command", "torque_command_n_m", "commanded torque"),
                             ("torque", "torque_n_m", "applied torque")):
        if var in ds:
            rows.append((name, label, "N m", ds[var].transpose("time", "spacecraft", "component"), False, None))
    if "impulse" in ds:
        rows.append(("effort_n_m_s", "actuator effort Σ∫|τ| dt", "N m s", ds["impulse"].sum("component"), False, None))
    if "wheel_speed" in ds:
        rows.append(("wheel_speed_rad_s", "wheel speed", "rad/s", ds["wheel_speed"].transpose("time", "spacecraft", "wheel"),
                     False, None))
    if "h_wheels" in ds:
        rows.append(("wheel_momentum_n_m_s", "wheel momentum ‖h‖", "N m s", _norm(ds["h_wheels"]), False, None))
    if "thruster_firings" in ds:
        rows.append(("thruster_firings", "thruster firings (cumulative)", "1", ds["thruster_firings"].sum("thruster"),
                     False, None))
    if "thruster_on_time" in ds:
        rows.append(("thruster_on_time_s", "thruster on-time (cumulative)", "s", ds["thruster_on_time"].sum("thruster"),
                     False, None))
    return rows


def _translation(ds):
    """(name, label, unit, values, log, threshold) of the relative motion, force and fuel series."""
    rows = []
    if "r_eci" in ds and ds.sizes["spacecraft"] > 1:
        for var, name, label, unit in (("r_eci", "distance_to_centroid_m", "distance to the formation's centroid", "m"),
                                       ("v_eci", "speed_to_centroid_m_s", "speed relative to the formation's centroid",
                                        "m/s")):
            x = ds[var].transpose("time", "spacecraft", "component")
            rows.append((name, label, unit, _norm(x - x.mean("spacecraft")), False, None))
    for var, name, label in (("force_command", "force_command_n", "commanded force"), ("force", "force_n", "applied force")):
        if var in ds:
            rows.append((name, label, "N", ds[var].transpose("time", "spacecraft", "component"), False, None))
    if "abs_force_impulse" in ds:
        rows.append(("fuel_n_s", "fuel Σ∫|F| dt", "N s", ds["abs_force_impulse"].sum("component"), False, None))
    if "impulse_bits" in ds:
        rows.append(("impulse_bits", "impulse bits fired (cumulative)", "1", ds["impulse_bits"].sum("component"), False, None))
    return rows


def _navigation(ds):
    """(name, label, unit, values, log, threshold) of a navigation filter's error, its claimed
    3σ (position, per LVLH axis) and its NEES, where the run has them."""
    if "nav_error" not in ds:
        return []
    frame = ds["nav_error"].attrs.get("frame", "")
    position = {"nav_state": "component"}
    xyz = {"component": ["x", "y", "z"]}
    error = ds["nav_error"].isel(nav_state=slice(0, 3)).rename(position).assign_coords(xyz)
    sigma = ds["nav_sigma"].isel(nav_state=slice(0, 3)).rename(position).assign_coords(xyz)
    return [
        ("nav_position_error_m", f"navigation estimate minus truth, position ({frame})", "m", error, False, None),
        ("nav_position_3sigma_m", f"navigation filter's 3σ, position ({frame})", "m", 3.0 * sigma, False, None),
        ("nees", "navigation filter's NEES (6 when consistent)", "1", ds["nees"], True, 6.0),
    ]


def run_series(ds, analysis=None):
    """Every time series the run has (module docstring), in a fixed order: attitude, rates,
    actuators, translation.

    Parameters
    ----------
    ds : xarray.Dataset
        Run record (:func:`coopsat.sim.recorder.to_dataset`, or ``result.nc``).
    analysis : object, optional
        The scenario's ``[analysis]`` table; its ``sync_attitude_deg`` and ``sync_rate_rad_s``
        become the thresholds of the pairwise spreads.

    Returns
    -------
    list of Series
        Values zero or NaN at every sample are left out, and so is every attitude and rate
        series of a run whose attitude does not move (:func:`attitude_moves`).
    """
    rows = (_attitude(ds, analysis) if attitude_moves(ds) else []) + _actuators(ds) + _translation(ds) + _navigation(ds)
    series = []
    for name, label, unit, values, log_scale, threshold in rows:
        v = np.asarray(values.values, dtype=float)
        if np.any(np.nan_to_num(v) != 0.0):
            series.append(Series(name, label, unit, values.rename(name).assign_attrs(units=unit, long_name=label),
                                 log_scale, threshold))
    return series


def series_by_name(series):
    """``{name: Series}`` of a catalogue (:func:`run_series`), in its order."""
    return {s.name: s for s in series}
