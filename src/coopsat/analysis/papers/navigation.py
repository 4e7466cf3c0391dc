"""Navigation consistency (``[navigation]``): each spacecraft's estimate against the truth, as an
engineer checks a Kalman filter.

At every sample, spacecraft i's estimate ``x̂`` (``nav_estimate_lvlh`` of a relative filter,
``nav_estimate_eci`` of an orbit filter) and covariance ``P`` (``nav_covariance_*``) are compared
with the truth of what it estimates (the filter's ``true_state`` of the recorded ECI states: the
state relative to the chief in the chief's LVLH frame, or the ECI state itself):

* ``nav_error`` (series): ``x̂ − x`` (m, m/s; the estimate's frame in its ``frame`` attribute);
  ``nav_sigma``: ``√diag P``.
* ``nees`` (series): ``(x̂ − x)ᵀ P⁻¹ (x̂ − x)``, χ²(6) for a consistent filter; NaN for the chief.
* ``nees_mean``: its mean over the judged spacecraft and the samples after the first (the first
  is the drawn initial error); ``nees_bound_low``, ``nees_bound_high``: the two-sided 95 % band
  of that mean, ``χ²_{6N}(0.025, 0.975) / N``, with N the number of *independent* values it
  averages, ``nees_effective_samples``: successive errors of one filter correlate, so each
  spacecraft's series counts ``T / τ`` values, τ its integrated autocorrelation time (Sokal's
  window; :func:`effective_count`). Counting every sample as independent would give a band
  several times too narrow. ``nees_consistent``: the mean inside the band.
* ``nis_mean_gnss`` / ``nis_mean_isl``: the mean normalised innovation squared over the updates
  recorded (χ²(6) / χ²(2)), with their 95 % bands ``nis_bound_*_{low,high}``.
* ``nav_position_error_rms_m``, ``nav_velocity_error_rms_m_s``: the RMS estimate error over the
  deputies and samples; ``nav_position_sigma_mean_m``: the filter's mean claimed position σ.

Across a campaign the run means average again: a run's ``nees_mean`` times its N is χ²(6N).
"""

import numpy as np

FIGURES = "coopsat.plots.navigation"
"""Module with the estimate-error and consistency figures."""

_DOF = {"gnss": 6, "isl": 2, "bearing": 2}


def nees(error, covariance):
    """``eᵀ P⁻¹ e`` for errors (..., 6) and covariances (..., 6, 6)."""
    return np.einsum("...i,...i->...", error, np.linalg.solve(covariance, error[..., None])[..., 0])


def effective_count(values):
    """Independent samples a correlated series is worth, ``T / τ`` with
    ``τ = 1 + 2 Σ_{k=1}^{W} ρ_k`` (ρ the sample autocorrelation; W the first lag with
    ``W ≥ 5 τ(W)``, Sokal's automatic window), in ``[1, T]``.

    Parameters
    ----------
    values : (T,)
    """
    x = np.asarray(values, dtype=float) - np.mean(values)
    t = x.size
    if t < 2 or not np.any(x):
        return float(t)
    spectrum = np.fft.rfft(x, 2 * t)
    acf = np.fft.irfft(spectrum * np.conj(spectrum))[:t]
    rho = acf / acf[0]
    tau = 1.0 + 2.0 * np.cumsum(rho[1:])
    window = np.arange(1, t)
    stop = np.flatnonzero(window >= 5.0 * tau)
    tau_int = tau[stop[0]] if stop.size else tau[-1]
    return float(np.clip(t / max(tau_int, 1.0), 1.0, t))


def chi2_band(dof, count, level=0.95):
    """The two-sided ``level`` band of the mean of ``count`` independent χ²(``dof``) values
    (``count`` may be fractional: an effective number)."""
    from scipy.stats import chi2

    tail = 0.5 * (1.0 - level)
    return chi2.ppf(tail, dof * count) / count, chi2.ppf(1.0 - tail, dof * count) / count


