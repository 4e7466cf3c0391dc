"""Facet torques and magnetorquers against hand calculations."""

import numpy as np
import pytest

from coopsat.actuators.magnetorquers import magnetorquer_torque_b
from coopsat.environment.earth_torques import facet_drag_torque_b, facet_srp_torque_b


def _plate(normal, area, centre):
    return np.array(normal, float)[:, None], np.array([area], float), np.array(centre, float)[:, None]


def test_one_plate_head_on_drag():
    n, a, c = _plate([-1.0, 0.0, 0.0], 0.1, [0.0, 0.2, 0.05])
    v = np.array([[-7500.0], [0.0], [0.0]])  # the flow comes at the plate's front
    rho, cd = np.array([4e-13]), 2.2
    force = -0.5 * rho[0] * cd * 0.1 * 7500.0**2 * np.array([-1.0, 0.0, 0.0])
    np.testing.assert_allclose(np.asarray(facet_drag_torque_b(v, rho, n, a, c, cd))[:, 0], np.cross(c[:, 0], force), rtol=1e-12)
    # Edge-on and from behind: nothing.
    assert np.allclose(facet_drag_torque_b(np.array([[0.0], [7500.0], [0.0]]), rho, n, a, c, cd), 0.0)
    assert np.allclose(facet_drag_torque_b(-v, rho, n, a, c, cd), 0.0)


def _cube(offset):
    normals = np.hstack([np.eye(3), -np.eye(3)])
    return normals, np.full(6, 0.04), 0.1 * normals - np.asarray(offset)[:, None]


def test_a_cube_about_its_centre_feels_no_torque_and_an_offset_one_minus_d_cross_f():
    rng = np.random.default_rng(5)
    u = rng.normal(size=(3, 8))
    u /= np.linalg.norm(u, axis=0)
    rho = np.full(8, 4e-13)
    n, a, c = _cube([0.0, 0.0, 0.0])
    assert np.abs(facet_drag_torque_b(7500.0 * u, rho, n, a, c, 2.2)).max() < 1e-20
    assert np.abs(facet_srp_torque_b(u, np.full(8, 4.5e-6), n, a, c, np.full(6, 0.3), np.full(6, 0.2))).max() < 1e-20
    d = np.array([0.01, -0.02, 0.03])
    n, a, c = _cube(d)
    projected = a @ np.maximum(n.T @ u, 0.0)  # (8,)
    force = -0.5 * 4e-13 * 2.2 * 7500.0**2 * projected * u
    np.testing.assert_allclose(np.asarray(facet_drag_torque_b(7500.0 * u, rho, n, a, c, 2.2)),
                               -np.cross(d, force.T).T, rtol=1e-10, atol=1e-22)


@pytest.mark.parametrize(("specular", "diffuse"), [(0.0, 0.0), (1.0, 0.0), (0.3, 0.4)])
def test_one_plate_solar_pressure(specular, diffuse):
    n, a, c = _plate([0.0, -1.0, 0.0], 0.2, [0.05, -0.1, 0.3])
    s = np.array([0.6, -0.8, 0.0])  # cos θ = 0.8
    p = 4.56e-6
    force = -p * 0.2 * 0.8 * ((1 - specular) * s + 2 * (specular * 0.8 + diffuse / 3) * n[:, 0])
    got = facet_srp_torque_b(s[:, None], np.array([p]), n, a, c, np.array([specular]), np.array([diffuse]))
    np.testing.assert_allclose(np.asarray(got)[:, 0], np.cross(c[:, 0], force), rtol=1e-12)


def test_magnetorquer_torque_is_m_cross_b_and_saturates_per_coil():
    m = np.array([[3.0, 0.5], [-1.0, 0.0], [0.2, 0.0]])
    b = np.array([[2e-5, 2e-5], [-1e-5, 0.0], [3e-5, 0.0]])
    torque, applied = (np.asarray(x) for x in magnetorquer_torque_b(m, b, 2.5))
    np.testing.assert_allclose(applied[:, 0], [2.5, -1.0, 0.2])
    np.testing.assert_allclose(torque.T, np.cross(applied.T, b.T), rtol=1e-12)
    assert np.allclose(np.sum(torque * b, axis=0), 0.0, atol=1e-20)  # never along the field
    assert np.allclose(torque[:, 1], 0.0)  # a dipole along B gives none
