"""The IGRF-13 (2020.0) tilted dipole: against its scalar potential written independently in
spherical coordinates, the closed-form dipole relations, the published 2020 geomagnetic pole,
the ECEF/ECI rotation, and the field's invariants (div B = 0, curl B = 0).

Measured: |g| = 29805.9 nT, axis tilt 9.4105°, north geomagnetic pole 80.5895° N geocentric
= 80.6514° N geodetic (WGS-84), 72.6797° W; IGRF-13 (Alken et al. 2021, Table 4) publishes
80.65° N (WGS-84 geodetic), 72.68° W for 2020.0.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pymap3d
import pytest

from coopsat.astro.earth import OMEGA_EARTH_RAD_S
from coopsat.astro.earth_orientation import z_rotation
from coopsat.astro.magnetic import IGRF2020_DIPOLE_T, IGRF_RADIUS_M, dipole_field_ecef, dipole_field_gcrf

TURN = z_rotation(0.0, 3600.0)  # θ = ω_E t: a Greenwich angle θ is the time θ / ω_E


def dipole_field_eci(r_eci_m, theta_rad, axis=-1):
    """The field at Greenwich angles θ, through the run-time function and a bare z turn."""
    return dipole_field_gcrf(r_eci_m, jnp.asarray(theta_rad) / OMEGA_EARTH_RAD_S, TURN, axis)

# IGRF-13, epoch 2020.0 (IGRF column of igrf13coeffs.txt; Alken et al., EPS 73:49, 2021), nT.
G10_NT, G11_NT, H11_NT = -29404.8, -1450.9, 4652.5
A_M = 6371200.0  # IGRF reference radius
G_NORM_T = np.sqrt(G10_NT**2 + G11_NT**2 + H11_NT**2) * 1e-9  # 29805.9 nT

RNG = np.random.default_rng(20200101)
# Points from 0.5 a to 10 a in all directions.
POINTS_M = RNG.normal(size=(40, 3))
POINTS_M *= (A_M * RNG.uniform(0.5, 10.0, size=40) / np.linalg.norm(POINTS_M, axis=-1))[:, None]


def potential_spherical(r_ecef_m):
    """Degree-1 IGRF potential, T·m, in its textbook spherical form (Schmidt P10 = cos θ,
    P11 = sin θ): V = a (a/r)² [g10 cos θ + (g11 cos φ + h11 sin φ) sin θ], θ colatitude,
    φ east longitude."""
    x, y, z = r_ecef_m
    r = jnp.sqrt(x * x + y * y + z * z)
    colat = jnp.arccos(z / r)
    lon = jnp.arctan2(y, x)
    bracket = G10_NT * jnp.cos(colat) + (G11_NT * jnp.cos(lon) + H11_NT * jnp.sin(lon)) * jnp.sin(colat)
    return A_M * (A_M / r) ** 2 * bracket * 1e-9


def r3(theta):
    """Rotation matrix R3(−θ) (ECEF components to ECI), built by hand."""
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def test_constants_are_the_published_igrf13_values():
    assert IGRF_RADIUS_M == A_M
    np.testing.assert_allclose(IGRF2020_DIPOLE_T, np.array([G11_NT, H11_NT, G10_NT]) * 1e-9, rtol=1e-15)


def test_field_is_minus_the_gradient_of_the_spherical_potential():
    grad = jax.vmap(jax.grad(potential_spherical))(jnp.asarray(POINTS_M))
    field = np.asarray(dipole_field_ecef(POINTS_M))
    assert field.shape == POINTS_M.shape
    np.testing.assert_allclose(field, -np.asarray(grad), rtol=0, atol=1e-12 * np.max(np.abs(field)))
    # Per point, relative to that point's field.
    err = np.linalg.norm(field + np.asarray(grad), axis=-1) / np.linalg.norm(field, axis=-1)
    assert np.max(err) < 1e-12


def test_magnitude_on_the_magnetic_equator_and_pole_and_everywhere():
    m_hat = np.array([G11_NT, H11_NT, G10_NT]) / np.linalg.norm([G11_NT, H11_NT, G10_NT])
    # Magnetic equator at r = a: a circle perpendicular to the axis; |B| = |g|, B = −g there
    # (pointing geographically north: +z component).
    e1 = np.cross(m_hat, [0.0, 0.0, 1.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(m_hat, e1)
    phase = np.linspace(0.0, 2.0 * np.pi, 13)
    equator = A_M * (np.cos(phase)[:, None] * e1 + np.sin(phase)[:, None] * e2)
    b_eq = np.asarray(dipole_field_ecef(equator))
    np.testing.assert_allclose(np.linalg.norm(b_eq, axis=-1), G_NORM_T, rtol=1e-13)
    np.testing.assert_allclose(b_eq, np.broadcast_to(-G_NORM_T * m_hat, b_eq.shape), rtol=0, atol=1e-13 * G_NORM_T)
    assert np.all(b_eq[:, 2] > 0.0)
    assert G_NORM_T == pytest.approx(29.806e-6, abs=1e-9)
    # Poles at r = a: |B| = 2|g|, along the axis.
    for sign in (1.0, -1.0):
        b_pole = np.asarray(dipole_field_ecef(sign * A_M * m_hat))
        assert np.linalg.norm(b_pole) == pytest.approx(2.0 * G_NORM_T, rel=1e-13)
        np.testing.assert_allclose(np.cross(b_pole, m_hat), 0.0, atol=1e-13 * G_NORM_T)
    # Everywhere: |B| = |g| (a/r)³ sqrt(1 + 3 sin² λm), sin λm = r̂ · (−m̂) (magnetic latitude).
    r = np.linalg.norm(POINTS_M, axis=-1)
    sin_lat_m = -(POINTS_M @ m_hat) / r
    expected = G_NORM_T * (A_M / r) ** 3 * np.sqrt(1.0 + 3.0 * sin_lat_m**2)
    np.testing.assert_allclose(np.linalg.norm(dipole_field_ecef(POINTS_M), axis=-1), expected, rtol=1e-13)
    # Inverse-cube fall-off.
    np.testing.assert_allclose(dipole_field_ecef(2.0 * POINTS_M), np.asarray(dipole_field_ecef(POINTS_M)) / 8.0,
                               rtol=1e-14, atol=0)


def test_geomagnetic_pole_is_the_published_2020_one():
    # Recover the dipole from the function's output alone: for B = a³(3(g·r̂)r̂ − g)/r³ at
    # r = a along a unit axis e, B·e = 2 g·e.
    g = np.array([float(np.asarray(dipole_field_ecef(A_M * e)) @ e) / 2.0 for e in np.eye(3)])
    tilt_deg = np.degrees(np.arccos(abs(g[2]) / np.linalg.norm(g)))
    assert tilt_deg == pytest.approx(9.41, abs=0.01)
    # North geomagnetic pole: where the axis leaves the northern hemisphere (the dipole moment
    # points south, g10 < 0, so that is along −g).
    pole = -g / np.linalg.norm(g)
    lat_gc = np.degrees(np.arcsin(pole[2]))
    lon = np.degrees(np.arctan2(pole[1], pole[0]))
    assert lat_gc == pytest.approx(80.59, abs=0.005)
    # IGRF-13 Table 4 gives latitudes in the WGS-84 geodetic system: put the axis's piercing
    # point on the ellipsoid and take its geodetic latitude with pymap3d.
    a, b = 6378137.0, 6356752.314245
    scale = 1.0 / np.sqrt((pole[0] ** 2 + pole[1] ** 2) / a**2 + pole[2] ** 2 / b**2)
    lat_gd, lon_gd, h = pymap3d.ecef2geodetic(*(scale * pole))
    assert abs(h) < 1e-3
    assert lat_gd == pytest.approx(80.65, abs=0.01)
    assert lon_gd == pytest.approx(-72.68, abs=0.01)
    assert lon == pytest.approx(-72.68, abs=0.01)
    # The field there is vertical and points down (into the Earth) in the north.
    b_pole = np.asarray(dipole_field_ecef(scale * pole))
    assert np.linalg.norm(np.cross(b_pole, pole)) < 1e-12 * np.linalg.norm(b_pole)
    assert b_pole @ pole < 0.0


def test_field_at_6900_km_on_the_geographic_equator():
    r_m = 6900e3
    lon = np.radians(np.linspace(-180.0, 180.0, 3601))
    points = r_m * np.stack([np.cos(lon), np.sin(lon), np.zeros_like(lon)], axis=-1)
    mag = np.linalg.norm(np.asarray(dipole_field_ecef(points)), axis=-1)
    # Magnetic latitude on the geographic equator ranges over ±tilt (9.41°): |B| from
    # |g|(a/r)³ = 23.46 µT to 1.039 times that, 24.38 µT.
    low = G_NORM_T * (A_M / r_m) ** 3
    sin_tilt = np.hypot(G11_NT, H11_NT) / np.linalg.norm([G10_NT, G11_NT, H11_NT])
    assert np.min(mag) == pytest.approx(low, rel=1e-5)
    assert np.max(mag) == pytest.approx(low * np.sqrt(1.0 + 3.0 * sin_tilt**2), rel=1e-5)
    assert 23.0e-6 < np.min(mag) and np.max(mag) < 24.5e-6
    # Horizontal and northward there (B·ẑ > 0), to within the tilt.
    b = np.asarray(dipole_field_ecef(points))
    assert np.all(b[:, 2] / mag > np.cos(np.radians(2 * 9.41 + 0.1)))


def test_eci_field_is_the_ecef_field_rotated():
    theta = RNG.uniform(-20.0, 20.0, size=len(POINTS_M))
    r_eci = np.einsum("nij,nj->ni", np.stack([r3(t) for t in theta]), POINTS_M)
    expected = np.einsum("nij,nj->ni", np.stack([r3(t) for t in theta]), np.asarray(dipole_field_ecef(POINTS_M)))
    scale = np.max(np.abs(expected))
    ours = np.asarray(dipole_field_eci(r_eci, theta))
    assert ours.shape == r_eci.shape
    np.testing.assert_allclose(ours, expected, rtol=0, atol=1e-12 * scale)
    # Component-major (3, n) with θ (n,), and one θ for all points.
    np.testing.assert_allclose(np.asarray(dipole_field_eci(r_eci.T, theta, axis=0)).T, ours, rtol=0, atol=1e-14 * scale)
    one = np.asarray(dipole_field_eci(POINTS_M, 0.7))
    np.testing.assert_allclose(one, np.asarray(dipole_field_ecef(POINTS_M @ r3(0.7)) @ r3(0.7).T), rtol=0,
                               atol=1e-12 * scale)
    # θ = 0: ECI and ECEF coincide.
    np.testing.assert_allclose(dipole_field_eci(POINTS_M, 0.0), dipole_field_ecef(POINTS_M), rtol=0, atol=1e-14 * scale)


def test_component_major_layout_and_jit():
    field = np.asarray(dipole_field_ecef(POINTS_M))
    scale = np.max(np.abs(field))
    np.testing.assert_allclose(np.asarray(dipole_field_ecef(POINTS_M.T, axis=0)).T, field, rtol=0, atol=1e-14 * scale)
    batched = POINTS_M.reshape(4, 10, 3)
    np.testing.assert_allclose(np.asarray(dipole_field_ecef(batched)).reshape(40, 3), field, rtol=0, atol=1e-14 * scale)
    theta = np.linspace(0.0, 3.0, len(POINTS_M))
    f = jax.jit(lambda r, t: dipole_field_eci(r, t, axis=0))
    np.testing.assert_allclose(f(POINTS_M.T, theta), dipole_field_eci(POINTS_M.T, theta, axis=0), rtol=0,
                               atol=1e-14 * scale)
    np.testing.assert_allclose(jax.jit(dipole_field_ecef)(POINTS_M), field, rtol=0, atol=1e-14 * scale)


def test_field_is_divergence_and_curl_free():
    jac = jax.vmap(jax.jacfwd(dipole_field_ecef))(jnp.asarray(POINTS_M))
    jac = np.asarray(jac)
    size = np.max(np.abs(jac), axis=(1, 2))
    div = np.trace(jac, axis1=1, axis2=2)
    curl = jac - np.swapaxes(jac, 1, 2)
    assert np.all(np.abs(div) < 1e-13 * size)
    assert np.all(np.max(np.abs(curl), axis=(1, 2)) < 1e-13 * size)
    # And not trivially: the Jacobian is of the size 3|B|/r.
    b = np.linalg.norm(np.asarray(dipole_field_ecef(POINTS_M)), axis=-1)
    assert np.all(size > 0.5 * b / np.linalg.norm(POINTS_M, axis=-1))
