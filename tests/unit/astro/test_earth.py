"""The rotating Earth (SPEC §0, §5): time scales and GMST against astropy, WGS-84 against pymap3d,
ECEF/ECI rotation, an Earth-fixed point's motion, elevation, and the 2019 paper's eqs. 5–6."""

import jax
import jax.numpy as jnp
import numpy as np
import pymap3d
import pytest
from astropy.time import Time
from astropy.utils import iers

from coopsat.astro.earth import (
    OMEGA_EARTH_RAD_S,
    WGS84_A_M,
    WGS84_B_M,
    WGS84_F,
    ecef_to_geodetic,
    elevation_rad,
    geocentric_paper_eci,
    geodetic_to_ecef,
    gmst_rad,
    julian_date_utc,
    up_ecef,
)
from coopsat.astro.earth_orientation import earth_fixed_point_gcrf, z_rotation


def ecef_to_eci(vec, theta):
    """A bare z turn, ``R3(−θ) v`` (NumPy, written out here), for placing points on the papers' Earth."""
    c, s = np.cos(theta), np.sin(theta)
    x, y, z = np.moveaxis(np.asarray(vec, dtype=float), -1, 0)
    return np.stack([c * x - s * y, s * x + c * y, z], axis=-1)

# 1990–2030, none on a day that ends in a leap second (see test_julian_date_on_leap_second_day).
DATES = [
    "1990-03-01T00:00:00",
    "1999-12-31T23:59:59.250",
    "2000-01-01T12:00:00",
    "2010-07-04T18:17:19",
    "2018-06-21T04:00:00",
    "2024-02-29T23:59:59.500",
    "2030-12-31T06:30:00",
]
# Dates inside the IERS-B table bundled with astropy (UT1 − UTC known without a download).
IERS_B_DATES = DATES[:6]

# Float64 spacing of a Julian date near 2.45e6 d is 4.7e-10 d; two roundings (ours, astropy's
# jd1 + jd2) make up to about 1e-9 d = 86 µs.
JD_TOL_D = 1e-9
# That JD resolution is 4.7e-10 d × 2π × 1.0027 rad/d = 3e-9 rad of sidereal angle.
GMST_TOL_RAD = 5e-9


def wrap(angle_rad):
    """Angle difference wrapped to (−π, π]."""
    return np.angle(np.exp(1j * np.asarray(angle_rad)))


# ----------------------------------------------------------------------------- time and GMST


@pytest.mark.filterwarnings("ignore::erfa.ErfaWarning")  # 2030: "dubious year" (future leap seconds unknown)
@pytest.mark.parametrize("iso", DATES)
def test_julian_date_matches_astropy(iso):
    assert julian_date_utc(iso) == pytest.approx(Time(iso, scale="utc").jd, abs=JD_TOL_D, rel=0)


def test_julian_date_of_zoned_instant_is_converted_to_utc():
    assert julian_date_utc("2018-06-21T06:00:00+02:00") == julian_date_utc("2018-06-21T04:00:00")
    assert julian_date_utc("2000-01-01T12:00:00") == 2451545.0


def test_julian_date_on_leap_second_day():
    # 2016-12-31 ended in a leap second; astropy stretches that day to 86401 s, POSIX time does
    # not, so at noon the two differ by half a second (the documented convention).
    iso = "2016-12-31T12:00:00"
    diff_s = (julian_date_utc(iso) - Time(iso, scale="utc").jd) * 86400.0
    assert diff_s == pytest.approx(0.5, abs=1e-4)


@pytest.mark.filterwarnings("ignore::erfa.ErfaWarning")
@pytest.mark.parametrize("iso", DATES)
def test_gmst_matches_astropy_iau1982_formula(iso):
    # The same Julian date handed to astropy on the UT1 scale: this compares the IAU-82
    # polynomial alone (erfa.gmst82), with no UT1 − UTC table involved.
    jd = julian_date_utc(iso)
    t = Time(jd, format="jd", scale="ut1")
    expected = t.sidereal_time("mean", "greenwich", model="IAU1982").rad
    assert abs(wrap(gmst_rad(jd) - expected)) < GMST_TOL_RAD
    assert 0.0 <= gmst_rad(jd) < 2.0 * np.pi


