"""The cooperative Earth-observation paper (SPEC §5, seed 004): staring errors, the image-plane
position of the target in each camera, and the pair's relative error.

Every error is a truth error, from the true attitude ``q`` and the desired attitude the flight
software recorded (``q_desired``, computed from the true orbit: the runs have no navigation
noise), or from the true line of sight (``target_los``):

* ``attitude_error`` — angle of ``δq = q_d* ⊗ q``; ``rate_error`` — ``ω − C(δq)ᵀ ω_d``;
* ``pointing_error`` — angle between the camera axis (+z) and the line of sight;
* ``image_position`` — where the target falls in the camera, ``(b_x/b_z, b_y/b_z)`` with ``b``
  the line of sight in body axes (tangent-plane coordinates, rad at small angles; the paper's
  ν, ζ of eqs. 15–16 describe the same point);
* for every spacecraft but the reference: ``relative_attitude_error`` — angle of
  ``δq_fr = δq_r* ⊗ δq_f`` (the paper's ΔQ_fr), and ``image_mismatch`` — the distance between
  its image position and the reference's, while both stare.

Metrics (the paper's Figs. 5, 8, 9):

* ``stare_start_s_<sc>``: the first sample at which the software stares; the *pass* runs from
  then until it stops staring (the target sets below ``min_elevation_deg``) or the run ends;
* ``switch_convergence_s_<sc>``: from the stare's start until the attitude error stays below
  ``analysis.pointing_converged_deg`` to the end of the pass (``settle_hold_s`` held);
* ``steady_attitude_error_max_deg_<sc>`` in the steady window of the pass (from five time
  constants of law 8, ``10 J_max / k2``, after convergence, so no tail of the switch counts),
  the time it happens (``..._time_s_<sc>``) and the overflight time (largest elevation,
  ``overflight_s_<sc>``);
* ``relative_attitude_error_max_deg`` / ``_rms_deg`` and ``image_mismatch_max_deg`` in the
  steady window after every spacecraft converged (the follower's against the reference; the
  worst follower), and ``relative_attitude_error_switch_max_deg`` from the first stare to
  convergence, while both stare;
* what saturates: ``torque_saturated_fraction_<sc>`` (samples whose torque command sits at
  ``torque_max_nm`` on some axis), ``wheel_speed_max_fraction_<sc>`` (largest wheel speed over
  its limit), ``wheel_speed_limit_s_<sc>`` (when a wheel first reaches 99 % of it) and
  ``wheel_speed_limited_time_s_<sc>`` (the longest any one wheel was held at its rated speed,
  its drive cutting the torque that would have taken it further: the run's
  ``wheel_speed_limited_time``).

A number the run does not define (no stare, no convergence) is None.
"""

import numpy as np

from coopsat.analysis.metrics import settle_time_s
from coopsat.geometry.quaternion import quat_angle, quat_conjugate, quat_error, quat_positive, quat_rotate

FIGURES = "coopsat.plots.observation"
"""Module with this paper's figures (Figs. 5–9)."""

_Z = np.array([0.0, 0.0, 1.0])


def _np(x):
    return np.asarray(x)


def attitude_errors(q, q_desired, omega, omega_desired):
    """``δq`` (…, 4), its angle (…) rad, and the rate error (…, 3) rad/s."""
    dq = _np(quat_positive(quat_error(q, q_desired)))
    rate = omega - _np(quat_rotate(quat_conjugate(dq), omega_desired))
    return dq, _np(quat_angle(dq)), rate


def image_position(q, los_eci):
    """Where the target falls in the camera: ``(b_x/b_z, b_y/b_z)`` of the body-frame line of
    sight; (…, 4), (…, 3) -> (…, 2). NaN where the target is not in front of the camera plane
    (``b_z = 0``: no image point)."""
    b = _np(quat_rotate(quat_conjugate(q), los_eci))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(b[..., 2:3] > 0.0, b[..., :2] / b[..., 2:3], np.nan)


def pointing_error_rad(q, los_eci):
    """Angle between the camera axis (+z) and the line of sight, rad."""
    z_eci = _np(quat_rotate(q, np.broadcast_to(_Z, los_eci.shape)))
    return np.arctan2(np.linalg.norm(np.cross(z_eci, los_eci), axis=-1), np.sum(z_eci * los_eci, axis=-1))


