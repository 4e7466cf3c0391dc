"""Facet torques and magnetorquers against hand calculations; the environment disturbance parts
(aerodynamic, solar pressure, residual dipole) on spacecraft states against the same, written
facet by facet, with the density from Vallado's table and the field of the tilted dipole written
out here."""

import tomllib

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from coopsat.actuators.magnetorquers import magnetorquer_torque_b
from coopsat.astro.earth_orientation import z_rotation
from coopsat.astro.earth import OMEGA_EARTH_RAD_S, WGS84_A_M, WGS84_F, gmst_rad, julian_date_utc
from coopsat.astro.sun import sun_position_eci_m
from coopsat.dynamics.plant import PlantState
from coopsat.environment.earth_torques import (
    AerodynamicTorque,
    ResidualDipoleTorque,
    SolarPressureTorque,
    facet_drag_torque_b,
    facet_srp_torque_b,
)
from coopsat.scenarios.load import bundled_text
from earth_reference import hand_dipole_eci, random_quats, to_body


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


# --- the disturbance parts on spacecraft states ------------------------------------------------

COOP = "observation-cooperative"
EPOCH = "2018-07-12T03:00:00"  # observation-cooperative's [orbit] epoch_utc
JD0 = julian_date_utc(EPOCH)
GMST0 = gmst_rad(JD0)
EARTH = z_rotation(GMST0, 86400.0)  # the papers' Earth: θ = GMST0 + ω_E t
AU = 149597870700.0
P_1AU = 4.56e-6


def _coop_tables():
    tables = tomllib.loads(bundled_text(COOP))["disturbances"]
    return {t["kind"]: t for t in tables}


def _facets(table):
    f = np.asarray(table["facets"], float)
    return f[:, :3].T, f[:, 3], f[:, 4:].T  # the bundled normals are unit already


def _state(q, r, v):
    """Component-major PlantState of n spacecraft from (n, 4), (n, 3), (n, 3)."""
    q, r, v = (np.atleast_2d(np.asarray(a, float)) for a in (q, r, v))
    n = q.shape[0]
    zeros = jnp.zeros((3, n))
    return PlantState(jnp.asarray(q.T), zeros, zeros, jnp.asarray(r.T), jnp.asarray(v.T), zeros)


# Two spacecraft at heights that fall inside bands of Vallado's Table 8-4, so the density is
# written here from the table: 520 km over the equator, 420 km over the north pole.
R_EQ = np.array([WGS84_A_M + 520e3, 0.0, 0.0])
V_EQ = 7600.0 * np.array([0.0, np.cos(np.radians(97.5)), np.sin(np.radians(97.5))])
R_POLE = np.array([0.0, 0.0, WGS84_A_M * (1.0 - WGS84_F) + 420e3])
V_POLE = np.array([-7650.0, 300.0, 0.0])
RHO = np.array([6.967e-13 * np.exp(-20.0 / 63.822), 3.725e-12 * np.exp(-20.0 / 58.515)])


def _aero_part(cd=2.2):
    n, a, c = _facets(_coop_tables()["aerodynamic-torque"])
    return AerodynamicTorque(jnp.asarray(n), jnp.asarray(a), jnp.asarray(c), jnp.asarray(cd))


def _srp_part(specular=0.1, diffuse=0.2):
    n, a, c = _facets(_coop_tables()["solar-pressure-torque"])
    f = a.size
    return SolarPressureTorque(jnp.asarray(n), jnp.asarray(a), jnp.asarray(c), jnp.full(f, specular), jnp.full(f, diffuse),
                               jnp.asarray(P_1AU), jnp.asarray(AU), jnp.asarray(JD0))


def _hand_drag(v_rel_b, rho, normals, areas, centres, cd):
    """Σ_f c_f × F_f, facet by facet, F_f = −½ ρ C_D A_f cos θ_f |v|² v̂ on front faces."""
    speed = np.linalg.norm(v_rel_b)
    v_hat = v_rel_b / speed
    torque = np.zeros(3)
    for k in range(areas.size):
        cos = normals[:, k] @ v_hat
        if cos > 0.0:
            torque += np.cross(centres[:, k], -0.5 * rho * cd * areas[k] * cos * speed**2 * v_hat)
    return torque


