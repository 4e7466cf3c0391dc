"""Analytic Sun and Moon, their point-mass pull on a spacecraft, and the Earth's conical shadow.

The Sun and the Moon are Montenbruck & Gill's low-precision series (*Satellite Orbits*, 2000,
§3.3.2, pp. 70–73), geocentric, in the mean equator and equinox of J2000 (EME2000), metres,
from a Julian date in Terrestrial Time. The coefficients are those of the authors' own
implementation (their ``SunPos``/``MoonPos``, in revolutions), which brahe 1.8 also uses, so
the two agree to the rounding of the same arithmetic (tests/unit/test_ephemeris.py). brahe
then rotates EME2000 into the GCRF by the constant frame bias (0.023″, 1.1e-7 rad: up to 17 km
at the Sun, 45 m at the Moon); these functions stop in EME2000, the frame the series define.
The bias is far below the series' own error against the JPL ephemeris
(:func:`ephemeris_difference`).

The functions of the closed loop (:func:`sun_position_eme2000_m`,
:func:`moon_position_eme2000_m`, :func:`third_body_accel`, :func:`shadow_fraction_conical`,
:func:`shadow_fraction_cylindrical`) are written with ``jax.numpy`` and trace under ``jit`` with
the date a traced scalar. They need float64 (``jax_enable_x64``): a float32 Julian date
resolves only a quarter of a day. :func:`ephemeris_difference` is design-time NumPy.
"""

import warnings
from pathlib import Path
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from coopsat.astro.constants import MU_SUN_M3_S2, R_EARTH_M
from coopsat.astro.earth import JD_J2000
from coopsat.astro.sun import sunlit

__all__ = [
    "MU_MOON_M3_S2",
    "MU_SUN_M3_S2",
    "R_SUN_M",
    "EphemerisDifference",
    "ephemeris_difference",
    "moon_position_eme2000_m",
    "shadow_fraction_conical",
    "shadow_fraction_cylindrical",
    "sun_position_eme2000_m",
    "third_body_accel",
]

MU_MOON_M3_S2 = 4.902800066e12
"""Moon's gravitational parameter, m³/s² (JPL DE430, Folkner et al. 2014, IPN PR 42-196,
4902.800066 km³/s²; brahe's ``GM_MOON``)."""

R_SUN_M = 6.957e8
"""Sun's radius, m: the IAU 2015 Resolution B3 nominal solar radius (brahe's ``R_SUN``).
Montenbruck & Gill's 696 000 km is 0.04 % larger."""

OBLIQUITY_J2000_RAD = np.radians(23.43929111)
"""Obliquity of the J2000 ecliptic, rad (Montenbruck & Gill eq. 3.46, ε = 23.43929111°)."""

ARCSEC_RAD = np.pi / (180.0 * 3600.0)
"""One arcsecond, rad."""

JULIAN_CENTURY_DAYS = 36525.0
"""Days in a Julian century."""


def _centuries_tt(jd_tt):
    """Julian centuries of TT from J2000.0 (the series' time argument T)."""
    return (jnp.asarray(jd_tt) - JD_J2000) / JULIAN_CENTURY_DAYS


def _angle_rad(revolutions):
    """An angle given in revolutions, reduced to one turn before scaling to radians: the
    reduction keeps the float64 rounding of the fast lunar arguments (up to ~700 turns in
    2050) to the 1e-13 rad of a single turn, as the authors' ``Frac`` does."""
    return 2.0 * jnp.pi * (revolutions - jnp.floor(revolutions))


def _ecliptic_to_eme2000(r_m, lon_rad, lat_rad):
    """Spherical ecliptic-J2000 coordinates → EME2000 Cartesian, shape (..., 3): the rotation
    ``R_x(−ε)`` about the equinox direction (Montenbruck & Gill eq. 3.46)."""
    x = r_m * jnp.cos(lat_rad) * jnp.cos(lon_rad)
    y = r_m * jnp.cos(lat_rad) * jnp.sin(lon_rad)
    z = r_m * jnp.sin(lat_rad)
    cos_eps, sin_eps = np.cos(OBLIQUITY_J2000_RAD), np.sin(OBLIQUITY_J2000_RAD)
    return jnp.stack([x, cos_eps * y - sin_eps * z, sin_eps * y + cos_eps * z], axis=-1)