@pytest.mark.parametrize("iso", IERS_B_DATES)
def test_gmst_of_utc_differs_from_astropy_by_ut1_minus_utc(iso):
    # With the instant on the UTC scale astropy converts it to the real UT1 (IERS-B table, no
    # download), while we take UT1 = UTC (SPEC §0). The difference is then exactly the Earth
    # rotation during UT1 − UTC, which reaches 0.9 s, i.e. 6.6e-5 rad (13.5 arcsec): an
    # "about 1 arcsec" tolerance would not hold in general (2000-01-01: 0.355 s, 2.6e-5 rad).
    with iers.conf.set_temp("auto_download", False):
        t = Time(iso, scale="utc")
        dut1_s = float((t.ut1.jd1 - t.jd1) + (t.ut1.jd2 - t.jd2)) * 86400.0
        astropy_rad = t.sidereal_time("mean", "greenwich", model="IAU1982").rad
    diff = wrap(gmst_rad(julian_date_utc(iso)) - astropy_rad)
    assert abs(dut1_s) <= 0.9
    assert abs(diff) <= 0.9 * OMEGA_EARTH_RAD_S
    assert diff == pytest.approx(-OMEGA_EARTH_RAD_S * dut1_s, abs=GMST_TOL_RAD)


# ----------------------------------------------------------------------------- WGS-84

LAT_GRID_RAD = np.radians(np.concatenate([[-90.0, -89.999], np.linspace(-85.0, 85.0, 35), [89.999, 90.0]]))
LON_GRID_RAD = np.radians(np.linspace(-180.0, 180.0, 13))
HEIGHTS_M = np.array([-5000.0, -100.0, 0.0, 1000.0, 10e3, 500e3, 36000e3])


def grid(heights_m):
    return np.meshgrid(LAT_GRID_RAD, LON_GRID_RAD, heights_m, indexing="ij")


def test_geodetic_to_ecef_matches_pymap3d():
    lat, lon, h = grid(HEIGHTS_M)
    ours = np.asarray(geodetic_to_ecef(lat, lon, h))
    theirs = np.stack(pymap3d.geodetic2ecef(lat, lon, h, deg=False), axis=-1)
    assert ours.shape == lat.shape + (3,)
    assert np.max(np.abs(ours - theirs)) < 1e-6


def test_ecef_to_geodetic_matches_pymap3d_near_the_surface():
    # pymap3d's inverse (You 2000, one Newton step on the reduced latitude) is itself only
    # approximate away from the surface: its latitude is 1e-10 rad (0.7 mm) off at 500 km and
    # 2e-6 rad at 36000 km, as the round trip through its own forward formula shows. The grid
    # against pymap3d therefore stops at 10 km; higher points are checked by the round trips
    # below.
    lat, lon, h = grid(HEIGHTS_M[HEIGHTS_M <= 10e3])
    r = np.asarray(geodetic_to_ecef(lat, lon, h))
    ours = ecef_to_geodetic(r)
    theirs = pymap3d.ecef2geodetic(r[..., 0], r[..., 1], r[..., 2], deg=False)
    assert np.max(np.abs(ours[0] - theirs[0])) < 1e-12
    assert np.max(np.abs(wrap(ours[1] - theirs[1]))) < 1e-12
    assert np.max(np.abs(ours[2] - theirs[2])) < 1e-6


def test_ecef_to_geodetic_inverts_pymap3d_forward_formula_at_all_heights():
    lat, lon, h = grid(HEIGHTS_M)
    r = np.stack(pymap3d.geodetic2ecef(lat, lon, h, deg=False), axis=-1)
    lat2, lon2, h2 = ecef_to_geodetic(r)
    assert np.max(np.abs(lat2 - lat)) < 1e-12
    assert np.max(np.abs(h2 - h)) < 1e-6
    off_pole = np.abs(lat) < np.radians(89.0)
    assert np.max(np.abs(wrap(lon2 - lon)[off_pole])) < 1e-12
    back = np.stack(pymap3d.geodetic2ecef(lat2, lon2, h2, deg=False), axis=-1)
    assert np.max(np.linalg.norm(back - r, axis=-1)) < 1e-6


def test_ecef_to_geodetic_hand_values():
    lat, lon, h = ecef_to_geodetic(np.array([[WGS84_A_M, 0.0, 0.0], [0.0, 0.0, -WGS84_B_M - 10.0], [0.0, -7e6, 0.0]]))
    np.testing.assert_allclose(lat, [0.0, -np.pi / 2, 0.0], atol=1e-15)
    np.testing.assert_allclose(h, [0.0, 10.0, 7e6 - WGS84_A_M], atol=1e-8)
    assert lon[2] == pytest.approx(-np.pi / 2, abs=1e-15)


