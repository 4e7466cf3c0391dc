"""The Earth's figure and the papers' sidereal time: the WGS-84 ellipsoid, GMST (SPEC §0, §5).

How the Earth-fixed frame turns in the inertial one is :mod:`coopsat.astro.earth_orientation`
(IAU 2006/2000A, or the papers' turn about z by :func:`gmst_rad`, with UT1 taken equal to UTC).

The functions of the closed loop (:func:`geodetic_to_ecef`, :func:`up_ecef`,
:func:`elevation_rad`, :func:`geocentric_paper_eci`) are written with ``jax.numpy`` and trace
under ``jit``; they also take NumPy arrays. Vector functions take ``axis``, the component axis
(``axis=0``: the component-major ``(3, n)`` layout of the compiled loop).
:func:`ecef_to_geodetic`, :func:`julian_date_utc` and :func:`gmst_rad` are design-time NumPy.
"""

from datetime import datetime, timezone


import jax.numpy as jnp
import numpy as np

OMEGA_EARTH_RAD_S = 7.292115146706979e-5
"""Earth's rotation rate relative to inertial axes, rad/s: 2π/86164.0989 s, the stellar day
(IERS conventional value 7.292115e-5). The IAU-82 GMST of :func:`gmst_rad` advances slightly
faster, 7.2921158553e-5 rad/s (2π/86164.0905 s, the sidereal day counted from the precessing
equinox); the difference, 7.1e-12 rad/s or 6e-7 rad (4 m at the equator) a day, is the
precession that SPEC §0 leaves out."""

WGS84_A_M = 6378137.0
"""WGS-84 semi-major axis (equatorial radius), m."""

WGS84_F = 1.0 / 298.257223563
"""WGS-84 flattening."""

WGS84_B_M = WGS84_A_M * (1.0 - WGS84_F)
"""WGS-84 semi-minor axis (polar radius), m."""

WGS84_E2 = WGS84_F * (2.0 - WGS84_F)
"""WGS-84 first eccentricity squared, ``e² = f (2 − f) = 1 − b²/a²``."""

JD_J2000 = 2451545.0
"""Julian date of J2000.0 (2000-01-01 12:00:00 TT; used here on the UT1 scale as IAU-82 does)."""


def julian_date_utc(iso_utc):
    """Julian date of an ISO-8601 UTC instant (``"2018-06-21T04:00:00"``; a zone suffix other
    than UTC is converted).

    Parameters
    ----------
    iso_utc : str

    Returns
    -------
    float
        Julian date, days (UTC; used as UT1, see the module notes).

    Raises
    ------
    ValueError
        A string that is not an ISO-8601 date-time.

    Notes
    -----
    POSIX time: every day has 86400 s. On a day that ends in a leap second SOFA and astropy
    spread the extra second over the day, so there the two differ by up to 1 s (0.5 s at noon
    of 2016-12-31); on every other day they agree to the float64 resolution of a Julian date.
    """
    when = datetime.fromisoformat(iso_utc)
    when = when.replace(tzinfo=timezone.utc) if when.tzinfo is None else when.astimezone(timezone.utc)
    return 2440587.5 + when.timestamp() / 86400.0


def gmst_rad(jd_ut1):
    """Greenwich mean sidereal time, rad in [0, 2π), IAU-82.

    Parameters
    ----------
    jd_ut1 : float
        Julian date on the UT1 scale.

    Notes
    -----
    Vallado, *Fundamentals of Astrodynamics and Applications*, 4th ed., eq. 3-47:
    ``θ = 67310.54841 s + (876600 h + 8640184.812866 s) T + 0.093104 s T² − 6.2e-6 s T³``,
    ``T`` Julian centuries of UT1 from J2000.
    """
    t = (jd_ut1 - JD_J2000) / 36525.0
    seconds = 67310.54841 + (876600.0 * 3600.0 + 8640184.812866) * t + 0.093104 * t**2 - 6.2e-6 * t**3
    return float(np.mod(seconds / 240.0 * np.pi / 180.0, 2.0 * np.pi))


# As coopsat.geometry.quaternion's: astro and geometry are sibling layers (pyproject.toml
# [tool.importlinter]), so astro does not import it from there.
def _dot(a, b, axis):
    """Sum of the product of ``a`` and ``b`` along ``axis``."""
    return jnp.sum(a * b, axis=axis)