def sun_position_eme2000_m(jd_tt):
    """Geocentric position of the Sun, m, mean equator and equinox of J2000 (EME2000).

    Parameters
    ----------
    jd_tt : array_like, shape (...)
        Julian date, Terrestrial Time, days.

    Returns
    -------
    jax.Array, shape (..., 3)
        Sun position, m.

    Notes
    -----
    Montenbruck & Gill §3.3.2, eqs. 3.43–3.46, with T the Julian centuries of TT from J2000:
    mean anomaly ``M = 0.9931267 + 99.9973583 T`` rev (357.5256° + 35999.049° T), ecliptic
    longitude ``λ = 0.7859444 rev + M + 6892″ sin M + 72″ sin 2M`` (Ω + ω = 282.9400°),
    distance ``r = 149.619e9 − 2.499e9 cos M − 0.021e9 cos 2M`` m, latitude 0, then ``R_x(−ε)``
    with ε = 23.43929111°. λ is referred to the equinox of J2000 as written: no 1.3972° T is
    added (that term refers λ to the equinox of date), as in the authors' ``SunPos`` and
    brahe. The revolution constants are those of ``SunPos``; the degree values of the book
    are them rounded (282.9400° is 1.6e-5° from 0.7859444 rev: 40 m at 1 AU).

    The series holds the longitude of perigee (Ω + ω) fixed, while in the J2000 frame it
    advances 0.3225° a century (1.7195° against the equinox of date less the 1.3972° of
    precession), so λ falls behind the true Sun in proportion to T. Measured against DE421
    over 1990–2050 (2000 dates): a linear fit of the longitude difference gives
    −0.3225° T + 0.0013°, 0.0074° left around it; distance within 8e-5; the largest direction
    difference 0.0035° in 2000, 0.037° in 1990 and 0.167° in 2050.
    """
    t = _centuries_tt(jd_tt)
    m = _angle_rad(0.9931267 + 99.9973583 * t)
    lon = _angle_rad(0.7859444 + m / (2.0 * jnp.pi)
                     + (6892.0 * jnp.sin(m) + 72.0 * jnp.sin(2.0 * m)) / 1296.0e3)
    r = 149.619e9 - 2.499e9 * jnp.cos(m) - 0.021e9 * jnp.cos(2.0 * m)
    return _ecliptic_to_eme2000(r, lon, jnp.zeros_like(r))


