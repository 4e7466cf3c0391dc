"""The analytic Sun and Moon, the third-body pull and the conical shadow
(coopsat.astro.ephemeris) against brahe 1.8 (the same Montenbruck & Gill series and formulas,
compiled from Rust) and against the JPL DE421 ephemeris.

Measured when written: Sun within 0.58 m of brahe, Moon within 0.021 m (20 dates, 1990–2050);
third-body accelerations within 1.7e-11 relative; conical shadow within 6.7e-9 of brahe, which
is brahe's own float64 error (ours is within 1.5e-12 of an extended-precision evaluation).
Against DE421, 1990–2050: Sun 0.167° (the series' fixed perigee, −0.3225° a century from
J2000), Moon 0.090° and 561 km.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from coopsat.astro.earth import JD_J2000
from coopsat.astro.ephemeris import (
    MU_MOON_M3_S2,
    R_SUN_M,
    ephemeris_difference,
    moon_position_eme2000_m,
    shadow_fraction_conical,
    shadow_fraction_cylindrical,
    sun_position_eme2000_m,
    third_body_accel,
)

bh = pytest.importorskip("brahe")


# 20 instants, 1990–2050, at scattered times of day so the Moon's fast terms are sampled.
DATES = [(1990 + 3 * k, 1 + (5 * k) % 12, 1 + (7 * k) % 28, (5 * k) % 24, (13 * k) % 60) for k in range(20)]


def _epoch(year, month, day, hour, minute):
    return bh.Epoch.from_datetime(year, month, day, hour, minute, 0.0, 0.0, bh.TimeSystem.TT)


def _jd_tt(epc):
    return epc.jd_as_time_system(bh.TimeSystem.TT)


# brahe rotates the series' EME2000 vector into the GCRF by the frame bias (17 km at the Sun);
# its inverse brings brahe back to the frame the series define.
GCRF_TO_EME2000 = bh.rotation_gcrf_to_eme2000()

# A float64 Julian date near 2.45e6 d rounds to 2^-31 d (40 µs; half of it at most), while
# brahe keeps the epoch in finer parts: at the Sun's 30 km/s relative to the Earth that is
# 0.6 m, at the Moon's 1 km/s 0.02 m. The arithmetic of the series adds ~1e-12 relative.
SUN_VS_BRAHE_M = 1.0
MOON_VS_BRAHE_M = 0.05


@pytest.mark.parametrize("date", DATES)
def test_sun_and_moon_match_brahe(date):
    epc = _epoch(*date)
    jd = _jd_tt(epc)
    sun = np.asarray(sun_position_eme2000_m(jd))
    moon = np.asarray(moon_position_eme2000_m(jd))
    assert sun.shape == (3,) and moon.shape == (3,)
    np.testing.assert_allclose(sun, GCRF_TO_EME2000 @ bh.sun_position(epc), rtol=0, atol=SUN_VS_BRAHE_M)
    np.testing.assert_allclose(moon, GCRF_TO_EME2000 @ bh.moon_position(epc), rtol=0, atol=MOON_VS_BRAHE_M)


def test_frame_is_eme2000_not_gcrf():
    """The frame bias moves the Sun by kilometres: a test against brahe's GCRF vector unrotated
    would fail, so the comparison above pins the frame."""
    epc = _epoch(2024, 3, 20, 3, 0)
    sun = np.asarray(sun_position_eme2000_m(_jd_tt(epc)))
    assert np.linalg.norm(sun - bh.sun_position(epc)) > 1e3


def _jd(year):
    return JD_J2000 + (year - 2000.0) * 365.25


@pytest.fixture(scope="module")
def de421_1990_2050():
    result = ephemeris_difference(_jd(1990.0), _jd(2050.0), samples=2000)
    if result is None:
        pytest.skip("jplephem and skyfield-data (DE421) not installed")
    return result


# The Sun series keeps the longitude of perigee fixed, which advances 0.3225° a century in the
# J2000 frame: λ falls behind by 0.3225° |T| (fit to DE421; brahe shares it). Around that
# drift DE421 differs by 0.0074° at most (0.0013° offset), and in distance by 8e-5: allow
# 0.01° beyond the drift. |T| ≤ 0.5 century over 1990–2050 (0.05 over 1995–2005).
SUN_DRIFT_DEG_PER_CENTURY = 0.3225
SUN_RESIDUAL_DEG = 0.01
SUN_DISTANCE_REL = 1e-4
SUN_MAX_DISTANCE_M = 1.521e11  # aphelion


def _sun_bounds(centuries):
    direction_deg = SUN_DRIFT_DEG_PER_CENTURY * centuries + SUN_RESIDUAL_DEG
    return direction_deg, SUN_MAX_DISTANCE_M * (np.radians(direction_deg) + SUN_DISTANCE_REL)


def test_sun_against_de421(de421_1990_2050):
    direction_deg, position_m = _sun_bounds(0.5)
    # measured: 0.1665° and 4.35e8 m (in 2050)
    assert de421_1990_2050.sun_direction_deg < direction_deg
    assert de421_1990_2050.sun_position_m < position_m


def test_sun_against_de421_near_j2000():
    """Within five years of J2000 the drift is small and the series is good to 0.026°."""
    result = ephemeris_difference(_jd(1995.0), _jd(2005.0), samples=500)
    if result is None:
        pytest.skip("jplephem and skyfield-data (DE421) not installed")
    direction_deg, position_m = _sun_bounds(0.05)
    # measured: 0.0198° and 5.1e7 m (1995)
    assert result.sun_direction_deg < direction_deg
    assert result.sun_position_m < position_m


# The lunar series is good to several arcminutes and some hundreds of km (M&G §3.3.2); its mean
# longitude carries its precession term, so the error does not grow from J2000. Allow 6′ and
# 600 km; measured 0.079° (4.8′) and 541 km over these 2000 dates, 0.090° and 561 km over
# 60 000 (9 h apart).
MOON_DIRECTION_DEG = 0.1
MOON_POSITION_M = 600e3


def test_moon_against_de421(de421_1990_2050):
    assert de421_1990_2050.moon_direction_deg < MOON_DIRECTION_DEG
    assert de421_1990_2050.moon_position_m < MOON_POSITION_M


# --- third body -----------------------------------------------------------------------------

R_LEO_M = bh.R_EARTH + 500e3

LEO_POSITIONS = np.array([
    [R_LEO_M, 0.0, 0.0],
    [0.0, -R_LEO_M, 0.0],
    [0.0, 0.0, R_LEO_M],
    R_LEO_M * np.array([0.6, -0.48, 0.64]),
])

# The perturbation (1e-6 m/s²) is the difference of two pulls ~1e2–1e4 times larger, so float64
# rounding leaves up to ~1e-16 × 1e4 of it (measured 1.7e-11); both sides use the same body
# position and GM.
THIRD_BODY_RTOL = 1e-9


@pytest.mark.parametrize("date", DATES[::5])
def test_third_body_matches_brahe(date):
    epc = _epoch(*date)
    for body, gm, brahe_accel in ((bh.sun_position(epc), bh.GM_SUN, bh.accel_third_body_sun),
                                  (bh.moon_position(epc), bh.GM_MOON, bh.accel_third_body_moon)):
        ours = np.asarray(third_body_accel(LEO_POSITIONS, body, gm))
        theirs = np.array([brahe_accel(epc, r) for r in LEO_POSITIONS])
        scale = np.linalg.norm(theirs, axis=-1, keepdims=True)
        np.testing.assert_allclose(ours / scale, theirs / scale, rtol=0, atol=THIRD_BODY_RTOL)


def test_moon_gm_is_brahes():
    assert MU_MOON_M3_S2 == bh.GM_MOON


@pytest.mark.parametrize("body_distance_m", [1.496e11, 3.844e8])
def test_third_body_is_the_tidal_pull_far_away(body_distance_m):
    """Independent of brahe: far from the body the pull is the tide μ/s³ (3 ŝ(ŝ·r) − r); the next
    term is smaller by ~(3/2)|r|/|s| (0.03 at the Moon), so allow 3 |r|/|s|. Without the
    indirect term the result would be the full pull, |s|²/|r|² times larger."""
    s = body_distance_m * np.array([0.36, 0.48, 0.8])
    s_hat = s / np.linalg.norm(s)
    mu = 4.9e12
    for r in LEO_POSITIONS:
        tide = mu / body_distance_m**3 * (3.0 * s_hat * (s_hat @ r) - r)
        got = np.asarray(third_body_accel(r, s, mu))
        assert np.linalg.norm(got - tide) < 3.0 * R_LEO_M / body_distance_m * np.linalg.norm(tide)


# The perturbation cancels the body's pull to 1e-4 here, so a reordered sum (jit's fusion)
# moves it by ~1e-16/1e-4: compare to 1e-10.
SHAPES_RTOL = 1e-10


def test_third_body_shapes_component_major():
    rng = np.random.default_rng(3)
    body = np.array([1.0e11, -8.0e10, 3.0e10])
    r_n3 = R_LEO_M * rng.normal(size=(5, 3)) / np.sqrt(3.0)
    expected = np.asarray(third_body_accel(r_n3, body, MU_MOON_M3_S2))  # (n, 3), axis=-1
    got = third_body_accel(r_n3.T, body[:, None], MU_MOON_M3_S2, axis=0)
    assert got.shape == (3, 5)
    np.testing.assert_allclose(np.asarray(got), expected.T, rtol=SHAPES_RTOL)
    r_3bn = np.stack([r_n3.T, 2.0 * r_n3.T])  # (B=2, 3, n) → (3, B, n)
    r_3bn = np.moveaxis(r_3bn, 1, 0)
    got_b = jax.jit(lambda r, s: third_body_accel(r, s, MU_MOON_M3_S2, axis=0))(r_3bn, body[:, None, None])
    assert got_b.shape == (3, 2, 5)
    np.testing.assert_allclose(np.asarray(got_b[:, 0]), expected.T, rtol=SHAPES_RTOL)
    np.testing.assert_allclose(np.asarray(got_b[:, 1]),
                               np.asarray(third_body_accel(2.0 * r_n3, body, MU_MOON_M3_S2)).T, rtol=SHAPES_RTOL)


# --- shadow ---------------------------------------------------------------------------------

def test_sun_radius_is_brahes():
    assert R_SUN_M == bh.R_SUN


def _shadow_sweep():
    """Positions in the plane of the Sun line at 500 km, 2 000 km and 36 000 km altitude, from
    the anti-Sun axis (deep umbra, c = 0 exactly) out through the penumbra to sunlight, finely
    where the shadow's edge lies, for a Sun of a real date."""
    r_sun = bh.sun_position(_epoch(2024, 6, 1, 0, 0))
    s_hat = r_sun / np.linalg.norm(r_sun)
    across = np.cross(s_hat, [0.0, 0.0, 1.0])
    across /= np.linalg.norm(across)
    positions = []
    for radius in (bh.R_EARTH + 500e3, bh.R_EARTH + 2000e3, bh.R_EARTH + 36000e3):
        edge = np.arcsin(bh.R_EARTH / radius)  # angle from the anti-Sun axis at the shadow's edge
        angles = np.concatenate([np.linspace(0.0, np.pi / 2, 91),
                                 edge + np.linspace(-0.02, 0.02, 801)])
        for angle in angles:
            positions.append(radius * (-np.cos(angle) * s_hat + np.sin(angle) * across))
    return np.array(positions), r_sun


