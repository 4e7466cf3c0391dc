"""The exponential atmosphere against Vallado (4th ed.) Table 8-4, and the approximate
ellipsoidal height against pymap3d.

Measured: the density is continuous across Vallado's band boundaries to the table's four
digits, except at 25 km where the sea-level band lands 0.14 % below the 25 km base value
(1.225 exp(−25/7.249) = 3.8937e-2 against 3.899e-2); elsewhere the jumps are at most 0.0096 % (80 km).
``altitude_m`` is within 25 m of the exact geodetic height (pymap3d) from 400 to 800 km, the
largest error near ±45° latitude; the sphere of radius a would be 21 km off at the poles.
"""

import jax
import numpy as np
import pymap3d
import pytest

from coopsat.astro.atmosphere import altitude_m, density_kg_m3

# A few rows of Vallado, Fundamentals of Astrodynamics and Applications, 4th ed., Table 8-4:
# base altitude h0 (km), nominal density ρ0 (kg/m³), scale height H (km).
BOOK_ROWS = [
    (0.0, 1.225, 7.249),
    (70.0, 8.770e-5, 6.549),
    (100.0, 5.297e-7, 5.877),
    (150.0, 2.070e-9, 22.523),
    (400.0, 3.725e-12, 58.515),
    (500.0, 6.967e-13, 63.822),
    (1000.0, 3.019e-15, 268.00),
]
# All of the table's base altitudes, km.
BOOK_BASES_KM = [0, 25, 30, 40, 50, 60, 70, 80, 90, 100, 110, 120, 130, 140, 150, 180, 200, 250, 300, 350, 400,
                 450, 500, 600, 700, 800, 900, 1000]


def rho(h_m):
    return np.asarray(density_kg_m3(np.asarray(h_m, dtype=float)))


@pytest.mark.parametrize(("h0_km", "rho0", "scale_km"), BOOK_ROWS)
def test_density_at_a_band_base_is_the_table_value(h0_km, rho0, scale_km):
    assert float(rho(h0_km * 1e3)) == pytest.approx(rho0, rel=1e-12)


@pytest.mark.parametrize(("h0_km", "rho0", "scale_km"), BOOK_ROWS[1:-1])
def test_density_inside_a_band_follows_its_exponential(h0_km, rho0, scale_km):
    # Points across the band up to the next base (the next row of BOOK_ROWS is above it).
    for dh_km in (0.5, 3.0, 4.9):
        h_km = h0_km + dh_km
        assert float(rho(h_km * 1e3)) == pytest.approx(rho0 * np.exp(-dh_km / scale_km), rel=1e-12), h_km


def test_density_hand_values_outside_the_table_and_at_530_km():
    assert float(rho(530e3)) == pytest.approx(6.967e-13 * np.exp(-30.0 / 63.822), rel=1e-12)
    assert float(rho(530e3)) == pytest.approx(4.35e-13, rel=1e-3)
    # Above 1000 km the last band continues; below 0 the sea-level one.
    assert float(rho(1500e3)) == pytest.approx(3.019e-15 * np.exp(-500.0 / 268.0), rel=1e-12)
    assert float(rho(-1e3)) == pytest.approx(1.225 * np.exp(1.0 / 7.249), rel=1e-12)


def test_density_decreases_monotonically_from_0_to_1500_km():
    h = np.linspace(0.0, 1500e3, 15001)  # every 100 m
    d = rho(h)
    assert np.all(np.isfinite(d)) and np.all(d > 0.0)
    assert np.all(np.diff(d) < 0.0)
    # Across the whole range: 1.225 down to 4.7e-16, 15.4 decades.
    assert np.log10(d[0] / d[-1]) == pytest.approx(15.41, abs=0.01)


def test_density_is_nearly_continuous_at_the_band_boundaries():
    bases_m = np.array(BOOK_BASES_KM[1:], dtype=float) * 1e3
    # 1 mm below a base is in the band under it: the exponential moves by 1e-6/H (< 2e-7).
    jump = rho(bases_m) / rho(bases_m - 1e-3) - 1.0
    worst = np.argmax(np.abs(jump))
    assert BOOK_BASES_KM[1:][worst] == 25
    assert jump[worst] == pytest.approx(1.36e-3, abs=2e-5)  # 0.14 % up at 25 km
    others = np.delete(jump, worst)
    assert np.max(np.abs(others)) < 1e-4  # largest 9.6e-5, at 80 km


def test_density_keeps_shape_and_traces_under_jit():
    h = np.array([[0.0, 250e3, 530e3], [700e3, 999.999e3, 1200e3]])
    eager = rho(h)
    assert eager.shape == (2, 3)
    np.testing.assert_allclose(jax.jit(density_kg_m3)(h), eager, rtol=1e-14, atol=0)
    np.testing.assert_allclose(eager.ravel(), [float(rho(x)) for x in h.ravel()], rtol=1e-14, atol=0)


# ----------------------------------------------------------------------------- altitude

LAT_DEG = np.linspace(-90.0, 90.0, 181)
LON_DEG = np.linspace(-180.0, 150.0, 12)
HEIGHTS_M = np.array([400e3, 500e3, 600e3, 800e3])
ALTITUDE_TOL_M = 30.0  # measured 24.8 m at 400 km; the module states "below 100 m in low orbit"


def orbit_points():
    lat, lon, h = np.meshgrid(LAT_DEG, LON_DEG, HEIGHTS_M, indexing="ij")
    r = np.stack(pymap3d.geodetic2ecef(lat, lon, h), axis=-1)
    return r, lat


def test_altitude_matches_pymap3d_geodetic_height():
    r, lat = orbit_points()
    _, _, h_exact = pymap3d.ecef2geodetic(r[..., 0], r[..., 1], r[..., 2])
    ours = np.asarray(altitude_m(r))
    assert ours.shape == r.shape[:-1]
    err = np.abs(ours - h_exact)
    assert np.max(err) < ALTITUDE_TOL_M
    # Exact at the equator to first order (sin φc = 0): only the rounding there.
    assert np.max(err[np.abs(lat) < 1e-9]) < 1e-6
    # The test can tell an ellipsoid from a sphere: |r| − a is off by up to 21 km.
    sphere = np.linalg.norm(r, axis=-1) - 6378137.0
    assert np.max(np.abs(sphere - h_exact)) > 20e3


def test_altitude_ignores_rotation_about_z():
    r, _ = orbit_points()
    r = r.reshape(-1, 3)
    c, s = np.cos(1.3), np.sin(1.3)
    turned = np.stack([c * r[:, 0] - s * r[:, 1], s * r[:, 0] + c * r[:, 1], r[:, 2]], axis=-1)
    np.testing.assert_allclose(altitude_m(turned), altitude_m(r), rtol=0, atol=1e-6)


def test_altitude_component_major_layout_and_jit():
    r, _ = orbit_points()
    r = r.reshape(-1, 3)
    last = np.asarray(altitude_m(r))
    np.testing.assert_allclose(altitude_m(r.T, axis=0), last, rtol=0, atol=1e-8)
    np.testing.assert_allclose(jax.jit(lambda x: altitude_m(x, axis=0))(r.T), last, rtol=0, atol=1e-8)
    # And the density of the result, as the closed loop uses it.
    d = jax.jit(lambda x: density_kg_m3(altitude_m(x, axis=0)))(r.T)
    np.testing.assert_allclose(d, rho(last), rtol=1e-12, atol=0)