def _hand_srp(s_b, p, normals, areas, centres, specular, diffuse):
    torque = np.zeros(3)
    for k in range(areas.size):
        cos = normals[:, k] @ s_b
        if cos > 0.0:
            force = -p * areas[k] * cos * ((1 - specular) * s_b + 2 * (specular * cos + diffuse / 3) * normals[:, k])
            torque += np.cross(centres[:, k], force)
    return torque


def test_aerodynamic_part_uses_the_air_turning_with_the_earth_and_the_tabulated_density():
    part = _aero_part()
    q = random_quats(2, 11)
    x = _state(q, [R_EQ, R_POLE], [V_EQ, V_POLE])
    got = np.asarray(part.wrench(0.0, x, part.init(2))["torque_b"])
    assert got.shape == (3, 2)
    normals, areas, centres = _facets(_coop_tables()["aerodynamic-torque"])
    omega_e = np.array([0.0, 0.0, OMEGA_EARTH_RAD_S])
    for i, (r, v) in enumerate([(R_EQ, V_EQ), (R_POLE, V_POLE)]):
        v_rel_b = to_body(q[i], v - np.cross(omega_e, r))
        expected = _hand_drag(v_rel_b, RHO[i], normals, areas, centres, 2.2)
        np.testing.assert_allclose(got[:, i], expected, rtol=1e-9)
    # Over the equator the co-rotating air matters (ω_E R ≈ 500 m/s across a 7.6 km/s flow):
    # the torque with the inertial velocity instead is measurably different.
    inertial = _hand_drag(to_body(q[0], V_EQ), RHO[0], normals, areas, centres, 2.2)
    assert np.linalg.norm(got[:, 0] - inertial) > 1e-2 * np.linalg.norm(inertial)
    # The torque scales with C_D.
    np.testing.assert_allclose(np.asarray(_aero_part(1.1).wrench(0.0, x, ())["torque_b"]), got / 2.0, rtol=1e-12)


def test_solar_pressure_part_is_zero_in_the_earth_shadow_and_the_hand_value_in_sunlight():
    part = _srp_part()
    t = 3600.0
    r_sun = np.asarray(sun_position_eci_m(JD0 + t / 86400.0))
    s_hat = r_sun / np.linalg.norm(r_sun)
    radius = WGS84_A_M + 500e3
    # Behind the Earth, opposite the Sun: shadow. On the day side, and beside the Earth just
    # outside the shadow cylinder: sunlight.
    side = np.cross(s_hat, [0.0, 0.0, 1.0])
    side /= np.linalg.norm(side)
    positions = [-radius * s_hat, radius * s_hat, -0.3 * radius * s_hat + radius * side]
    q = random_quats(3, 12)
    x = _state(q, positions, [[0.0, 7600.0, 0.0]] * 3)
    got = np.asarray(part.wrench(t, x, part.init(3))["torque_b"])
    np.testing.assert_array_equal(got[:, 0], 0.0)
    normals, areas, centres = _facets(_coop_tables()["solar-pressure-torque"])
    for i in (1, 2):
        to_sun = r_sun - positions[i]
        dist = np.linalg.norm(to_sun)
        s_b = to_body(q[i], to_sun / dist)
        expected = _hand_srp(s_b, P_1AU * (AU / dist) ** 2, normals, areas, centres, 0.1, 0.2)
        assert np.linalg.norm(expected) > 1e-8
        np.testing.assert_allclose(got[:, i], expected, rtol=1e-9)


def test_residual_dipole_part_is_m_cross_the_body_field_of_the_turning_earth():
    dipole = np.array([0.02, -0.05, 0.03])
    part = ResidualDipoleTorque(jnp.asarray(dipole.reshape(3, 1)), EARTH)
    q = random_quats(2, 13)
    x = _state(q, [R_EQ, [4.0e6, -3.0e6, 4.5e6]], [V_EQ, V_POLE])
    t = 1234.5
    got = np.asarray(part.wrench(t, x, part.init(2))["torque_b"])
    theta = GMST0 + OMEGA_EARTH_RAD_S * t
    for i, r in enumerate([R_EQ, np.array([4.0e6, -3.0e6, 4.5e6])]):
        b_b = to_body(q[i], hand_dipole_eci(r, theta))
        np.testing.assert_allclose(got[:, i], np.cross(dipole, b_b), rtol=1e-10)
        # The field at t = 0 (the Earth 5° less turned) gives another torque.
        b_0 = to_body(q[i], hand_dipole_eci(r, GMST0))
        assert np.linalg.norm(got[:, i] - np.cross(dipole, b_0)) > 1e-3 * np.linalg.norm(got[:, i])
    assert np.allclose(np.asarray(part.record(t, x, ())["residual_dipole_torque"]), got, rtol=0, atol=0)