# brahe evaluates M&G's overlap with acos((c − x)/b), an argument within 1e-5 of 1 in low orbit
# where acos amplifies rounding: against the extended-precision evaluation below brahe is off by
# up to 6.7e-9 on this sweep (ours by 1.5e-12), so the two agree to brahe's error, not 1e-9.
SHADOW_VS_BRAHE_ATOL = 1e-8


def test_conical_shadow_matches_brahe():
    positions, r_sun = _shadow_sweep()
    ours = np.asarray(shadow_fraction_conical(positions, r_sun, r_earth_m=bh.R_EARTH))
    theirs = np.array([bh.eclipse_conical(r, r_sun) for r in positions])
    np.testing.assert_allclose(ours, theirs, rtol=0, atol=SHADOW_VS_BRAHE_ATOL)
    # the sweep reaches all three regions
    assert np.sum(theirs == 0.0) > 10 and np.sum(theirs == 1.0) > 10
    assert np.sum((theirs > 0.01) & (theirs < 0.99)) > 50


def _conical_extended(r, s, r_earth_m):
    """M&G eqs. 3.79–3.87 as written (acos), in NumPy's extended precision: 64-bit mantissas
    leave the formula's 6.7e-9 float64 error at ~3e-12 (× 2^-11)."""
    r, s = r.astype(np.longdouble), s.astype(np.longdouble)
    to_sun = s - r
    d_sun, d_earth = np.sqrt(np.sum(to_sun**2)), np.sqrt(np.sum(r**2))
    a = np.arcsin(np.longdouble(R_SUN_M) / d_sun)
    b = np.arcsin(np.longdouble(r_earth_m) / d_earth)
    c = np.arccos(np.clip(-np.sum(r * to_sun) / (d_earth * d_sun), -1, 1))  # 1 + ulp on the axis
    if c >= a + b:
        return 1.0
    if c <= abs(a - b):
        return 0.0
    x = (c**2 + a**2 - b**2) / (2 * c)
    y = np.sqrt(a**2 - x**2)
    area = a**2 * np.arccos(x / a) + b**2 * np.arccos((c - x) / b) - c * y
    return float(1 - area / (np.pi * a**2))


