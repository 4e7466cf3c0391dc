"""Metrics of a run: synchronisation and tracking times, final errors, thruster use.

Pure NumPy on the recorded samples (a :class:`xarray.Dataset` from
:func:`coopsat.sim.recorder.to_dataset`). Times are resolved to the record interval: a
"settle time" is the first *recorded* instant after which a condition holds at every later
sample, and None (JSON null) when it does not hold at the last sample.
"""

import numpy as np

from coopsat.geometry.quaternion import quat_angle, quat_error, quat_rotate

EXACT_PAIRS_MAX_N = 64
"""Up to this many spacecraft every pair is compared; above it, each one against the first
(the pairwise maximum is then bounded by twice the reported value)."""


def quat_angle_between_deg(q_a, q_b):
    """Rotation angle between attitudes, deg, in [0, 180]; shapes (..., 4) -> (...).

    Notes
    -----
    The angle of the error quaternion ``q_b* ⊗ q_a`` (sign invariant: q and −q are one
    attitude), formed from its vector part rather than ``acos`` of a dot product, which loses
    everything below about 1e-6 deg to rounding.
    """
    return np.degrees(np.asarray(quat_angle(quat_error(q_a, q_b))))


def _pairwise_max(x, distance):
    """Largest ``distance`` over pairs of spacecraft at each sample; x (T, n, k) -> (T,)."""
    n = x.shape[1]
    if n < 2:
        return np.zeros(x.shape[0])
    if n <= EXACT_PAIRS_MAX_N:
        i, j = np.triu_indices(n, k=1)
    else:
        i, j = np.arange(1, n), np.zeros(n - 1, dtype=int)
    return distance(x[:, i], x[:, j]).max(axis=1)


def pairwise_attitude_error_deg(q):
    """Largest attitude difference over pairs of spacecraft at each sample, deg.

    Parameters
    ----------
    q : ndarray, shape (T, n, 4)

    Returns
    -------
    ndarray, shape (T,)
    """
    return _pairwise_max(q, quat_angle_between_deg)


def pairwise_rate_difference_rad_s(omega):
    """Largest ``|ω_i − ω_j|`` (body components, as law (3) compares them) at each sample, rad/s.

    Parameters
    ----------
    omega : ndarray, shape (T, n, 3)

    Returns
    -------
    ndarray, shape (T,)
    """
    return _pairwise_max(omega, lambda a, b: np.linalg.norm(a - b, axis=-1))


def settle_time_s(t_s, ok, hold_s=0.0):
    """First sample time after which ``ok`` holds at every later sample; None if never.

    Parameters
    ----------
    t_s : ndarray, shape (T,)
    ok : ndarray of bool, shape (T,) or (T, k)
        With a second axis, returns one time per column.
    hold_s : float
        The condition must have held for at least this long by the end of the run; a
        condition met only in the last moments is not called settled.

    Returns
    -------
    float or None, or list of those
    """
    ok = np.asarray(ok, dtype=bool)
    if ok.ndim == 2:
        return [settle_time_s(t_s, ok[:, k], hold_s) for k in range(ok.shape[1])]
    if not ok[-1]:
        return None
    bad = np.flatnonzero(~ok)
    settled = float(t_s[0] if bad.size == 0 else t_s[bad[-1] + 1])
    return settled if t_s[-1] - settled >= hold_s else None


def inertial_angular_momentum_nms(q, omega, inertia_kgm2, h_wheels_b_nms=0.0):
    """Total angular momentum of the formation in inertial components, N·m·s.

    Parameters
    ----------
    q : ndarray, shape (T, n, 4)
    omega : ndarray, shape (T, n, 3)
    inertia_kgm2 : ndarray, shape (n, 3, 3)
    h_wheels_b_nms : ndarray, shape (n, 3) or (T, n, 3), optional
        Wheel momentum relative to each body, body components.

    Returns
    -------
    ndarray, shape (T, 3)
        ``Σ_i C(q_i) (I_i ω_i + h_w,i)``. Law (3) pushes on each spacecraft in its own body axes, so it
        does not conserve this exactly, but near agreement its torques nearly cancel: a
        formation that starts with momentum ends spinning together, not at rest.
    """
    h_b = np.einsum("nij,tnj->tni", inertia_kgm2, omega) + h_wheels_b_nms
    return np.asarray(quat_rotate(q, h_b)).sum(axis=1)


