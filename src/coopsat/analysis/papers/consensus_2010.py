"""The 2010 consensus paper's metrics and explanations (SPEC §1).

Synchronisation: the largest pairwise attitude and rate differences and the time after which
both stay below the ``[analysis]`` thresholds. Tracking: the error to the reference, the time
all spacecraft stay on it, and each spacecraft's rate settle time. Design-time: each
spacecraft's thrust-limited spin-down bound. Explanations: why law (3) need not end at rest,
the PWM dead band, the spin-down bound.
"""

import numpy as np

from coopsat.analysis.metrics import (
    pairwise_attitude_error_deg,
    pairwise_rate_difference_rad_s,
    quat_angle_between_deg,
    run_rows,
    settle_times_s,
)
from coopsat.analysis.surrogates import Surrogate, settled_by, time_weighted_error
from coopsat.scenarios.build import inertia_matrix


def spin_axes(scenario, omega_ref):
    """Each spacecraft's initial excess spin: the unit axis ê of ``ω(0) − ω_r`` (body) and its
    size ``|ω(0) − ω_r|``, rad/s; ê is zero where there is no excess. Shapes (n, 3), (n,)."""
    excess = np.array([s.omega_b_rad_s for s in scenario.spacecraft], dtype=float) - omega_ref
    size = np.linalg.norm(excess, axis=1)
    return np.divide(excess, size[:, None], out=np.zeros_like(excess), where=size[:, None] > 0), size


def _spin_down_bounds(scenario, omega_ref):
    """``<name>_min_spin_down_time_s``: the thrust-limited bound for the spin-down time's own
    definition (the excess spin along ê brought from its initial size down to the threshold):
    ``I_ê (|ω(0) − ω_r| − threshold) / (T_max Σ_k |ê_k|)``, with ``I_ê = êᵀ I ê`` and the
    largest torque along ê that ±T_max per body axis can give. Assumptions: every thruster at
    full torque for the whole time, no gyroscopic coupling (exact for a spin about a principal
    axis). Only for one saturated torque actuator; 0 when the spin starts below the threshold."""
    acts = scenario.actuator_list
    torque_max = getattr(acts[0], "torque_max_nm", np.inf) if len(acts) == 1 else np.inf
    if not np.isfinite(torque_max):
        return {}
    axes, size = spin_axes(scenario, omega_ref)
    threshold = scenario.analysis.spin_rate_rad_s
    out = {}
    for s, e, w in zip(scenario.spacecraft, axes, size):
        i_e = float(e @ inertia_matrix(s.inertia_kgm2) @ e)
        authority = torque_max * float(np.abs(e).sum())
        out[f"{s.name}_min_spin_down_time_s"] = max(0.0, i_e * (w - threshold) / authority) if authority > 0 else 0.0
    return out


def metrics(ds, built):
    """Synchronisation and (for law (4)) tracking metrics of a run (:func:`batch_metrics` of a
    batch of one).

    Returns
    -------
    dict of str -> float or None
    """
    return run_rows(batch_metrics(ds.expand_dims("run"), [built]), 1)[0]


def batch_metrics(ds, builds):
    """:func:`metrics` of every run of a batch at once.

    Parameters
    ----------
    ds : xarray.Dataset
        The batch's record, dimension ``run`` first.
    builds : sequence of Built
        Each run's build (its thresholds, reference and initial spin are its own).

    Returns
    -------
    dict of str -> ndarray, shape (R,)
        NaN for a time never reached.
    """
    analysis = [b.scenario.analysis for b in builds]
    sync_deg, sync_rate, spin_rate, hold = (np.array([getattr(a, f) for a in analysis], dtype=float) for f in
                                            ("sync_attitude_deg", "sync_rate_rad_s", "spin_rate_rad_s", "settle_hold_s"))
    t = ds["time"].values
    q = ds["q"].values  # (R, T, n, 4)
    omega = ds["omega"].values  # (R, T, n, 3)
    att = pairwise_attitude_error_deg(q)  # (R, T)
    rate = pairwise_rate_difference_rad_s(omega)
    synced = (att < sync_deg[:, None]) & (rate < sync_rate[:, None])
    m = {
        "sync_time_s": settle_times_s(t, synced, hold, axis=1),
        "final_attitude_spread_deg": att[:, -1],
        "final_rate_spread_rad_s": rate[:, -1],
    }
    if builds[0].scenario.controller.kind != "consensus-track":  # the law is the batch's structure
        return m
    omega_ref = np.array([b.scenario.controller.omega_ref_rad_s for b in builds], dtype=float)  # (R, 3)
    err_deg = quat_angle_between_deg(q, ds["q_ref"].values[:, :, None, :])  # (R, T, n)
    rate_err = np.linalg.norm(omega - omega_ref[:, None, None, :], axis=-1)  # (R, T, n)
    tracking = (err_deg < sync_deg[:, None, None]) & (rate_err < sync_rate[:, None, None])
    m["track_time_s"] = settle_times_s(t, tracking.all(axis=-1), hold, axis=1)
    m["final_track_error_deg"] = err_deg[:, -1].max(axis=-1)
    m["final_track_rate_error_rad_s"] = rate_err[:, -1].max(axis=-1)
    names = builds[0].names
    settle = settle_times_s(t, rate_err < sync_rate[:, None, None], hold[:, None], axis=1)  # (R, n)
    m.update({f"{name}_rate_settle_time_s": settle[:, i] for i, name in enumerate(names)})
    # The spin itself: the excess rate along each spacecraft's initial spin axis.
    axes = np.stack([spin_axes(b.scenario, w)[0] for b, w in zip(builds, omega_ref)])  # (R, n, 3)
    spin = np.abs(np.einsum("rtni,rni->rtn", omega - omega_ref[:, None, None, :], axes))  # (R, T, n)
    spun = settle_times_s(t, spin < spin_rate[:, None, None], hold[:, None], axis=1)
    m.update({f"{name}_spin_down_time_s": spun[:, i] for i, name in enumerate(names)})
    bounds = [_spin_down_bounds(b.scenario, w) for b, w in zip(builds, omega_ref)]
    m.update({k: np.array([b[k] for b in bounds]) for k in bounds[0]})
    return m