def geodetic_to_ecef(lat_rad, lon_rad, h_m):
    """ECEF position of a point given by geodetic latitude, longitude and ellipsoidal height.

    Parameters
    ----------
    lat_rad, lon_rad : array_like, shape (...)
        Geodetic latitude (angle of the ellipsoid normal to the equator) and longitude, rad.
    h_m : array_like, shape (...)
        Height above the WGS-84 ellipsoid along its normal, m. The three broadcast.

    Returns
    -------
    jax.Array, shape (..., 3)
        ``r_ecef_m``, m.

    Notes
    -----
    Exact, no iteration: ``N = a / sqrt(1 − e² sin²φ)`` (prime-vertical radius of curvature),
    ``x = (N + h) cos φ cos λ``, ``y = (N + h) cos φ sin λ``, ``z = (N (1 − e²) + h) sin φ``
    (Vallado, 4th ed., eq. 3-14; NIMA TR8350.2 eq. 4-14).
    """
    sin_lat, cos_lat = jnp.sin(lat_rad), jnp.cos(lat_rad)
    n_m = WGS84_A_M / jnp.sqrt(1.0 - WGS84_E2 * sin_lat * sin_lat)
    rho_m = (n_m + h_m) * cos_lat
    x, y, z = rho_m * jnp.cos(lon_rad), rho_m * jnp.sin(lon_rad), (n_m * (1.0 - WGS84_E2) + h_m) * sin_lat
    return jnp.stack(jnp.broadcast_arrays(x, y, z), axis=-1)


def ecef_to_geodetic(r_ecef_m, max_iter=10):
    """Geodetic latitude, longitude and height of ECEF positions (design time, NumPy).

    Parameters
    ----------
    r_ecef_m : array_like, shape (..., 3)
        Position, m.
    max_iter : int
        Cap on the iterations after Bowring's starting value (see the notes).

    Returns
    -------
    lat_rad : ndarray, shape (...)
        Geodetic latitude, rad, in [−π/2, π/2].
    lon_rad : ndarray, shape (...)
        Longitude, rad, in (−π, π].
    h_m : ndarray, shape (...)
        Height above the WGS-84 ellipsoid along its normal, m.

    Notes
    -----
    Bowring's iteration on the parametric (reduced) latitude β (Bowring 1976, *Survey Review*
    23(181)): ``tan φ = (z + e'² b sin³β) / (p − e² a cos³β)``, ``tan β = (1 − f) tan φ``, with
    ``p = sqrt(x² + y²)`` and ``e'² = e²/(1 − e²)``, started from ``tan β = z / ((1 − f) p)``.
    Bowring's start alone is within 3e-10 rad up to 500 km and 9e-8 rad at 3000 km below the
    surface; one more step reaches 2.2e-16 rad (one rounding) everywhere measured, from 3000 km
    below the surface to 4e8 m out. The loop stops when no latitude moves by more than 1e-15
    rad (6 nm on the ground). The height is ``h = p cos φ + z sin φ − a sqrt(1 − e² sin²φ)``,
    which has no singularity at the poles or the equator. Points within about 40 km of the
    Earth's centre (inside the evolute of the ellipse) have several normals; the one returned
    there is not specified.
    """
    r = np.asarray(r_ecef_m, dtype=float)
    x, y, z = r[..., 0], r[..., 1], r[..., 2]
    p = np.hypot(x, y)
    ep2 = WGS84_E2 / (1.0 - WGS84_E2)
    beta = np.arctan2(z, (1.0 - WGS84_F) * p)
    lat = np.arctan2(z + ep2 * WGS84_B_M * np.sin(beta) ** 3, p - WGS84_E2 * WGS84_A_M * np.cos(beta) ** 3)
    for _ in range(max_iter):
        beta = np.arctan2((1.0 - WGS84_F) * np.sin(lat), np.cos(lat))
        new = np.arctan2(z + ep2 * WGS84_B_M * np.sin(beta) ** 3, p - WGS84_E2 * WGS84_A_M * np.cos(beta) ** 3)
        moved = np.max(np.abs(new - lat), initial=0.0)
        lat = new
        if moved <= 1e-15:
            break
    sin_lat, cos_lat = np.sin(lat), np.cos(lat)
    h = p * cos_lat + z * sin_lat - WGS84_A_M * np.sqrt(1.0 - WGS84_E2 * sin_lat * sin_lat)
    return lat, np.arctan2(y, x), h