def run_metrics(ds, names, analysis, inertia_kgm2, omega_ref_rad_s=None, h_wheels_b_nms=0.0):
    """All metrics of a run as a flat dict of named numbers (unit at the end of each name).

    Parameters
    ----------
    ds : xarray.Dataset
        From :func:`coopsat.sim.recorder.to_dataset` (single run).
    names : sequence of str
        Spacecraft names.
    analysis : coopsat.scenarios.schema.Analysis
        Thresholds.
    inertia_kgm2 : ndarray, shape (n, 3, 3)
    omega_ref_rad_s : array_like (3,), optional
        Reference rate of a tracking run; with ``ds.q_ref`` it enables the tracking metrics.
    h_wheels_b_nms : ndarray, shape (n, 3), optional
        Wheel momentum of each spacecraft (in the formation's angular momentum).

    Returns
    -------
    dict of str -> float, int or None
    """
    t = ds["time"].values
    q = ds["q"].values
    omega = ds["omega"].values
    att = pairwise_attitude_error_deg(q)
    rate = pairwise_rate_difference_rad_s(omega)
    synced = (att < analysis.sync_attitude_deg) & (rate < analysis.sync_rate_rad_s)
    h = inertial_angular_momentum_nms(q, omega, inertia_kgm2, h_wheels_b_nms)
    m = {
        "sync_time_s": settle_time_s(t, synced, analysis.settle_hold_s),
        "final_attitude_spread_deg": float(att[-1]),
        "final_rate_spread_rad_s": float(rate[-1]),
        "final_rate_max_rad_s": float(np.linalg.norm(omega[-1], axis=-1).max()),
        "angular_momentum_initial_nms": float(np.linalg.norm(h[0])),
        "angular_momentum_final_nms": float(np.linalg.norm(h[-1])),
    }
    if "q_ref" in ds and omega_ref_rad_s is not None:
        err_deg = quat_angle_between_deg(q, ds["q_ref"].values[:, None, :])  # (T, n)
        rate_err = np.linalg.norm(omega - np.asarray(omega_ref_rad_s), axis=-1)  # (T, n)
        tracking = (err_deg < analysis.sync_attitude_deg) & (rate_err < analysis.sync_rate_rad_s)
        m["track_time_s"] = settle_time_s(t, tracking.all(axis=1), analysis.settle_hold_s)
        m["final_track_error_deg"] = float(err_deg[-1].max())
        m["final_track_rate_error_rad_s"] = float(rate_err[-1].max())
        for name, ts in zip(names, settle_time_s(t, rate_err < analysis.sync_rate_rad_s, analysis.settle_hold_s)):
            m[f"{name}_rate_settle_time_s"] = ts
    if "impulse" in ds:
        impulse = ds["impulse"].values[-1].sum(axis=-1)
        for name, value in zip(names, impulse):
            m[f"{name}_impulse_nms"] = float(value)
    if "thruster_on_time" in ds:
        on = ds["thruster_on_time"].values[-1].sum(axis=-1)
        for name, value in zip(names, on):
            m[f"{name}_on_time_s"] = float(value)
        for name, value in zip(names, ds["thruster_firings"].values[-1].sum(axis=-1)):
            m[f"{name}_firings"] = int(value)
    return m


def design_metrics(scenario, stability):
    """Numbers known before the run: sampled-data check, PWM dead band, spin-down bounds.

    Parameters
    ----------
    scenario : coopsat.scenarios.schema.Scenario
    stability : coopsat.design.sampled_data.SampledDataStability or None

    Returns
    -------
    dict of str -> float
        ``<name>_min_spin_down_time_s`` is the largest over body axes of
        ``|(I (ω(0) − ω_r))_k| / T_max``: the time the axis's thrusters need, at full thrust, to
        remove the initial excess angular momentum (gyroscopic coupling neglected).
    """
    from coopsat.scenarios.build import inertia_matrix
    from coopsat.scenarios.schema import ConsensusTrack, PwmThrusters

    act, ctrl = scenario.actuators, scenario.controller
    m = {"control_period_s": scenario.control_period_s}
    if isinstance(act, PwmThrusters):
        m["pwm_deadband_torque_nm"] = act.torque_max_nm * act.min_pulse_s / scenario.control_period_s
    if np.isfinite(act.torque_max_nm) and isinstance(ctrl, ConsensusTrack):
        for s in scenario.spacecraft:
            h_excess = inertia_matrix(s.inertia_kgm2) @ (np.asarray(s.omega_b_rad_s) - np.asarray(ctrl.omega_ref_rad_s))
            m[f"{s.name}_min_spin_down_time_s"] = float(np.abs(h_excess).max() / act.torque_max_nm)
    if stability is not None:
        m.update(
            spectral_radius=stability.spectral_radius,
            max_stable_period_s=stability.max_stable_period_s,
            continuous_max_real_1_s=stability.continuous_max_real,
        )
    return m
