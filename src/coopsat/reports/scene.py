"""The 3D view of a run: where each spacecraft is, which way it points, in the frame that shows it.

Pure NumPy from the run's dataset to display arrays. The frame is chosen from what the run has:

* a close formation in orbit (two or more spacecraft, spread under :data:`CLOSE_FRACTION` of
  the chief's orbit radius): the chief's LVLH frame (the first spacecraft), metres: the
  cartwheel and the deep-space formations;
* a spacecraft or a wide formation in orbit: the inertial frame of the ``[orbit]`` (ECI, or
  heliocentric when the central body is the Sun), kilometres, with the central body drawn;
* an attitude-only run (no ``r_eci``): the spacecraft drawn on a circle, not to scale, so that
  their body axes can be compared in inertial axes.

Body axes come from ``q`` (``q_bi``, scalar first: the columns of ``C_ib`` are the body axes
in inertial components), or, for the linearised leader–follower model that records only
small attitude ``angle``, from that angle taken as a rotation vector. The observation family's
camera boresight (body +z) ends on its ground target, found by intersecting the recorded line
of sight with the central body's sphere (a display choice: the equatorial radius).
"""

from dataclasses import dataclass

import numpy as np

from coopsat.astro.constants import central_body_name
from coopsat.geometry.frames import lvlh_dcm
from coopsat.geometry.quaternion import quat_from_axis_angle, quat_to_dcm

CLOSE_FRACTION = 1e-3
"""A formation whose spread is below this fraction of its chief's orbit radius is drawn in the
chief's LVLH frame: in an inertial view it would be one dot."""

MAX_FRAMES = 200
"""Most time steps the slider offers: enough to follow a run, few enough to keep the page light."""

MAX_TRAIL = 1500
"""Most samples of each drawn path."""


@dataclass(frozen=True)
class Scene:
    """What the 3D view draws.

    Attributes
    ----------
    frame : str
        The display frame, in words (``"LVLH of sat1"``, ``"ECI"``…).
    axis_titles : tuple of str
        Titles of the display x, y, z axes, with the unit.
    frame_index : ndarray of int (F,)
        Record index of each slider step.
    positions : ndarray (F, n, 3)
        Spacecraft positions at each step, display frame and unit.
    trails : ndarray (T, n, 3)
        Each spacecraft's path, decimated to at most :data:`MAX_TRAIL` samples.
    body_axes : ndarray (F, n, 3, 3) or None
        ``[f, sc, a]``: body axis ``a`` (x, y, z) as a unit vector in the display frame.
    axis_length : float
        Drawn length of a body axis, display unit.
    central_body : (str, float) or None
        Name and radius (display unit) of the sphere drawn at the origin.
    targets : ndarray (F, n, 3) or None
        Ground target each camera stares at, display frame (NaN where it sees none).
    note : str
        What the view does not show to scale, or an empty string.
    """

    frame: str
    axis_titles: tuple
    frame_index: np.ndarray
    positions: np.ndarray
    trails: np.ndarray
    body_axes: np.ndarray | None
    axis_length: float
    central_body: tuple | None
    targets: np.ndarray | None
    note: str


def frame_indices(n_samples, max_frames=MAX_FRAMES):
    """Evenly spread record indices, first and last included, at most ``max_frames`` of them.

    Returns
    -------
    ndarray of int (F,)
    """
    return np.unique(np.linspace(0, n_samples - 1, min(n_samples, max_frames)).round().astype(np.int64))


def _values(ds, name):
    """``ds[name]`` as (time, spacecraft, component) float64."""
    return np.asarray(ds[name].transpose("time", "spacecraft", ...).values, dtype=float)


def body_axes_inertial(ds):
    """Body axes in inertial components, from ``q`` or the small-angle ``angle``.

    Returns
    -------
    ndarray (time, n, 3, 3) or None
        ``[t, sc, a]``: body axis ``a`` as an inertial unit vector (row ``a`` of ``C_ib``ᵀ);
        None when the run records no attitude.
    """
    if "q" in ds:
        c_ib = quat_to_dcm(_values(ds, "q"))
    elif "angle" in ds:
        rotation_vector = _values(ds, "angle")
        angle = np.linalg.norm(rotation_vector, axis=-1)
        axis = np.where(angle[..., None] > 0, rotation_vector / np.where(angle > 0, angle, 1.0)[..., None], [1.0, 0, 0])
        c_ib = quat_to_dcm(quat_from_axis_angle(axis, angle))
    else:
        return None
    return np.swapaxes(np.asarray(c_ib), -1, -2)