def up_ecef(lat_rad, lon_rad):
    """Outward unit normal of the WGS-84 ellipsoid (the local vertical), ECEF.

    Parameters
    ----------
    lat_rad, lon_rad : array_like, shape (...)
        Geodetic latitude and longitude, rad.

    Returns
    -------
    jax.Array, shape (..., 3)
        ``[cos φ cos λ, cos φ sin λ, sin φ]``, unit length.
    """
    cos_lat = jnp.cos(lat_rad)
    parts = jnp.broadcast_arrays(cos_lat * jnp.cos(lon_rad), cos_lat * jnp.sin(lon_rad), jnp.sin(lat_rad))
    return jnp.stack(parts, axis=-1)


def elevation_rad(r_sc_eci_m, r_target_eci_m, up_eci, axis=-1):
    """Elevation of a spacecraft above a ground target's local horizon, rad in [−π/2, π/2].

    Parameters
    ----------
    r_sc_eci_m, r_target_eci_m : array_like, shape (..., 3) (component ``axis``)
        Spacecraft and target positions, m, in one frame (ECI, or both ECEF).
    up_eci : array_like, shape (..., 3)
        The target's unit vertical in the same frame (:func:`up_ecef`, rotated).
    axis : int
        Component axis.

    Returns
    -------
    jax.Array, shape (...)
        ``asin(ℓ̂ · û)``, ``ℓ̂`` the unit line of sight from the target to the spacecraft. The
        sine is clipped to [−1, 1] so that rounding at the zenith gives π/2, not NaN.
        Coincident positions give NaN.
    """
    los = jnp.asarray(r_sc_eci_m) - jnp.asarray(r_target_eci_m)
    sine = _dot(los, up_eci, axis) / jnp.sqrt(_dot(los, los, axis))
    return jnp.arcsin(jnp.clip(sine, -1.0, 1.0))


def geocentric_paper_eci(lat_rad, lon_rad, h_m, theta_rad):
    """A ground target's inertial position as the 2019 observation paper writes it (eqs. 5–6).

    Parameters
    ----------
    lat_rad, lon_rad : array_like, shape (...)
        Geodetic latitude B and longitude L, rad.
    h_m : array_like, shape (...)
        Height H, m.
    theta_rad : array_like, shape (...)
        Greenwich sidereal angle, rad. All four broadcast.

    Returns
    -------
    jax.Array, shape (..., 3)
        ``R [cos B' cos(L + θ), cos B' sin(L + θ), sin B']``, ECI, m, with the geocentric
        latitude ``B' = atan((1 − f)² tan B)`` and ``R = a b / sqrt(a² sin²B' + b² cos²B') + H``.

    Notes
    -----
    Fang et al. (2019), eqs. 5–6, transcribed as printed (``B'`` written with ``atan2`` so
    that the poles are defined). For ``H = 0`` this is exactly the geodetic surface point
    (``R − H`` is the ellipse's polar-form radius at geocentric latitude ``B'``). For
    ``H ≠ 0`` it differs from the exact point ``geodetic_to_ecef(B, L, H)`` rotated to ECI:
    the paper adds the height along the geocentric direction, not along the ellipsoid
    normal. The two directions are ``δ = B − B'`` apart (at most 0.19° at 45°), so the
    points are ``2 H sin(δ/2)`` apart: about 3.4 m for ``H = 1 km`` at ``B = 45°``, 0 at the
    equator and the poles. Measured in tests/unit/astro/test_earth.py.
    """
    lat_gc = jnp.arctan2((1.0 - WGS84_F) ** 2 * jnp.sin(lat_rad), jnp.cos(lat_rad))
    sin_gc, cos_gc = jnp.sin(lat_gc), jnp.cos(lat_gc)
    a, b = WGS84_A_M, WGS84_B_M
    radius_m = a * b / jnp.sqrt(a * a * sin_gc * sin_gc + b * b * cos_gc * cos_gc) + h_m
    lon_eci = lon_rad + theta_rad
    parts = jnp.broadcast_arrays(radius_m * cos_gc * jnp.cos(lon_eci), radius_m * cos_gc * jnp.sin(lon_eci),
                                 radius_m * sin_gc)
    return jnp.stack(parts, axis=-1)
