"""Design-time geometry of a staring pass (SPEC §5): the sun-pointing attitude, when the target
rises, and a default target under the ground track.

NumPy/SciPy; the closed loop uses :mod:`coopsat.control.observation`.
"""

import functools

import numpy as np
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from coopsat.astro.earth import ecef_to_geodetic, geodetic_to_ecef, up_ecef
from coopsat.astro.earth_orientation import itrf_from_gcrf_matrix
from coopsat.design.memo import by_value


def sun_pointing_quaternion(sun_eci, r_eci_m):
    """``Q_s``: body −y toward the Sun, +z as close to nadir as that allows.

    Parameters
    ----------
    sun_eci : array_like, shape (3,)
        Direction to the Sun, ECI (any length).
    r_eci_m : array_like, shape (3,)
        The spacecraft's position, m (nadir is ``−r``).

    Returns
    -------
    ndarray, shape (4,)
        Body-to-inertial quaternion, scalar first, ``q0 ≥ 0``.

    Raises
    ------
    ValueError
        The Sun exactly at nadir or zenith (the roll about the Sun line is then undefined).

    Notes
    -----
    The paper (eq. 3) takes ``Q_s`` inertial and says only that the solar array, normal to −y,
    faces the Sun; the roll about the Sun line is our choice: the camera (+z) as near the Earth
    as it can be, which also makes the slew to the target short.
    """
    y_b = -np.asarray(sun_eci, dtype=float) / np.linalg.norm(sun_eci)
    nadir = -np.asarray(r_eci_m, dtype=float) / np.linalg.norm(r_eci_m)
    z_b = nadir - (nadir @ y_b) * y_b
    if np.linalg.norm(z_b) < 1e-9:
        raise ValueError("sun-pointing attitude: the Sun is at nadir or zenith, so the roll about the Sun line is undefined")
    z_b /= np.linalg.norm(z_b)
    q = Rotation.from_matrix(np.column_stack([np.cross(y_b, z_b), y_b, z_b])).as_quat(scalar_first=True)
    return q if q[0] >= 0 else -q


@functools.cache
def _state_derivative():
    """``f(s, μ, J2, R) = [v, a]`` of an ECI state ``s = [r m, v m/s]`` under two-body + J2,
    compiled (the JAX force models run op by op cost 0.5 ms a call: 6.7 s for the two orbits
    of a pass, against 0.6 s)."""
    import jax
    import jax.numpy as jnp

    from coopsat.dynamics.translational import j2_accel, two_body_accel

    return jax.jit(lambda s, mu, j2, rb: jnp.concatenate([s[3:], two_body_accel(s[:3], mu) + j2_accel(s[:3], mu, j2, rb)]))


def propagate(r0_m, v0_m_s, times_s, mu_m3_s2, j2, r_body_m):
    """ECI positions at ``times_s`` under two-body + J2 (DOP853, rtol 1e-10), shape (len(times_s), 3)."""
    derivative = _state_derivative()

    def f(_, s):
        return np.asarray(derivative(s, mu_m3_s2, j2, r_body_m))

    sol = solve_ivp(f, (0.0, float(times_s[-1])), np.concatenate([r0_m, v0_m_s]), t_eval=times_s, method="DOP853",
                    rtol=1e-10, atol=1e-6)
    return sol.y[:3].T


def target_elevations(r_eci_m, times_s, target_ecef_m, up_target_ecef, earth):
    """Elevation of each spacecraft position above the target's horizon, rad, shape (len(times_s),);
    ``earth`` the run's :class:`~coopsat.astro.earth_orientation.EarthOrientation`."""
    # The spacecraft into ECEF, where the target and its vertical stand still.
    r_ecef = (itrf_from_gcrf_matrix(earth, times_s, np) @ np.asarray(r_eci_m)[..., None])[..., 0]
    los = r_ecef - target_ecef_m
    return np.arcsin(los @ up_target_ecef / np.linalg.norm(los, axis=1))


@by_value
def first_visible_s(r0_m, v0_m_s, target_ecef_m, up_target_ecef, earth, min_elevation_rad, horizon_s, mu_m3_s2,
                    j2, r_body_m, step_s=5.0):
    """First time the target is at least ``min_elevation_rad`` above its horizon, s (None if not
    within ``horizon_s``), sampled every ``step_s``."""
    times = np.arange(0.0, horizon_s + step_s, step_s)
    el = target_elevations(propagate(r0_m, v0_m_s, times, mu_m3_s2, j2, r_body_m), times, target_ecef_m, up_target_ecef,
                           earth)
    above = np.flatnonzero(el >= min_elevation_rad)
    return float(times[above[0]]) if above.size else None


def ground_track_point(r0_m, v0_m_s, t_s, earth, mu_m3_s2, j2, r_body_m, cross_track_m=0.0):
    """Geodetic latitude, longitude (rad) of the point under the spacecraft at ``t_s``, moved
    ``cross_track_m`` along the orbit normal (a target near, not on, the ground track)."""
    r = propagate(r0_m, v0_m_s, np.array([0.0, t_s]), mu_m3_s2, j2, r_body_m)[-1]
    normal = np.cross(r0_m, v0_m_s)
    normal /= np.linalg.norm(normal)
    to_itrf = itrf_from_gcrf_matrix(earth, t_s, np)
    r_ecef, n_ecef = to_itrf @ r, to_itrf @ normal
    lat, lon, _ = ecef_to_geodetic(r_ecef)
    surface = geodetic_to_ecef(lat, lon, 0.0)
    lat, lon, _ = ecef_to_geodetic(np.asarray(surface) + cross_track_m * n_ecef)
    return float(lat), float(lon)


def target_ecef(lat_rad, lon_rad, h_m):
    """The target and its vertical, Earth-fixed: (position m (3,), unit normal (3,))."""
    return np.asarray(geodetic_to_ecef(lat_rad, lon_rad, h_m), dtype=float), np.asarray(up_ecef(lat_rad, lon_rad), dtype=float)
