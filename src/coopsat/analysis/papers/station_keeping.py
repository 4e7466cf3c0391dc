"""Formation keeping in orbit (``lvlh-pd``, ``lvlh-consensus``): truth slot errors and fuel.

Every error is a truth error: each spacecraft's true position relative to the first spacecraft,
in the first's LVLH frame (:func:`coopsat.geometry.frames.eci_to_lvlh` of the ECI truth), minus
where the law wants it (the part's ``targets_lvlh()``: the offset from the chief for
``lvlh-pd``; ``R_0 (δ_i − δ_0)`` for ``lvlh-consensus``). The series ``slot_error_lvlh`` holds it
at every sample (x along-track, y against the orbit normal, z to nadir).

* ``slot_error_along_track_max_m``, ``slot_error_cross_track_max_m``,
  ``slot_error_radial_max_m``: the largest |error| on each axis over the spacecraft and the
  judged window, the second half of the time after the law starts (``start_s``): the first half
  is left to the capture of a free-drift start. None (JSON null) for a run that ends before the
  law starts.
* ``delta_v_m_s_<name>``: ``Σ_axes ∫|F| dt / m`` over the run, per spacecraft (what per-axis
  thrusters spend).
* ``delta_v_per_day_max_m_s``, ``delta_v_per_day_mean_m_s``: the rate over the run's last day
  (the whole time after the start when that is shorter), scaled to a day; the largest, and the
  mean over the spacecraft that fire.
"""

import numpy as np

from coopsat.analysis.papers.low_orbit import lvlh_series, relative_position_lvlh

FIGURES = "coopsat.plots.station_keeping"
"""Module with the slot-error and fuel figures."""

DAY_S = 86400.0


def slot_errors_lvlh(r_eci, v_eci, targets_lvlh):
    """Truth slot errors, (T, n, 3) m, relative to the first spacecraft, in its LVLH frame.

    Parameters
    ----------
    r_eci, v_eci : (T, n, 3)
        Truth positions (m) and velocities (m/s), ECI.
    targets_lvlh : (n, 3)
        Where each spacecraft should be relative to the first, its LVLH frame, m.
    """
    return relative_position_lvlh(r_eci, v_eci) - targets_lvlh[None]


def _start_s(built):
    return float(built.system.controller.start_s)


def judged(t_s, start_s):
    """The samples of the judged window: the second half of the time after ``start_s``."""
    return t_s >= start_s + 0.5 * (t_s[-1] - start_s)


def delta_v_rate_per_day(t_s, abs_impulse_ns, masses_kg, start_s):
    """Each spacecraft's ``Σ_axes ∫|F| dt / m`` over the last day (or since ``start_s`` when
    shorter), per day, m/s, (n,).

    Parameters
    ----------
    t_s : (T,)
    abs_impulse_ns : (T, n, 3)
        Cumulative ``∫|F| dt`` per axis, N·s.
    masses_kg : (n,)
    start_s : float
    """
    window = min(DAY_S, t_s[-1] - start_s)
    if window <= 0.0:
        return np.zeros(abs_impulse_ns.shape[1])
    k = int(np.searchsorted(t_s, t_s[-1] - window, side="left"))
    spent = (abs_impulse_ns[-1] - abs_impulse_ns[k]).sum(axis=-1) / masses_kg
    return spent * DAY_S / (t_s[-1] - t_s[k])


def series(ds, built):
    """``slot_error_lvlh`` (time, spacecraft, component), m."""
    err = slot_errors_lvlh(ds["r_eci"].values, ds["v_eci"].values, built.system.controller.targets_lvlh())
    return {"slot_error_lvlh": lvlh_series(err, "true position relative to the first spacecraft minus the slot")}


def metrics(ds, built):
    t = ds["time"].values
    start = _start_s(built)
    err = ds["slot_error_lvlh"].values if "slot_error_lvlh" in ds else series(ds, built)["slot_error_lvlh"].values
    window = np.abs(err[judged(t, start) & (t >= start)])
    m = {
        f"slot_error_{axis}_max_m": float(window[..., c].max()) if window.size else None
        for c, axis in enumerate(("along_track", "cross_track", "radial"))
    }
    if "abs_force_impulse" in ds:
        masses = np.array([sc.mass_kg for sc in built.scenario.spacecraft], dtype=float)
        spent = ds["abs_force_impulse"].values
        for name, dv in zip(built.names, spent[-1].sum(axis=-1) / masses):
            m[f"delta_v_m_s_{name}"] = float(dv)
        rate = delta_v_rate_per_day(t, spent, masses, start)
        m["delta_v_per_day_max_m_s"] = float(rate.max())
        m["delta_v_per_day_mean_m_s"] = float(rate[rate > 0].mean()) if np.any(rate > 0) else 0.0
    return m