# Against the extended-precision reference: its own ~3e-12, and ours (measured 1.5e-12).
SHADOW_VS_EXTENDED_ATOL = 1e-11


@pytest.mark.skipif(np.finfo(np.longdouble).eps > 1e-18, reason="no extended precision here")
def test_conical_shadow_accurate():
    positions, r_sun = _shadow_sweep()
    ours = np.asarray(shadow_fraction_conical(positions, r_sun))
    reference = np.array([_conical_extended(r, r_sun, 6378137.0) for r in positions])
    np.testing.assert_allclose(ours, reference, rtol=0, atol=SHADOW_VS_EXTENDED_ATOL)


def test_cylindrical_shadow_matches_brahe():
    positions, r_sun = _shadow_sweep()
    ours = np.asarray(shadow_fraction_cylindrical(positions, r_sun))
    theirs = np.array([bh.eclipse_cylindrical(r, r_sun) for r in positions])
    # brahe's cylinder is 0.7 m narrower (R_E 6 378 136.3 m): leave out positions that close
    # to the edge (none in this sweep, whose steps are kilometres)
    s_hat = r_sun / np.linalg.norm(r_sun)
    off_axis = np.linalg.norm(positions - np.outer(positions @ s_hat, s_hat), axis=-1)
    clear = np.abs(off_axis - 6378137.0) > 1.0
    np.testing.assert_array_equal(ours[clear], theirs[clear])
    assert set(np.unique(ours)) == {0.0, 1.0}