def _judged(built):
    """The filter, and the spacecraft whose estimates it judges (not the chief of a relative
    filter) and those it does not."""
    nav = built.system.controller.navigation
    judged = np.array(nav.estimated(len(built.names)), dtype=int)
    return nav, judged, np.setdiff1d(np.arange(len(built.names)), judged)


def recorded(ds):
    """The names of the filter's recorded estimate and covariance (``nav_estimate_<frame>``)."""
    estimate = next(k for k in ds.data_vars if str(k).startswith("nav_estimate_"))
    return estimate, estimate.replace("nav_estimate_", "nav_covariance_")


def series(ds, built):
    """``nav_error``, ``nav_sigma`` (time, spacecraft, nav_state) and ``nees`` (time,
    spacecraft), NaN for a spacecraft the filter does not judge (the chief of a relative filter)."""
    import xarray as xr

    nav, deputies, others = _judged(built)
    estimate, covariance = recorded(ds)
    frame = ds[estimate].attrs.get("frame", "")
    truth = nav.true_state(ds["r_eci"].values, ds["v_eci"].values)
    error = ds[estimate].values - truth
    cov = ds[covariance].values
    sigma = np.sqrt(np.clip(np.diagonal(cov, axis1=-2, axis2=-1), 0.0, None))
    value = np.full(error.shape[:2], np.nan)
    value[:, deputies] = nees(error[:, deputies], cov[:, deputies])
    error[:, others] = np.nan
    sigma[:, others] = np.nan
    dims = ("time", "spacecraft", "nav_state")
    return {
        "nav_error": xr.DataArray(error, dims=dims, attrs={
            "units": "m, m/s", "frame": frame, "long_name": f"navigation estimate minus truth ({frame})"}),
        "nav_sigma": xr.DataArray(sigma, dims=dims, attrs={
            "units": "m, m/s", "frame": frame,
            "long_name": "standard deviation the navigation filter claims (square root of its covariance's diagonal)"}),
        "nees": xr.DataArray(value, dims=("time", "spacecraft"), attrs={
            "units": "1", "long_name": "normalised estimation error squared (chi-square with 6 dof when consistent)"}),
    }


def series_of(ds, built):
    """``nav_error``, ``nav_sigma`` and ``nees`` as the record holds them, or as :func:`series`
    computes them for a record that does not."""
    return {k: ds[k] for k in ("nav_error", "nav_sigma", "nees")} if "nees" in ds else series(ds, built)


def metrics(ds, built):
    _, deputies, _ = _judged(built)
    have = series_of(ds, built)
    values = have["nees"].values[1:, deputies]
    err = have["nav_error"].values[:, deputies]
    m = {"nees_mean": float(values.mean())}
    count = sum(effective_count(values[:, k]) for k in range(values.shape[1]))
    m["nees_effective_samples"] = count
    m["nees_bound_low"], m["nees_bound_high"] = (float(b) for b in chi2_band(6, count))
    m["nees_consistent"] = bool(m["nees_bound_low"] <= m["nees_mean"] <= m["nees_bound_high"])
    m["nav_position_error_rms_m"] = float(np.sqrt(np.mean(np.sum(err[..., :3] ** 2, axis=-1))))
    m["nav_velocity_error_rms_m_s"] = float(np.sqrt(np.mean(np.sum(err[..., 3:] ** 2, axis=-1))))
    m["nav_position_sigma_mean_m"] = float(np.mean(np.linalg.norm(have["nav_sigma"].values[:, deputies, :3], axis=-1)))
    for k, name in enumerate(str(m) for m in ds["nav_updated"].coords["nav_measurement"].values):
        used = ds["nav_updated"].values[:, deputies, k] > 0.0
        if used.any():
            m[f"nis_mean_{name}"] = float(ds["nav_nis"].values[:, deputies, k][used].mean())
            m[f"nis_bound_{name}_low"], m[f"nis_bound_{name}_high"] = (float(b) for b in chi2_band(_DOF[name], int(used.sum())))
    return m