def _coop_states(t):
    """The two spacecraft of observation-cooperative at time t on their Keplerian orbits (enough
    for a sanity check of size), with their initial attitudes."""
    from coopsat.astro.constants import MU_EARTH_M3_S2
    from coopsat.astro.kepler import elements_to_rv

    q, r, v = [], [], []
    for sc in tomllib.loads(bundled_text(COOP))["spacecraft"]:
        el = sc["elements"]
        mean_motion = np.sqrt(MU_EARTH_M3_S2 / el["a_m"] ** 3)
        angles = (np.radians(el[k]) for k in ("i_deg", "raan_deg", "argp_deg"))
        ri, vi = elements_to_rv(el["a_m"], el["e"], *angles, np.radians(el["mean_anomaly_deg"]) + mean_motion * t,
                                MU_EARTH_M3_S2)
        q.append(np.asarray(sc["q_bi"]) / np.linalg.norm(sc["q_bi"]))
        r.append(np.asarray(ri))
        v.append(np.asarray(vi))
    return _state(q, r, v)


def _coop_parts():
    dipole = np.asarray(_coop_tables()["residual-dipole"]["dipole_am2"], float).reshape(3, 1)
    return [_aero_part(), _srp_part(), ResidualDipoleTorque(jnp.asarray(dipole), EARTH)]


def test_observation_cooperative_torques_are_of_the_expected_order():
    """Sanity: a 0.2 × 0.2 × 0.3 m body with a 0.18 m² array at ~530 km: each torque between
    1e-8 and 1e-5 N·m on both spacecraft. At the epoch both are in the Earth's shadow (no
    solar pressure at all); by 900 s (overflight) both are in sunlight."""
    aero, srp, dipole = _coop_parts()
    x0 = _coop_states(0.0)
    np.testing.assert_array_equal(np.asarray(srp.wrench(0.0, x0, ())["torque_b"]), 0.0)
    x = _coop_states(900.0)
    for part in (aero, srp, dipole):
        torque = np.linalg.norm(np.asarray(part.wrench(900.0, x, part.init(2))["torque_b"]), axis=0)
        assert np.all((torque > 1e-8) & (torque < 1e-5)), (type(part).__name__, torque)


# jit may round the Julian date jd0 + t/86400 differently (by 5e-10 day, the Sun moving 1e-11
# rad): the solar pressure torque then differs by about 1e-11 of itself; the others by rounding.
JIT_RTOL = {"AerodynamicTorque": 1e-13, "SolarPressureTorque": 1e-10, "ResidualDipoleTorque": 1e-13}


def test_parts_trace_under_jit_and_each_column_is_its_own_spacecraft():
    q = random_quats(2, 14)
    r, v = [R_EQ, R_POLE], [V_EQ, V_POLE]
    x2 = _state(q, r, v)
    t = 250.0
    for part in _coop_parts():
        eager = np.asarray(part.wrench(t, x2, part.init(2))["torque_b"])
        jitted = np.asarray(jax.jit(part.wrench)(t, x2, part.init(2))["torque_b"])
        assert jitted.shape == eager.shape == (3, 2)
        scale = np.linalg.norm(eager, axis=0)
        assert np.all(scale > 0.0)
        assert np.all(np.abs(jitted - eager).max(axis=0) <= JIT_RTOL[type(part).__name__] * scale)
        for i in range(2):
            one = np.asarray(part.wrench(t, _state(q[i], r[i], v[i]), part.init(1))["torque_b"])
            assert one.shape == (3, 1)
            np.testing.assert_allclose(eager[:, i], one[:, 0], rtol=1e-14, atol=1e-14 * scale[i])
        assert not np.allclose(eager[:, 0], eager[:, 1], rtol=1e-3)