def test_annular_beyond_the_umbra():
    """Beyond the umbra's tip (1.38 million km) on the axis, the Earth's disc lies inside the
    Sun's: the fraction is 1 − b²/a², where brahe returns 0."""
    r_sun = np.array([1.496e11, 0.0, 0.0])
    r = np.array([-3.0e9, 0.0, 0.0])
    a = np.arcsin(R_SUN_M / np.linalg.norm(r_sun - r))
    b = np.arcsin(6378137.0 / np.linalg.norm(r))
    got = float(shadow_fraction_conical(r, r_sun))
    assert got == pytest.approx(1.0 - b**2 / a**2, rel=1e-12)
    assert 0.5 < got < 1.0


def test_conical_shadow_finite_under_jit_and_grad():
    """Umbra on the axis (c = 0), deep umbra, penumbra, sunlight: finite values and gradients,
    the gradient zero where the fraction is constant."""
    r_sun = jnp.array([1.496e11, 0.0, 0.0])
    radius = 6378137.0 + 500e3
    edge = np.arcsin(6378137.0 / radius)
    angles = jnp.array([0.0, 0.3, edge, 1.5, 2.5, np.pi])  # from the anti-Sun axis
    positions = radius * jnp.stack([-jnp.cos(angles), jnp.sin(angles), jnp.zeros_like(angles)], axis=0)

    fraction = jax.jit(lambda r: shadow_fraction_conical(r, r_sun[:, None], axis=0))
    values = np.asarray(fraction(positions))
    assert values.shape == (6,)
    np.testing.assert_array_equal(values[[0, 1, 3, 4, 5]], [0.0, 0.0, 1.0, 1.0, 1.0])
    assert 0.0 < values[2] < 1.0

    grad = np.asarray(jax.jit(jax.grad(lambda r: jnp.sum(fraction(r))))(positions))
    assert np.all(np.isfinite(grad))
    np.testing.assert_array_equal(grad[:, [0, 1, 3, 4, 5]], 0.0)
    # in the penumbra the gradient is the derivative: central differences across the orbit
    step = 1.0  # m; the fraction changes over ~20 km
    e_y = jnp.array([0.0, 1.0, 0.0])
    r_pen = positions[:, 2]
    numeric = (float(shadow_fraction_conical(r_pen + step * e_y, r_sun))
               - float(shadow_fraction_conical(r_pen - step * e_y, r_sun))) / (2.0 * step)
    assert grad[1, 2] == pytest.approx(numeric, rel=1e-5)
    assert grad[1, 2] != 0.0


