"""Solar radiation pressure against its closed form (SPEC §4)."""

import numpy as np

from coopsat.astro.constants import AU_M, SOLAR_PRESSURE_1AU_N_M2
from coopsat.environment.forces import srp_force_eci


def test_pressure_constant_is_the_solar_luminosity_over_the_1au_sphere_and_c():
    # 1361 W/m² (the measured total solar irradiance) over c is 4.54e-6 N/m².
    assert abs(SOLAR_PRESSURE_1AU_N_M2 - 1361.0 / 299792458.0) / SOLAR_PRESSURE_1AU_N_M2 < 2e-3


def test_cannonball_at_1au_points_away_from_the_sun_with_area_and_reflectivity():
    r = np.array([AU_M, 0.0, 0.0])
    f = np.asarray(srp_force_eci(r, 15.0, 0.5, SOLAR_PRESSURE_1AU_N_M2, AU_M))
    np.testing.assert_allclose(f, [SOLAR_PRESSURE_1AU_N_M2 * 15.0 * 1.5, 0.0, 0.0], rtol=1e-14)


def test_inverse_square_and_component_major_layout():
    rng = np.random.default_rng(1)
    r = rng.normal(size=(3, 4)) * AU_M
    area, refl = np.array([1.0, 2.0, 3.0, 4.0]), np.array([0.0, 0.2, 0.5, 1.0])
    f = np.asarray(srp_force_eci(r, area, refl, SOLAR_PRESSURE_1AU_N_M2, AU_M, axis=0))
    dist = np.linalg.norm(r, axis=0)
    expected = SOLAR_PRESSURE_1AU_N_M2 * (AU_M / dist) ** 2 * area * (1 + refl) * r / dist
    np.testing.assert_allclose(f, expected, rtol=1e-13)


def test_differential_acceleration_of_two_reflectivities():
    # 700 kg, 15 m²: reflectivities 0.4 and 0.7 differ by P·A·0.3/m ≈ 2.9e-8 m/s².
    r = np.array([[AU_M, AU_M + 100.0], [0.0, 0.0], [0.0, 0.0]])
    f = np.asarray(srp_force_eci(r, 15.0, np.array([0.4, 0.7]), SOLAR_PRESSURE_1AU_N_M2, AU_M, axis=0))
    da = (f[0, 1] - f[0, 0]) / 700.0
    assert abs(da - SOLAR_PRESSURE_1AU_N_M2 * 15.0 * 0.3 / 700.0) < 1e-11