def moon_position_eme2000_m(jd_tt):
    """Geocentric position of the Moon, m, mean equator and equinox of J2000 (EME2000).

    Parameters
    ----------
    jd_tt : array_like, shape (...)
        Julian date, Terrestrial Time, days.

    Returns
    -------
    jax.Array, shape (..., 3)
        Moon position, m.

    Notes
    -----
    Montenbruck & Gill §3.3.2, eqs. 3.47–3.48. The fundamental arguments, in revolutions with
    T in Julian centuries of TT from J2000: the Moon's mean longitude referred to the equinox
    of J2000 ``L0 = 0.606433 + 1336.851344 T`` (218.31617° + 481267.88088° T − 1.3972° T: the
    last term takes out the precession), the Moon's mean anomaly ``l = 0.374897 + 1325.552410 T``,
    the Sun's ``l' = 0.993133 + 99.997361 T``, the mean elongation ``D = 0.827361 + 1236.853086 T``
    and the argument of latitude ``F = 0.259086 + 1342.227825 T``. These are the authors'
    ``MoonPos`` constants (and brahe's); they are the book's degree values rounded to 1e-6 rev
    (up to 3.6e-4°, 2.4 km at the Moon), far inside the series' accuracy.

    Longitude ``λ = L0 + δλ`` with the 14-term perturbation δλ (″) below, latitude
    ``β = 18520″ sin S + N`` with ``S = F + (δλ + 412″ sin 2F + 541″ sin l')`` and
    ``h = F − 2D``, distance r (km) from a 9-term series; then ``R_x(−ε)`` (eq. 3.46).
    A low-precision series: several arcminutes, some hundreds of km. Measured against
    DE421 over 1990–2050 (60 000 dates, 9 h apart): direction within 0.090° (5.4′), position
    within 561 km; unlike the Sun's, the error does not grow away from 2000, since
    L0 carries its precession term.
    """
    t = _centuries_tt(jd_tt)
    l0 = 0.606433 + 1336.851344 * t  # rev: L0 is reduced together with δλ below
    l = _angle_rad(0.374897 + 1325.552410 * t)
    lp = _angle_rad(0.993133 + 99.997361 * t)
    d = _angle_rad(0.827361 + 1236.853086 * t)
    f = _angle_rad(0.259086 + 1342.227825 * t)

    dlon_arcsec = (22640.0 * jnp.sin(l) - 4586.0 * jnp.sin(l - 2.0 * d)
                   + 2370.0 * jnp.sin(2.0 * d) + 769.0 * jnp.sin(2.0 * l)
                   - 668.0 * jnp.sin(lp) - 412.0 * jnp.sin(2.0 * f)
                   - 212.0 * jnp.sin(2.0 * l - 2.0 * d) - 206.0 * jnp.sin(l + lp - 2.0 * d)
                   + 192.0 * jnp.sin(l + 2.0 * d) - 165.0 * jnp.sin(lp - 2.0 * d)
                   - 125.0 * jnp.sin(d) - 110.0 * jnp.sin(l + lp)
                   + 148.0 * jnp.sin(l - lp) - 55.0 * jnp.sin(2.0 * f - 2.0 * d))
    lon = _angle_rad(l0 + dlon_arcsec / 1296.0e3)

    s = f + (dlon_arcsec + 412.0 * jnp.sin(2.0 * f) + 541.0 * jnp.sin(lp)) * ARCSEC_RAD
    h = f - 2.0 * d
    n_arcsec = (-526.0 * jnp.sin(h) + 44.0 * jnp.sin(l + h) - 31.0 * jnp.sin(-l + h)
                - 23.0 * jnp.sin(lp + h) + 11.0 * jnp.sin(-lp + h)
                - 25.0 * jnp.sin(-2.0 * l + f) + 21.0 * jnp.sin(-l + f))
    lat = (18520.0 * jnp.sin(s) + n_arcsec) * ARCSEC_RAD

    r = (385000e3 - 20905e3 * jnp.cos(l) - 3699e3 * jnp.cos(2.0 * d - l)
         - 2956e3 * jnp.cos(2.0 * d) - 570e3 * jnp.cos(2.0 * l)
         + 246e3 * jnp.cos(2.0 * l - 2.0 * d) - 205e3 * jnp.cos(lp - 2.0 * d)
         - 171e3 * jnp.cos(l + 2.0 * d) - 152e3 * jnp.cos(l + lp - 2.0 * d))
    return _ecliptic_to_eme2000(r, lon, lat)


def third_body_accel(r_sc_m, r_body_m, mu_body_m3_s2, axis=-1):
    """Perturbing acceleration of a third body on a spacecraft orbiting the Earth, m/s².

    Parameters
    ----------
    r_sc_m : array_like, shape (..., 3) (component ``axis``)
        Geocentric spacecraft position, m; ``(3, n)`` with ``axis=0`` in the compiled loop.
    r_body_m : array_like, broadcastable against ``r_sc_m``
        Geocentric position of the body, m (``(3, 1)`` against ``(3, n)``).
    mu_body_m3_s2 : float
        The body's gravitational parameter, m³/s² (``MU_SUN_M3_S2``, ``MU_MOON_M3_S2``).
    axis : int
        Component axis.

    Returns
    -------
    jax.Array
        The broadcast shape of the inputs, m/s².

    Notes
    -----
    Montenbruck & Gill eq. 3.37, ``a = μ ((s − r)/|s − r|³ − s/|s|³)``: the body's pull on the
    spacecraft less its pull on the Earth (the indirect term), since the frame is the
    Earth's centre, which the body accelerates too.
    """
    r_sc_m = jnp.asarray(r_sc_m)
    r_body_m = jnp.asarray(r_body_m)
    to_body = r_body_m - r_sc_m
    d = jnp.linalg.norm(to_body, axis=axis, keepdims=True)
    s = jnp.linalg.norm(r_body_m, axis=axis, keepdims=True)
    return mu_body_m3_s2 * (to_body / d**3 - r_body_m / s**3)