def _reference(built):
    return int(built.system.controller.reference)


def series(ds, built):
    """The derived time series written into result.nc (dims ``time, spacecraft[, …]``)."""
    import xarray as xr

    q, qd = ds["q"].values, ds["q_desired"].values
    los = ds["target_los"].values
    dq, angle, rate = attitude_errors(q, qd, ds["omega"].values, ds["omega_desired"].values)
    image = image_position(q, los)
    ref = _reference(built)
    # Defined for the followers while they and the reference stare (NaN for the reference itself).
    both = (ds["staring"].values > 0.5) & (ds["staring"].values[:, [ref]] > 0.5) & (np.arange(q.shape[1]) != ref)
    rel = _np(quat_angle(quat_error(dq, dq[:, [ref]])))
    mismatch = np.linalg.norm(image - image[:, [ref]], axis=-1)
    dims = ("time", "spacecraft")

    def var(values, units, name, extra=()):
        return xr.DataArray(values, dims=dims + extra, attrs={"units": units, "long_name": name})

    return {
        "attitude_error": var(angle, "rad", "angle of the true attitude error q_d* ⊗ q"),
        "rate_error": var(rate, "rad/s", "true rate error ω − C(δq)ᵀ ω_d, body", ("component",)),
        "pointing_error": var(pointing_error_rad(q, los), "rad", "angle between the camera axis (+z) and the target"),
        "image_position": var(image, "1", "target in the camera: (b_x/b_z, b_y/b_z) of the body line of sight",
                              ("image_axis",)),
        "relative_attitude_error": var(np.where(both, rel, np.nan), "rad",
                                       "angle of δq_r* ⊗ δq_f against the reference, while both stare"),
        "image_mismatch": var(np.where(both, mismatch, np.nan), "1",
                              "distance from the reference's image position, while both stare"),
    }


def _pass(flags):
    """Boolean mask of the first contiguous run of ``flags`` (the first staring pass), or None."""
    idx = np.flatnonzero(flags)
    if not idx.size:
        return None
    gaps = np.flatnonzero(~flags[idx[0]:])
    end = idx[0] + (gaps[0] if gaps.size else flags.size - idx[0])
    mask = np.zeros_like(flags)
    mask[idx[0]:end] = True
    return mask


def _settle_s(built):
    """Five time constants of law 8's slowest mode, ``5 · 2 J_max / k2``, s: the steady window
    starts this long after convergence, so it holds no tail of the switch (the linearised law
    decays as ``exp(−k2 t / 2J)``)."""
    moments = np.linalg.eigvalsh(built.context.inertia_kgm2)
    return 10.0 * float(moments.max()) / built.scenario.controller.k2


_PER_SPACECRAFT = (
    "stare_start_s", "switch_convergence_s", "overflight_s", "steady_attitude_error_max_deg",
    "steady_attitude_error_max_time_s", "steady_attitude_error_rms_deg", "steady_pointing_error_max_deg",
    "torque_saturated_fraction", "wheel_speed_max_fraction", "wheel_speed_limit_s", "wheel_speed_limited_time_s",
)
_PAIR = (
    "relative_attitude_error_max_deg", "relative_attitude_error_rms_deg", "image_mismatch_max_deg",
    "relative_attitude_error_switch_max_deg",
)


def metrics(ds, built):
    """The paper's numbers of one run (module docstring); a number the run does not define
    (no stare, no convergence) is None."""
    a = built.scenario.analysis
    t = ds["time"].values
    staring = ds["staring"].values > 0.5
    angle = ds["attitude_error"].values
    limit = np.radians(a.pointing_converged_deg)
    m = {f"{key}_{name}": None for name in built.names for key in _PER_SPACECRAFT}
    m.update(dict.fromkeys(_PAIR))
    m.update(_saturation(ds, built))
    converged_at, passes = [], []
    for k, name in enumerate(built.names):
        window = _pass(staring[:, k])
        passes.append(window)
        converged_at.append(None)
        if window is None:
            continue
        start = float(t[window][0])
        m[f"stare_start_s_{name}"] = start
        m[f"overflight_s_{name}"] = float(t[np.argmax(ds["target_elevation"].values[:, k])])
        done = settle_time_s(t[window], angle[window, k] < limit, a.settle_hold_s)
        if done is None:
            continue
        converged_at[k] = done
        m[f"switch_convergence_s_{name}"] = done - start
        after = window & (t >= done + _settle_s(built))
        if after.any():
            worst = np.argmax(np.where(after, angle[:, k], -1.0))
            m[f"steady_attitude_error_max_deg_{name}"] = float(np.degrees(angle[worst, k]))
            m[f"steady_attitude_error_max_time_s_{name}"] = float(t[worst])
            m[f"steady_attitude_error_rms_deg_{name}"] = float(np.degrees(np.sqrt(np.mean(angle[after, k] ** 2))))
            m[f"steady_pointing_error_max_deg_{name}"] = float(np.degrees(ds["pointing_error"].values[after, k].max()))
    m.update(_pair_metrics(ds, built, converged_at, passes))
    return m