def test_shadow_batch_shapes():
    positions, r_sun = _shadow_sweep()
    flat = np.asarray(shadow_fraction_conical(positions, r_sun))
    batch = positions[:600].T.reshape(3, 4, 150)  # (3, B, n), component-major
    got = jax.jit(lambda r: shadow_fraction_conical(r, r_sun[:, None, None], axis=0))(batch)
    assert got.shape == (4, 150)
    # jit fuses the arithmetic and rounds differently: to the function's 1e-12 accuracy
    np.testing.assert_allclose(np.asarray(got).reshape(-1), flat[:600], rtol=0, atol=1e-12)
    got_cyl = shadow_fraction_cylindrical(batch, r_sun[:, None, None], axis=0)
    assert got_cyl.shape == (4, 150)


# --- shapes and jit of the ephemerides ------------------------------------------------------

def test_ephemerides_batch_and_jit():
    jd = JD_J2000 + np.array([[-3650.25, 0.0, 17.3], [5000.5, 9000.125, 12345.678]])
    for position in (sun_position_eme2000_m, moon_position_eme2000_m):
        eager = np.asarray(position(jd))
        assert eager.shape == (2, 3, 3)
        jitted = jax.jit(position)
        for idx in np.ndindex(jd.shape):
            # the date a traced scalar; jit's fused arithmetic rounds differently: 5e-14 of
            # the distance seen (1.5 mm at the Sun)
            np.testing.assert_allclose(np.asarray(jitted(jd[idx])), eager[idx], rtol=0,
                                       atol=1e-12 * np.linalg.norm(eager[idx]))
        assert eager.dtype == np.float64