def shadow_fraction_conical(r_sc_m, r_sun_m, axis=-1, r_earth_m=R_EARTH_M):
    """Fraction of the Sun's disc a spacecraft sees past the Earth: 0 in the umbra, 1 in
    sunlight, between in the penumbra (and in the annulus beyond the umbra's tip).

    Parameters
    ----------
    r_sc_m : array_like, shape (..., 3) (component ``axis``)
        Geocentric spacecraft position, m, outside the Earth.
    r_sun_m : array_like, broadcastable against ``r_sc_m``
        Geocentric Sun position, m.
    axis : int
        Component axis.
    r_earth_m : float
        Radius of the shadowing sphere, m (the WGS-84 equatorial radius; brahe's is
        6 378 136.3 m).

    Returns
    -------
    jax.Array
        The broadcast shape of the inputs without the component axis.

    Notes
    -----
    Montenbruck & Gill §3.4.2, eqs. 3.79–3.87. Seen from the spacecraft, the Sun's disc has
    the apparent radius ``a = asin(R_sun/|s − r|)``, the Earth's ``b = asin(R_E/|r|)``, and
    their centres are ``c = ∠(−r, s − r)`` apart. With ``|a − b| < c < a + b`` the discs
    overlap in the area ``A = a² acos(x/a) + b² acos((c − x)/b) − c y``, where
    ``x = (c² + a² − b²)/(2c)`` and ``y = √(a² − x²)``, and the fraction is ``1 − A/(π a²)``
    (written here with ``atan2`` for the acos, see the comments, which brings the float64
    error in low orbit from 7e-9, brahe's, to 2e-12);
    ``c ≥ a + b`` is sunlight; ``c ≤ b − a`` the umbra. ``c ≤ a − b`` (the Earth's disc
    inside the Sun's, only beyond the umbra's tip 1.4 million km away) leaves ``1 − b²/a²``,
    where brahe returns 0.

    The branches are chosen with ``jnp.where`` on arguments made safe first: the overlap is
    evaluated only at a ``c`` inside the penumbra, so neither the value nor the gradient of
    an unused branch is NaN (on the shadow's axis c = 0 and acos has an infinite slope).
    """
    r_sc_m = jnp.asarray(r_sc_m)
    to_sun = jnp.asarray(r_sun_m) - r_sc_m
    d_sun = jnp.linalg.norm(to_sun, axis=axis)
    d_earth = jnp.linalg.norm(r_sc_m, axis=axis)
    a = jnp.arcsin(R_SUN_M / d_sun)
    b = jnp.arcsin(r_earth_m / d_earth)
    cos_c = -jnp.sum(r_sc_m * to_sun, axis=axis) / (d_earth * d_sun)

    # Compare cosines, not angles: acos has an infinite slope at ±1 (on the axis), and the
    # comparisons need no gradient. Angles in [0, π], so cos is decreasing.
    lit = cos_c <= jnp.cos(a + b)
    inside = cos_c >= jnp.cos(jnp.abs(a - b))
    partial = ~lit & ~inside

    mid_cos = 0.5 * (jnp.cos(a + b) + jnp.cos(jnp.abs(a - b)))  # a penumbra point
    c = jnp.arccos(jnp.where(partial, cos_c, mid_cos))
    # x: from the Sun's centre to the chord through the discs' crossings; y: half the chord.
    # (c − b)(c + b) rather than c² − b², and (a − x)(a + x): both differences are ~a ≪ b.
    x = ((c - b) * (c + b) + a**2) / (2.0 * c)
    y = jnp.sqrt(jnp.maximum((a - x) * (a + x), 0.0))  # > 0 inside; rounding at an edge
    # Half-angles of the two discs' segments by atan2, not acos((c − x)/b): that argument is
    # within 1e-5 of 1 in low orbit, where acos loses ~1e-13 that, over π a², is ~1e-9.
    overlap = (a**2 * jnp.arctan2(y, x) + b**2 * jnp.arctan2(y, c - x) - c * y)
    penumbra = 1.0 - overlap / (jnp.pi * a**2)

    # Inside the cone: the umbra (Earth's disc covers the Sun's) or the annulus (Sun's larger).
    covered = jnp.where(b >= a, 0.0, 1.0 - b**2 / a**2)
    return jnp.where(lit, 1.0, jnp.where(partial, penumbra, covered))


