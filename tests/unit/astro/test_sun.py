"""The low-precision Sun (Astronomical Almanac, Vallado Alg. 29) against astropy, and the
cylindrical shadow against hand-built cases.

astropy's ``get_sun`` (VSOP87/ERFA ephemeris, GCRS) transformed to ``PrecessedGeocentric``
with the equinox at the date is the independent reference for the mean equator and equinox of
date. Measured (this file's dates): direction 0.0001°–0.0039° from astropy, distance within
5.3e-5 relative. The same astropy Sun in GCRS (J2000 axes) is 0.26° away in 2018 and 0.57° in
2040 (the precession of the equinox), far outside the 0.02° tolerance, which pins the frame.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from astropy import units as u
from astropy.coordinates import GCRS, PrecessedGeocentric, get_sun
from astropy.time import Time
from astropy.utils import iers

from coopsat.astro.earth import julian_date_utc
from coopsat.astro.sun import sun_direction_eci, sun_position_eci_m, sunlit

AU_M = 149597870700.0  # IAU 2012 astronomical unit, m
R_EQ_M = 6378137.0  # WGS-84 equatorial radius, m (the shadow cylinder's radius)

DATES = [
    "1990-01-01T00:00:00",
    "1995-03-20T00:00:00",
    "2000-01-01T12:00:00",
    "2005-06-21T12:00:00",
    "2010-09-23T06:00:00",
    "2018-07-12T03:00:00",
    "2024-12-21T18:00:00",
    "2030-04-15T09:30:00",
    "2035-12-01T18:30:00",
    "2040-12-31T23:00:00",
]

# The Almanac's stated accuracy is 0.01° (1950–2050); allow twice that for astropy's apparent
# Sun (aberration) and TT − UT1 (69 s, 0.0008°), which the low-precision formula ignores.
ANGLE_TOL_DEG = 0.02
DIST_TOL_REL = 1e-4


def angle_deg(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    cos = np.sum(a * b, axis=-1) / (np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1))
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def astropy_sun_m(iso, frame):
    """Geocentric Sun from astropy, m: ``frame`` 'of-date' (PrecessedGeocentric) or 'gcrs'."""
    with iers.conf.set_temp("auto_download", False):
        t = Time(iso, scale="utc")
        sun = get_sun(t)
        target = PrecessedGeocentric(equinox=t, obstime=t) if frame == "of-date" else GCRS(obstime=t)
        return sun.transform_to(target).cartesian.xyz.to(u.m).value


# ----------------------------------------------------------------------------- against astropy


@pytest.mark.filterwarnings("ignore::erfa.ErfaWarning")  # years past the leap-second table: "dubious year"
@pytest.mark.parametrize("iso", DATES)
def test_sun_direction_and_distance_match_astropy_of_date(iso):
    ref = astropy_sun_m(iso, "of-date")
    jd = julian_date_utc(iso)
    direction = np.asarray(sun_direction_eci(jd))
    position = np.asarray(sun_position_eci_m(jd))
    assert direction.shape == (3,) and position.shape == (3,)
    assert angle_deg(direction, ref) < ANGLE_TOL_DEG
    assert angle_deg(position, ref) < ANGLE_TOL_DEG
    assert np.linalg.norm(position) == pytest.approx(np.linalg.norm(ref), rel=DIST_TOL_REL)
    # Sanity of the reference itself: the Sun is 0.983–1.017 AU away.
    assert 0.983 < np.linalg.norm(ref) / AU_M < 1.0168


@pytest.mark.filterwarnings("ignore::erfa.ErfaWarning")
@pytest.mark.parametrize("iso", ["2018-07-12T03:00:00", "2040-12-31T23:00:00"])
def test_sun_is_in_the_equinox_of_date_not_j2000(iso):
    # 18.5 and 41 years of precession (50.3"/yr in longitude) move the equinox by 0.26° and
    # 0.57°: the J2000 (GCRS) direction is well outside the tolerance, the of-date one inside.
    ours = np.asarray(sun_direction_eci(julian_date_utc(iso)))
    of_date, gcrs = astropy_sun_m(iso, "of-date"), astropy_sun_m(iso, "gcrs")
    frame_gap = angle_deg(of_date, gcrs)
    assert frame_gap > 10 * ANGLE_TOL_DEG
    assert angle_deg(ours, gcrs) > 10 * ANGLE_TOL_DEG
    assert angle_deg(ours, gcrs) == pytest.approx(frame_gap, abs=ANGLE_TOL_DEG)
    assert angle_deg(ours, of_date) < ANGLE_TOL_DEG


# ----------------------------------------------------------------------------- shape, jit, rate


def test_sun_batches_over_dates_and_has_unit_norm():
    jd0 = julian_date_utc("2018-07-12T03:00:00")
    jd = jd0 + np.arange(10.0).reshape(2, 5) * 37.3
    direction = np.asarray(sun_direction_eci(jd))
    position = np.asarray(sun_position_eci_m(jd))
    assert direction.shape == (2, 5, 3) and position.shape == (2, 5, 3)
    np.testing.assert_allclose(np.linalg.norm(direction, axis=-1), 1.0, rtol=0, atol=1e-15)
    # Element by element as scalars: XLA's vectorised sine and the scalar one round apart by
    # a few ulps of the ~120 rad mean longitude (1.4e-14), so 1e-13, not exact equality.
    for i in range(2):
        for j in range(5):
            np.testing.assert_allclose(direction[i, j], sun_direction_eci(jd[i, j]), rtol=0, atol=1e-13)
            np.testing.assert_allclose(position[i, j], sun_position_eci_m(jd[i, j]), rtol=1e-13, atol=0)
    np.testing.assert_allclose(direction, position / np.linalg.norm(position, axis=-1, keepdims=True), atol=1e-15)


def test_sun_traces_under_jit_with_a_traced_date():
    jd = julian_date_utc("2018-07-12T03:00:00")
    jitted = jax.jit(sun_direction_eci)
    np.testing.assert_allclose(jitted(jnp.asarray(jd)), sun_direction_eci(jd), rtol=0, atol=1e-15)
    # A traced date inside a larger traced computation (start date + elapsed seconds).
    f = jax.jit(lambda jd0, t_s: sun_direction_eci(jd0 + t_s / 86400.0))
    t_s = jnp.array([0.0, 3600.0, 86400.0])
    np.testing.assert_allclose(f(jd, t_s), sun_direction_eci(jd + np.asarray(t_s) / 86400.0), rtol=0, atol=1e-15)
    assert f(jd, t_s).shape == (3, 3)


@pytest.mark.parametrize("iso", ["2019-01-03T12:00:00", "2019-07-04T12:00:00", "2019-04-01T00:00:00"])
def test_sun_apparent_rate_is_keplerian(iso):
    # The Sun's geocentric motion is 360°/365.2596 d (anomalistic year) × (1 + e cos ν)² / (1 − e²)^1.5 with
    # e = 0.0167: 1.0194°/d at perihelion (early January), 0.9532°/d at aphelion (early July).
    # jacfwd through the traced date; 1 day ≈ 1/36525 of the polynomial's unit.
    jd = julian_date_utc(iso)
    rate_deg_d = np.degrees(np.linalg.norm(np.asarray(jax.jacfwd(sun_direction_eci)(jd))))
    assert 0.950 < rate_deg_d < 1.022
    if iso.startswith("2019-01"):
        assert rate_deg_d == pytest.approx(1.0194, abs=0.002)
    if iso.startswith("2019-07"):
        assert rate_deg_d == pytest.approx(0.9532, abs=0.002)


# ----------------------------------------------------------------------------- shadow

SUN_X = np.array([1.0, 0.0, 0.0])


@pytest.mark.parametrize(
    ("r_m", "lit"),
    [
        ([-7e6, 0.0, 0.0], 0.0),  # behind the Earth on the Sun line
        ([7e6, 0.0, 0.0], 1.0),  # sunward side on the line
        ([7e6, 1e6, -2e6], 1.0),  # sunward side, within R_E of the line
        ([-7e6, 0.0, 7e6], 1.0),  # behind, but 7000 km (> R_E) off the line
        ([-4.2e7, 0.0, -R_EQ_M + 1e3], 0.0),  # far behind, 1 km inside the cylinder
        ([-4.2e7, 0.0, -R_EQ_M - 1e3], 1.0),  # far behind, 1 km outside it
        ([-1e5, R_EQ_M - 1e3, 0.0], 0.0),  # just past the terminator plane, inside
        ([1e5, R_EQ_M - 1e3, 0.0], 1.0),  # just before it
    ],
)
def test_sunlit_hand_cases(r_m, lit):
    assert float(sunlit(np.asarray(r_m), SUN_X)) == lit


def test_sunlit_with_an_oblique_sun_batched_both_layouts_and_jit():
    sun = np.asarray(sun_direction_eci(julian_date_utc("2018-07-12T03:00:00")))
    # A unit vector perpendicular to the Sun line.
    side = np.cross(sun, [0.0, 0.0, 1.0])
    side /= np.linalg.norm(side)
    points = np.stack(
        [
            -7e6 * sun,  # behind: shadow
            7e6 * sun,  # in front: lit
            -7e6 * sun + 6.0e6 * side,  # behind, 6000 km off the line: shadow
            -7e6 * sun + 6.8e6 * side,  # behind, 6800 km off the line: lit
            -7e6 * sun - 6.8e6 * side,  # the other side: lit
            7e6 * side,  # above the terminator, 7000 km from the line: lit
        ]
    )
    expected = np.array([0.0, 1.0, 0.0, 1.0, 1.0, 1.0])
    np.testing.assert_array_equal(np.asarray(sunlit(points, sun)), expected)
    # Component-major (3, n) with the Sun broadcast as (3, 1).
    np.testing.assert_array_equal(np.asarray(sunlit(points.T, sun[:, None], axis=0)), expected)
    # One Sun direction per point, (3, n) against (3, n).
    suns = np.repeat(sun[:, None], len(points), axis=1)
    np.testing.assert_array_equal(np.asarray(sunlit(points.T, suns, axis=0)), expected)
    # Flipping the Sun swaps front and back.
    np.testing.assert_array_equal(np.asarray(sunlit(points, -sun))[:2], [1.0, 0.0])
    # Under jit, with a leading batch dimension in the (3, n) layout: (2, 3, n) with axis=1.
    stacked = np.stack([points.T, points.T])
    out = jax.jit(lambda r, s: sunlit(r, s, axis=1))(stacked, sun[None, :, None])
    assert out.shape == (2, len(points))
    np.testing.assert_array_equal(np.asarray(out), np.stack([expected, expected]))