def _saturation(ds, built):
    """What saturates: the fraction of samples whose torque command sits at the software's clip
    on some axis, each spacecraft's largest wheel speed as a fraction of its limit, when a
    wheel first reaches 99 % of its limit, and how long a drive held a wheel at it."""
    controller = built.scenario.controller
    clipped = np.abs(ds["torque_command"].values) >= controller.torque_max_nm * (1.0 - 1e-9)
    m = {f"torque_saturated_fraction_{name}": float(clipped[:, k].any(axis=-1).mean()) for k, name in enumerate(built.names)}
    wheels = next((a for a in built.scenario.actuator_list if a.kind == "reaction-wheels"), None)
    if wheels is None or "wheel_speed" not in ds:
        return m
    limit = np.broadcast_to(np.asarray(wheels.max_speed_rpm, dtype=float) * np.pi / 30.0, ds["wheel_speed"].shape[-1:])
    fraction = np.abs(ds["wheel_speed"].values) / limit
    t = ds["time"].values
    for k, name in enumerate(built.names):
        m[f"wheel_speed_max_fraction_{name}"] = float(fraction[:, k].max())
        at_limit = np.flatnonzero(fraction[:, k].max(axis=-1) >= 0.99)
        m[f"wheel_speed_limit_s_{name}"] = float(t[at_limit[0]]) if at_limit.size else None
        m[f"wheel_speed_limited_time_s_{name}"] = float(ds["wheel_speed_limited_time"].values[-1, k].max())
    return m


def _pair_metrics(ds, built, converged_at, passes):
    ref = _reference(built)
    followers = [k for k in range(len(built.names)) if k != ref]
    if not followers or any(c is None for c in converged_at):
        return {}  # the keys stay None
    t = ds["time"].values
    rel = ds["relative_attitude_error"].values[:, followers]
    mismatch = ds["image_mismatch"].values[:, followers]
    all_stare = np.logical_and.reduce(passes)
    after = all_stare & (t >= max(converged_at) + _settle_s(built))
    if not after.any():
        return {}
    switch = np.logical_or.reduce(passes) & (t < max(converged_at))
    deg = np.degrees
    return {
        "relative_attitude_error_max_deg": float(deg(np.nanmax(rel[after]))),
        "relative_attitude_error_rms_deg": float(deg(np.sqrt(np.nanmean(rel[after] ** 2)))),
        "image_mismatch_max_deg": float(deg(np.nanmax(mismatch[after]))),
        "relative_attitude_error_switch_max_deg": float(deg(np.nanmax(rel[switch]))) if np.any(
            np.isfinite(rel[switch])) else None,
    }


def _relative_explanation(quantity, m):
    rms = m.get("relative_attitude_error_rms_deg")
    if rms is None:
        return None
    return (
        f"ours {m['relative_attitude_error_max_deg']:.4f}° max, {rms:.4f}° RMS: the relative error of two spacecraft is "
        "set by both star trackers' noise and both loops' response to it, which cooperation cannot remove (the follower "
        "tracks the reference's *measured* error); docs/papers/observation-2019.md derives the linearised budget"
    )


EXPLAINERS = {"relative_attitude_error_max_deg": _relative_explanation}
"""Explanations of a difference, by metric name."""

PAIRED_SERIES = ("relative_attitude_error", "image_mismatch", "attitude_error")
"""Series ``coopsat pair`` compares over time (B − A per seed)."""
