"""Metrics of a run of the saturated consensus law (the plug-in's ``analysis`` module).

coopsat calls :func:`metrics` after the run and writes its numbers to metrics.json, next to
the metrics every run has (``final_rate_max_rad_s``, each spacecraft's ``_impulse_nms``,
``_on_time_s`` and ``_firings``). The thresholds are this module's own.
"""

import numpy as np

SYNC_ATTITUDE_DEG = 1.0
"""Largest pairwise attitude difference that counts as synchronised, deg."""

SYNC_RATE_RAD_S = 0.005
"""Largest pairwise rate difference that counts as synchronised, rad/s."""

EXPLAINERS = {}
"""No published numbers to explain."""


def pairwise_attitude_error_deg(q):
    """Largest rotation angle between two spacecraft's attitudes at each sample, deg.

    Parameters
    ----------
    q : ndarray (T, n, 4)
        Scalar-first unit quaternions.

    Returns
    -------
    ndarray (T,)
    """
    n = q.shape[1]
    if n < 2:
        return np.zeros(q.shape[0])
    i, j = np.triu_indices(n, k=1)
    dot = np.abs(np.sum(q[:, i] * q[:, j], axis=-1))  # |scalar part of q_j* ⊗ q_i|
    w_j, v_j, w_i, v_i = q[:, j, :1], q[:, j, 1:], q[:, i, :1], q[:, i, 1:]
    vec = np.linalg.norm(w_j * v_i - w_i * v_j - np.cross(v_j, v_i), axis=-1)
    return np.degrees(2.0 * np.arctan2(vec, dot)).max(axis=1)


def pairwise_rate_difference_rad_s(omega):
    """Largest ``|ω_i − ω_j|`` over pairs at each sample, rad/s; (T, n, 3) -> (T,)."""
    n = omega.shape[1]
    if n < 2:
        return np.zeros(omega.shape[0])
    i, j = np.triu_indices(n, k=1)
    return np.linalg.norm(omega[:, i] - omega[:, j], axis=-1).max(axis=1)


def metrics(ds, built):
    """Synchronisation error at the start and the end, its reduction, the synchronisation time,
    and what the cold-gas thrusters did.

    Returns
    -------
    dict of str -> float, int or None
        ``sync_error_initial_deg``, ``sync_error_final_deg``, ``sync_error_reduction``
        (initial / final), ``rate_spread_final_rad_s``, ``sync_time_s`` (first sample after
        which both thresholds hold to the end; None if they do not hold at the end), and with
        cold-gas thrusters ``valve_openings`` and ``commands_below_bit`` (totals over the
        formation).
    """
    t = ds["time"].values
    att = pairwise_attitude_error_deg(ds["q"].values)
    rate = pairwise_rate_difference_rad_s(ds["omega"].values)
    synced = (att < SYNC_ATTITUDE_DEG) & (rate < SYNC_RATE_RAD_S)
    broken = np.flatnonzero(~synced)
    if not synced[-1]:
        sync_time = None
    else:
        sync_time = float(t[0] if broken.size == 0 else t[broken[-1] + 1])
    m = {
        "sync_error_initial_deg": float(att[0]),
        "sync_error_final_deg": float(att[-1]),
        "sync_error_reduction": float(att[0] / att[-1]) if att[-1] > 0 else None,
        "rate_spread_final_rad_s": float(rate[-1]),
        "sync_time_s": sync_time,
    }
    if "commands_below_bit" in ds:
        m["valve_openings"] = int(ds["thruster_firings"].values[-1].sum())
        m["commands_below_bit"] = int(ds["commands_below_bit"].values[-1].sum())
    return m