def _rest_explanation(quantity, metrics):
    """Why law (3) need not end at rest: it damps only rate differences."""
    h0, hf = metrics.get("angular_momentum_initial_nms"), metrics.get("angular_momentum_final_nms")
    if h0 is None or hf is None:
        return None
    return (
        "law (3) damps only rate differences: once attitudes and rates agree its torque is zero whatever the "
        "common rate, so a common spin about a shared principal axis is an equilibrium and nothing brings the "
        f"formation to rest (inertial angular momentum {h0:.3g} N·m·s at the start, {hf:.3g} N·m·s at the end)"
    )


def _deadband_explanation(quantity, metrics):
    """A PWM minimum pulse leaves small commands unexecuted: errors stall instead of vanishing."""
    deadband = metrics.get("pwm_deadband_torque_nm")
    if deadband is None or metrics.get(quantity) is not None or metrics.get("spectral_radius", 0.0) >= 1.0:
        return None  # an unstable loop is explanation enough; the dead band is not the cause
    spread = metrics.get("final_attitude_spread_deg")
    tail = f"; the attitude spread ends at {spread:.3g} deg" if spread is not None else ""
    return (
        f"PWM commands below T_max·τ/T = {deadband:.3g} N·m are not executed (minimum pulse), so the loop stops "
        f"correcting small errors{tail}"
    )


def _spin_down_explanation(quantity, metrics):
    """The thrusters' authority bounds how fast a spin can be removed."""
    stem = quantity.removesuffix("_rate_settle_time_s").removesuffix("_spin_down_time_s")
    bound = metrics.get(f"{stem}_min_spin_down_time_s")
    if bound is None:
        return None
    spin = metrics.get(f"{stem}_spin_down_time_s")
    tail = f"; the spin itself is down at {spin:.4g} s (the rest is the slower tracking)" if (
        quantity.endswith("_rate_settle_time_s") and spin is not None) else ""
    return (
        f"at full thrust the spin cannot be brought down in less than {bound:.3g} s "
        f"(I_ê·(|Δω| − threshold)/(T_max Σ|ê_k|), gyroscopic coupling neglected){tail}"
    )


EXPLAINERS = {
    "final_rate_max_rad_s": _rest_explanation,
    "sync_time_s": _deadband_explanation,
    "track_time_s": _deadband_explanation,
    "_rate_settle_time_s": _spin_down_explanation,
    "_spin_down_time_s": _spin_down_explanation,
}
"""Explanations of a difference, by metric name or name suffix."""


def _sync_error(samples, built):
    """The synchronisation test's largest ratio to its tolerance at each sample, (T,) (JAX):
    ``max(pairwise attitude error / sync_attitude_deg, pairwise rate difference /
    sync_rate_rad_s)``; < 1 is synchronised (as :func:`metrics` counts it)."""
    import jax.numpy as jnp

    from coopsat.analysis.metrics import EXACT_PAIRS_MAX_N
    from coopsat.geometry.quaternion import quat_error

    a = built.scenario.analysis
    q, omega = samples["q"], samples["omega"]
    n = q.shape[1]
    if n <= EXACT_PAIRS_MAX_N:
        i, j = np.triu_indices(n, k=1)
    else:
        i, j = np.arange(1, n), np.zeros(n - 1, dtype=int)
    qe = quat_error(q[:, i], q[:, j])
    # The angle 2·atan2(|vec|, |q0|), with |vec| smoothed at 0 so that its gradient stays finite.
    angle = 2.0 * jnp.arctan2(jnp.sqrt(jnp.sum(qe[..., 1:] ** 2, axis=-1) + 1e-30), jnp.abs(qe[..., 0]))
    rate = jnp.sqrt(jnp.sum((omega[:, i] - omega[:, j]) ** 2, axis=-1) + 1e-30)
    return jnp.maximum(jnp.max(angle, axis=-1) / np.radians(a.sync_attitude_deg), jnp.max(rate, axis=-1) / a.sync_rate_rad_s)


SURROGATES = {
    "sync_time_s": Surrogate(
        lambda s, t, b, sys: time_weighted_error(t, _sync_error(s, b)),
        lambda s, t, b, sys, bound: settled_by(t, _sync_error(s, b), bound),
        "objective: ∫t·e(t)dt/∫t dt (ITAE) of e = max(attitude spread / sync_attitude_deg, rate spread / sync_rate_rad_s); "
        "constraint: log-sum-exp of e over the samples at or after the bound, ≤ 1",
    ),
}