def ground_targets(r_eci_m, los_eci, radius_m):
    """Where each line of sight meets a sphere of ``radius_m`` about the origin (the nearer point).

    Parameters
    ----------
    r_eci_m : ndarray (..., 3)
        Spacecraft positions, m.
    los_eci : ndarray (..., 3)
        Unit lines of sight.
    radius_m : float

    Returns
    -------
    ndarray (..., 3)
        The points, m; NaN where the line misses the sphere.
    """
    b = np.sum(r_eci_m * los_eci, axis=-1)
    c = np.sum(r_eci_m * r_eci_m, axis=-1) - radius_m**2
    disc = b * b - c
    with np.errstate(invalid="ignore"):
        s = -b - np.sqrt(disc)
    s = np.where((disc >= 0) & (s > 0), s, np.nan)
    return r_eci_m + s[..., None] * los_eci


def _trail_index(n_samples):
    return np.unique(np.linspace(0, n_samples - 1, min(n_samples, MAX_TRAIL)).round().astype(np.int64))


def _central_body(orbit):
    """The drawn name of the ``[orbit]``'s central body (None without one)."""
    if orbit is None:
        return None
    name = central_body_name(orbit.mu_m3_s2)
    return "central body" if name is None else name.title()


def _lvlh_scene(ds, r, axes_i, frames, names, body):
    """Close formation: positions relative to the chief, in the chief's LVLH frame, m."""
    c = np.asarray(lvlh_dcm(r[:, 0], _values(ds, "v_eci")[:, 0]))  # (t, 3, 3): rows are LVLH axes
    rho = np.einsum("tij,tnj->tni", c, r - r[:, :1])
    spread = float(np.max(np.ptp(rho.reshape(-1, 3), axis=0)))
    rotated = None if axes_i is None else np.einsum("tij,tnaj->tnai", c, axes_i)[frames]
    trail = _trail_index(len(rho))
    frame = f"LVLH of {names[0]}" + (f" (orbiting the {body})" if body in ("Earth", "Sun") else "")
    titles = ("x along-track (m)", "y −orbit normal (m)", "z towards the centre (m)")
    return Scene(frame, titles, frames, rho[frames], rho[trail], rotated, 0.15 * max(spread, 1.0), None, None, "")


def _inertial_scene(ds, r, axes_i, frames, body, radius_m, targets_m):
    """Positions in the orbit's inertial frame, km, the central body at the origin."""
    km = 1e-3
    name = "heliocentric inertial" if body == "Sun" else "ECI"
    extent = float(np.max(np.linalg.norm(r, axis=-1)))
    trail = _trail_index(len(r))
    sphere = (body, radius_m * km) if body is not None and radius_m < extent else None
    targets = None if targets_m is None else targets_m[frames] * km
    return Scene(name, ("x (km)", "y (km)", "z (km)"), frames, r[frames] * km, r[trail] * km,
                 None if axes_i is None else axes_i[frames], 0.12 * extent * km, sphere, targets, "")


def _attitude_scene(axes_i, frames, n):
    """No positions recorded: the spacecraft on a unit circle, their axes in inertial axes."""
    angle = 2 * np.pi * np.arange(n) / max(n, 1)
    ring = np.stack([np.cos(angle), np.sin(angle), np.zeros(n)], axis=-1) if n > 1 else np.zeros((1, 3))
    at = np.broadcast_to(ring, (len(frames), n, 3))
    return Scene("inertial axes", ("x", "y", "z"), frames, at, ring[None], None if axes_i is None else axes_i[frames],
                 0.45, None, None,
                 "positions are not simulated in this run: the spacecraft are placed on a circle to compare attitudes")


def build_scene(ds, orbit=None):
    """The 3D view of a run.

    Parameters
    ----------
    ds : xarray.Dataset
        The run's record (``result.nc``).
    orbit : coopsat.scenarios.schema.Orbit or None
        The scenario's ``[orbit]`` table (central body and its radius), None without one.

    Returns
    -------
    Scene
    """
    names = [str(s) for s in ds["spacecraft"].values]
    frames = frame_indices(ds.sizes["time"])
    axes_i = body_axes_inertial(ds)
    if "r_eci" not in ds:
        return _attitude_scene(axes_i, frames, len(names))
    r = _values(ds, "r_eci")
    body = _central_body(orbit)
    spread = np.max(np.linalg.norm(r - r[:, :1], axis=-1))
    if len(names) > 1 and "v_eci" in ds and spread < CLOSE_FRACTION * np.min(np.linalg.norm(r[:, 0], axis=-1)):
        return _lvlh_scene(ds, r, axes_i, frames, names, body)
    radius_m = orbit.r_body_m if orbit is not None else 0.0
    targets = ground_targets(r, _values(ds, "target_los"), radius_m) if "target_los" in ds and radius_m > 0 else None
    return _inertial_scene(ds, r, axes_i, frames, body, radius_m, targets)
