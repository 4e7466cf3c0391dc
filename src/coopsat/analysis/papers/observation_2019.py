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

* ``stare_start_s_<sc>``: the first sample at which the software stares;
* ``switch_convergence_s_<sc>``: from then until the attitude error stays below
  ``analysis.pointing_converged_deg`` to the end of the run (``settle_hold_s`` held);
* ``steady_attitude_error_max_deg_<sc>`` after convergence, the time it happens
  (``..._time_s_<sc>``) and the overflight time (largest elevation, ``overflight_s_<sc>``);
* ``relative_attitude_error_max_deg`` / ``_rms_deg`` and ``image_mismatch_max_deg`` after every
  spacecraft converged (the follower's against the reference; the worst follower), and
  ``relative_attitude_error_switch_max_deg`` from the first stare to convergence.
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
    sight; (…, 4), (…, 3) -> (…, 2)."""
    b = _np(quat_rotate(quat_conjugate(q), los_eci))
    return b[..., :2] / b[..., 2:3]


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
    both = (ds["staring"].values > 0.5) & (ds["staring"].values[:, [ref]] > 0.5)
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


def _first(t, flags):
    idx = np.flatnonzero(flags)
    return float(t[idx[0]]) if idx.size else None


def metrics(ds, built):
    """The paper's numbers of one run (module docstring)."""
    a = built.scenario.analysis
    t = ds["time"].values
    staring = ds["staring"].values > 0.5
    angle = ds["attitude_error"].values
    limit = np.radians(a.pointing_converged_deg)
    m = {}
    converged_at = []
    for k, name in enumerate(built.names):
        start = _first(t, staring[:, k])
        m[f"stare_start_s_{name}"] = start
        if start is None:
            converged_at.append(None)
            continue
        done = settle_time_s(t, staring[:, k] & (angle[:, k] < limit), a.settle_hold_s)
        converged_at.append(done)
        m[f"switch_convergence_s_{name}"] = None if done is None else done - start
        m[f"overflight_s_{name}"] = float(t[np.argmax(ds["target_elevation"].values[:, k])])
        if done is not None:
            after = t >= done
            worst = np.argmax(np.where(after, angle[:, k], -1.0))
            m[f"steady_attitude_error_max_deg_{name}"] = float(np.degrees(angle[worst, k]))
            m[f"steady_attitude_error_max_time_s_{name}"] = float(t[worst])
            m[f"steady_attitude_error_rms_deg_{name}"] = float(np.degrees(np.sqrt(np.mean(angle[after, k] ** 2))))
            m[f"steady_pointing_error_max_deg_{name}"] = float(np.degrees(ds["pointing_error"].values[after, k].max()))
    m.update(_pair_metrics(ds, built, converged_at))
    return m


def _pair_metrics(ds, built, converged_at):
    ref = _reference(built)
    followers = [k for k in range(len(built.names)) if k != ref]
    if not followers or any(c is None for c in converged_at):
        return {}
    t = ds["time"].values
    rel = ds["relative_attitude_error"].values[:, followers]
    mismatch = ds["image_mismatch"].values[:, followers]
    after = t >= max(converged_at)
    first = min(s for s in (ds["staring"].values > 0.5).argmax(axis=0))
    switch = (t >= t[first]) & ~after
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