def shadow_fraction_cylindrical(r_sc_m, r_sun_m, axis=-1):
    """1.0 in sunlight, 0.0 in the Earth's cylindrical shadow (no penumbra).

    Parameters
    ----------
    r_sc_m : array_like, shape (..., 3) (component ``axis``)
        Geocentric spacecraft position, m.
    r_sun_m : array_like, broadcastable against ``r_sc_m``
        Geocentric Sun position, m.
    axis : int
        Component axis.

    Returns
    -------
    jax.Array
        The broadcast shape of the inputs without the component axis.

    Notes
    -----
    Montenbruck & Gill §3.4.2 (the cylindrical model, eq. 3.79): :func:`coopsat.astro.sun.sunlit`
    with the Sun's unit vector, the cylinder of radius ``R_EARTH_M`` behind the Earth.
    """
    r_sun_m = jnp.asarray(r_sun_m)
    return sunlit(r_sc_m, r_sun_m / jnp.linalg.norm(r_sun_m, axis=axis, keepdims=True), axis=axis)


class EphemerisDifference(NamedTuple):
    """Largest differences of the series from JPL DE421 over the sampled dates."""

    sun_position_m: float
    """Largest |r_series − r_DE421| of the Sun, m."""
    sun_direction_deg: float
    """Largest angle between the two geocentric Sun directions, degrees."""
    moon_position_m: float
    """Largest |r_series − r_DE421| of the Moon, m."""
    moon_direction_deg: float
    """Largest angle between the two geocentric Moon directions, degrees."""


def _angle_deg(u, v):
    """Angle between the rows of ``u`` and ``v`` (shape (n, 3)), degrees, by atan2 (accurate
    at small angles, where acos of the dot product is not)."""
    return np.degrees(np.arctan2(np.linalg.norm(np.cross(u, v), axis=-1), np.sum(u * v, axis=-1)))


def ephemeris_difference(jd_tt_start, jd_tt_end, samples=25):
    """Compare the Sun and Moon series with the JPL DE421 ephemeris (design time, NumPy).

    Parameters
    ----------
    jd_tt_start, jd_tt_end : float
        First and last Julian date, TT, days (DE421 covers 1899-07-29 to 2053-10-09).
    samples : int
        Evenly spaced dates compared, both ends included.

    Returns
    -------
    EphemerisDifference or None
        None when the optional packages ``jplephem`` and ``skyfield-data`` (which ships
        ``de421.bsp``) are not installed.

    Notes
    -----
    DE421 gives barycentric ICRF positions, km, against TDB; TDB − TT is periodic and below
    2 ms, so the date is passed as TT (in 2 ms the Moon moves 2 m, the Sun 60 m). The geocentric Sun is
    ``SSB→Sun − (SSB→EMB + EMB→Earth)``, the Moon ``EMB→Moon − EMB→Earth``: geometric
    positions, without light time or aberration (20″ for the Sun), which the series do not
    model either. ICRF and EME2000 differ by the frame bias, 0.02″, far below what is compared.
    The series are evaluated in float64 under ``jax.enable_x64`` (scoped: the process's
    setting is left as it was).
    """
    try:  # the optional extra: DE421 and its reader
        import skyfield_data
        from jplephem.spk import SPK
    except ImportError:
        return None

    with warnings.catch_warnings():
        # skyfield-data warns that its Earth-orientation file has expired: not used here.
        warnings.simplefilter("ignore", RuntimeWarning)
        data = Path(skyfield_data.get_skyfield_data_path())
    jd = np.linspace(float(jd_tt_start), float(jd_tt_end), int(samples))
    kernel = SPK.open(str(data / "de421.bsp"))
    try:
        earth_km = kernel[0, 3].compute(jd) + kernel[3, 399].compute(jd)
        sun_ref = (kernel[0, 10].compute(jd) - earth_km).T * 1e3
        moon_ref = (kernel[3, 301].compute(jd) - kernel[3, 399].compute(jd)).T * 1e3
    finally:
        kernel.close()
    with jax.enable_x64(True):  # float64 for this evaluation only, whatever the process chose
        sun = np.asarray(sun_position_eme2000_m(jd))
        moon = np.asarray(moon_position_eme2000_m(jd))
    return EphemerisDifference(
        sun_position_m=float(np.max(np.linalg.norm(sun - sun_ref, axis=-1))),
        sun_direction_deg=float(np.max(_angle_deg(sun, sun_ref))),
        moon_position_m=float(np.max(np.linalg.norm(moon - moon_ref, axis=-1))),
        moon_direction_deg=float(np.max(_angle_deg(moon, moon_ref))),
    )