def test_up_ecef_is_the_ellipsoid_normal():
    lat, lon, _ = grid([0.0])
    lat, lon = lat[..., 0], lon[..., 0]
    up = np.asarray(up_ecef(lat, lon))
    np.testing.assert_allclose(np.linalg.norm(up, axis=-1), 1.0, atol=1e-15)
    # Gradient of x²/a² + y²/a² + z²/b² at the surface point, normalised.
    x, y, z = np.moveaxis(np.asarray(geodetic_to_ecef(lat, lon, 0.0)), -1, 0)
    grad = np.stack([x / WGS84_A_M**2, y / WGS84_A_M**2, z / WGS84_B_M**2], axis=-1)
    np.testing.assert_allclose(up, grad / np.linalg.norm(grad, axis=-1, keepdims=True), atol=1e-15)
    # Height is measured along it.
    step = np.asarray(geodetic_to_ecef(lat, lon, 1000.0)) - np.asarray(geodetic_to_ecef(lat, lon, 0.0))
    np.testing.assert_allclose(step, 1000.0 * up, atol=1e-8)


# ----------------------------------------------------------------------------- ECEF and ECI


TARGET_ECEF_M = np.asarray(geodetic_to_ecef(np.radians(40.0), np.radians(-105.0), 1600.0))


TURN = z_rotation(1.234, 86400.0)  # the papers' Earth, θ = 1.234 + ω_E t


def earth_fixed_point_eci(r_ecef_m, t_s, table=TURN, axis=-1):
    return earth_fixed_point_gcrf(r_ecef_m, t_s, table, axis)


def test_earth_fixed_point_velocity_and_acceleration_are_derivatives_of_position():
    times = np.array([0.0, 137.0, 5400.0, 86400.0])

    def position(t):
        return earth_fixed_point_eci(TARGET_ECEF_M, t)[0]

    for t in times:
        r, v, a = (np.asarray(x) for x in earth_fixed_point_eci(TARGET_ECEF_M, t))
        # Automatic differentiation of the position formula.
        np.testing.assert_allclose(jax.jacfwd(position)(t), v, rtol=0, atol=1e-12)
        np.testing.assert_allclose(jax.jacfwd(jax.jacfwd(position))(t), a, rtol=0, atol=1e-15)
        # Central differences (independent of JAX), step 1 s: truncation r ω³ h²/6 ≈ 4e-7 m/s
        # for v and r ω⁴ h²/6 ≈ 3e-11 m/s² for a.
        h = 1.0
        rp, vp, _ = (np.asarray(x) for x in earth_fixed_point_eci(TARGET_ECEF_M, t + h))
        rm, vm, _ = (np.asarray(x) for x in earth_fixed_point_eci(TARGET_ECEF_M, t - h))
        np.testing.assert_allclose((rp - rm) / (2 * h), v, rtol=0, atol=1e-6)
        np.testing.assert_allclose((vp - vm) / (2 * h), a, rtol=0, atol=1e-10)
        # Speed of a point at 40° latitude: ω × distance from the axis (≈ 356 m/s).
        assert np.linalg.norm(v) == pytest.approx(OMEGA_EARTH_RAD_S * np.hypot(*TARGET_ECEF_M[:2]), rel=1e-14)


def test_earth_fixed_point_component_major_and_jit():
    points = np.stack([TARGET_ECEF_M, -2.0 * TARGET_ECEF_M, np.array([0.0, 0.0, WGS84_B_M])])
    t = np.array([0.0, 100.0, 1e4])
    turn = z_rotation(0.5, 1e4)
    last = [np.asarray(x) for x in earth_fixed_point_eci(points, t, turn)]
    first = jax.jit(lambda p, tt: earth_fixed_point_eci(p, tt, turn, axis=0))(points.T, t)
    for x, y in zip(last, first):
        np.testing.assert_allclose(np.asarray(y).T, x, rtol=0, atol=1e-9)
    # The pole does not move.
    np.testing.assert_allclose(last[1][2], 0.0, atol=0)


def _enu(lat_rad, lon_rad):
    east = np.array([-np.sin(lon_rad), np.cos(lon_rad), 0.0])
    up = np.asarray(up_ecef(lat_rad, lon_rad))
    return east, np.cross(up, east), up


@pytest.mark.parametrize("theta", [0.0, 2.1])
def test_elevation_zenith_horizon_and_between(theta):
    lat, lon = np.radians(40.0), np.radians(-105.0)
    east, north, up = _enu(lat, lon)
    target_ecef = np.asarray(geodetic_to_ecef(lat, lon, 1600.0))
    cases = [
        (500e3 * up, 90.0),
        (2000e3 * east, 0.0),
        (1500e3 * north, 0.0),
        (1e6 * (np.cos(np.radians(30.0)) * north + np.sin(np.radians(30.0)) * up), 30.0),
        (1e6 * (np.cos(np.radians(10.0)) * east - np.sin(np.radians(10.0)) * up), -10.0),
    ]
    sc_ecef = np.stack([target_ecef + offset for offset, _ in cases])
    expected = np.radians([deg for _, deg in cases])
    to_eci = lambda x: np.asarray(ecef_to_eci(x, theta))  # noqa: E731
    el = np.asarray(elevation_rad(to_eci(sc_ecef), to_eci(target_ecef), to_eci(up)))
    # asin near 1 loses half the digits: a rounding of 1e-16 in the sine is 1.5e-8 rad at the zenith.
    np.testing.assert_allclose(el, expected, rtol=0, atol=2e-8)
    np.testing.assert_allclose(el[1:], expected[1:], rtol=0, atol=1e-12)
    el0 = np.asarray(elevation_rad(to_eci(sc_ecef).T, to_eci(target_ecef)[:, None], to_eci(up)[:, None], axis=0))
    np.testing.assert_allclose(el0, el, rtol=0, atol=0)


# ----------------------------------------------------------------------------- the paper's eqs. 5–6


def test_geocentric_paper_is_exact_on_the_ellipsoid():
    lat = np.radians(np.array([-90.0, -60.0, -45.0, -10.0, 0.0, 10.0, 45.0, 60.0, 89.9, 90.0]))
    lon = np.radians(np.linspace(-170.0, 170.0, lat.size))
    theta = 0.7
    paper = np.asarray(geocentric_paper_eci(lat, lon, 0.0, theta))
    exact = np.asarray(ecef_to_eci(geodetic_to_ecef(lat, lon, 0.0), theta))
    # H = 0: the same point up to rounding (a few nm on 6.4e6 m).
    assert np.max(np.linalg.norm(paper - exact, axis=-1)) < 1e-6


def test_geocentric_paper_puts_height_along_the_geocentric_direction():
    lat, lon, h, theta = np.radians(45.0), np.radians(20.0), 1000.0, 0.3
    paper = np.asarray(geocentric_paper_eci(lat, lon, h, theta))
    exact = np.asarray(ecef_to_eci(geodetic_to_ecef(lat, lon, h), theta))
    gap_m = np.linalg.norm(paper - exact)
    # The height goes along the geocentric direction, δ = B − B' (0.192° at 45°) away from the
    # normal: the points are 2 H sin(δ/2) apart.
    delta = lat - np.arctan((1.0 - WGS84_F) ** 2 * np.tan(lat))
    assert gap_m == pytest.approx(2.0 * h * np.sin(delta / 2.0), rel=1e-6)
    assert 3.0 < gap_m < 4.0
    # Both are 1 km from the surface point, and the paper's point is on the geocentric ray.
    surface = np.asarray(ecef_to_eci(geodetic_to_ecef(lat, lon, 0.0), theta))
    assert np.linalg.norm(paper - surface) == pytest.approx(h, rel=1e-9)
    np.testing.assert_allclose(np.cross(paper, surface), 0.0, atol=1e-9 * np.linalg.norm(paper) ** 2)
    # At the equator and the poles the two directions coincide.
    for b in (0.0, np.pi / 2, -np.pi / 2):
        gap = np.asarray(geocentric_paper_eci(b, lon, h, theta)) - np.asarray(ecef_to_eci(geodetic_to_ecef(b, lon, h), theta))
        assert np.linalg.norm(gap) < 1e-6


def test_geocentric_paper_traces_under_jit():
    f = jax.jit(geocentric_paper_eci)
    np.testing.assert_allclose(f(0.7, 0.1, 100.0, 2.0), geocentric_paper_eci(0.7, 0.1, 100.0, 2.0), rtol=1e-15)
    assert jnp.asarray(f(np.zeros(4), 0.0, 0.0, np.zeros(4))).shape == (4, 3)
