"""Point-mass and J2 gravity, and classical elements to position and velocity."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from coopsat.astro.constants import J2_EARTH, MU_EARTH_M3_S2, R_EARTH_M
from coopsat.astro.kepler import elements_to_rv, solve_kepler
from coopsat.dynamics.translational import j2_accel, specific_energy_j_kg, two_body_accel

MU, J2, RE = MU_EARTH_M3_S2, J2_EARTH, R_EARTH_M

POSITIONS = np.array(
    [
        [7.0e6, 0.0, 0.0],  # equator
        [0.0, 0.0, 7.2e6],  # north pole
        [0.0, 0.0, -6.9e6],  # south pole
        [4.1e6, -3.3e6, 4.7e6],
        [-2.0e6, 6.5e6, -1.2e6],
        [3.0e7, 2.0e7, -1.5e7],  # far out
    ]
)


# --------------------------------------------------------------------------------------------
# Two-body.
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("r", POSITIONS)
def test_two_body_magnitude_and_direction(r):
    a = np.asarray(two_body_accel(r, MU))
    rn = np.linalg.norm(r)
    assert np.linalg.norm(a) == pytest.approx(MU / rn**2, rel=1e-14)
    # Points to the centre: antiparallel to r.
    np.testing.assert_allclose(a / np.linalg.norm(a), -r / rn, atol=1e-15)


def test_two_body_hand_value():
    # At r = R_E on the x axis: μ / R_E² ≈ 9.798 m/s², towards −x.
    a = np.asarray(two_body_accel(np.array([RE, 0.0, 0.0]), MU))
    np.testing.assert_allclose(a, [-MU / RE**2, 0.0, 0.0], rtol=1e-15)
    assert a[0] == pytest.approx(-9.798, abs=1e-3)


def test_two_body_axis0_and_batch():
    last = np.asarray(two_body_accel(POSITIONS, MU))
    first = np.asarray(two_body_accel(POSITIONS.T, MU, axis=0))
    np.testing.assert_allclose(first, last.T, rtol=1e-15)
    for k, r in enumerate(POSITIONS):
        np.testing.assert_allclose(last[k], two_body_accel(r, MU), rtol=1e-15)


# --------------------------------------------------------------------------------------------
# J2, against a finite-difference gradient of the potential.
# --------------------------------------------------------------------------------------------


def _u_j2(r):
    """Perturbing potential whose gradient is the J2 acceleration, m²/s².

    The potential energy per unit mass is V = −μ/r [1 − J2 (R/r)² (3 sin²φ − 1)/2], a = −∇V.
    Its J2 part is +μ J2 R² (3 sin²φ − 1)/(2 r³), so a_J2 = ∇U with U the negative of that.
    """
    rn = np.linalg.norm(r)
    s = r[2] / rn
    return -MU * J2 * RE**2 * (3.0 * s * s - 1.0) / (2.0 * rn**3)


def _v_total(r):
    rn = np.linalg.norm(r)
    s = r[2] / rn
    return -MU / rn * (1.0 - J2 * (RE / rn) ** 2 * (3.0 * s * s - 1.0) / 2.0)


def _grad(f, r, h=10.0):
    # Fourth-order central differences.
    g = np.empty(3)
    for k in range(3):
        e = np.zeros(3)
        e[k] = h
        g[k] = (-f(r + 2 * e) + 8 * f(r + e) - 8 * f(r - e) + f(r - 2 * e)) / (12 * h)
    return g


@pytest.mark.parametrize("r", POSITIONS)
def test_j2_is_gradient_of_potential(r):
    a = np.asarray(j2_accel(r, MU, J2, RE))
    expected = _grad(_u_j2, r)
    np.testing.assert_allclose(a, expected, rtol=1e-7, atol=1e-9 * np.linalg.norm(expected))


@pytest.mark.parametrize("r", POSITIONS)
def test_two_body_plus_j2_is_minus_gradient_of_total_potential(r):
    a = np.asarray(two_body_accel(r, MU)) + np.asarray(j2_accel(r, MU, J2, RE))
    # The point-mass part dominates by ~1e3, so compare the J2 part separately above and the
    # total here only to the FD accuracy relative to |a|.
    np.testing.assert_allclose(a, -_grad(_v_total, r), rtol=0, atol=1e-9 * np.linalg.norm(a))


def test_j2_hand_values_equator_and_pole():
    r = 7.0e6
    k = 1.5 * J2 * MU * RE**2 / r**4
    # Equator: extra pull inwards, 3/2 J2 μ R²/r⁴.
    np.testing.assert_allclose(j2_accel(np.array([r, 0.0, 0.0]), MU, J2, RE), [-k, 0.0, 0.0], rtol=1e-14)
    # Pole: push outwards, 3 J2 μ R²/r⁴.
    np.testing.assert_allclose(j2_accel(np.array([0.0, 0.0, r]), MU, J2, RE), [0.0, 0.0, 2 * k], rtol=1e-14)
    np.testing.assert_allclose(j2_accel(np.array([0.0, 0.0, -r]), MU, J2, RE), [0.0, 0.0, -2 * k], rtol=1e-14)
    # Order of magnitude at LEO: ~1e-2 m/s².
    assert 5e-3 < k < 2e-2


def test_j2_axis0_and_batch():
    last = np.asarray(j2_accel(POSITIONS, MU, J2, RE))
    first = np.asarray(j2_accel(POSITIONS.T, MU, J2, RE, axis=0))
    np.testing.assert_allclose(first, last.T, rtol=1e-15)
    for k, r in enumerate(POSITIONS):
        np.testing.assert_allclose(last[k], j2_accel(r, MU, J2, RE), rtol=1e-15)


def test_j2_axisymmetric():
    # Rotating the position about z rotates the acceleration the same way.
    r = POSITIONS[3]
    c, s = np.cos(1.1), np.sin(1.1)
    rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    np.testing.assert_allclose(j2_accel(rz @ r, MU, J2, RE), rz @ np.asarray(j2_accel(r, MU, J2, RE)), rtol=1e-13)


# --------------------------------------------------------------------------------------------
# Elements to r, v.
# --------------------------------------------------------------------------------------------


def test_circular_equatorial_at_zero_anomaly():
    a = 7.0e6
    r, v = elements_to_rv(a, 0.0, 0.0, 0.0, 0.0, 0.0, MU)
    np.testing.assert_allclose(r, [a, 0.0, 0.0], atol=1e-6)
    np.testing.assert_allclose(v, [0.0, np.sqrt(MU / a), 0.0], rtol=1e-15, atol=1e-9)


def test_circular_equatorial_quarter_orbit():
    a = 7.0e6
    r, v = elements_to_rv(a, 0.0, 0.0, 0.0, 0.0, np.pi / 2, MU)
    np.testing.assert_allclose(r, [0.0, a, 0.0], atol=1e-6)
    np.testing.assert_allclose(v, [-np.sqrt(MU / a), 0.0, 0.0], rtol=1e-14, atol=1e-9)


def test_periapsis_direction_hand_case():
    # i = 90°, Ω = 90°, ω = 90°, M = 0: node line along +y, periapsis 90° past it, along +z.
    a, e = 8.0e6, 0.2
    r, v = elements_to_rv(a, e, np.pi / 2, np.pi / 2, np.pi / 2, 0.0, MU)
    np.testing.assert_allclose(r, [0.0, 0.0, a * (1 - e)], atol=1e-6)
    # The orbit normal is [sin i sin Ω, −sin i cos Ω, cos i] = +x, so at periapsis (+z) the
    # velocity is along x × z = −y, with magnitude sqrt(μ/p)(1 + e).
    speed = np.sqrt(MU / (a * (1 - e * e))) * (1 + e)
    assert np.linalg.norm(v) == pytest.approx(speed, rel=1e-14)
    np.testing.assert_allclose(v, [0.0, -speed, 0.0], atol=1e-8)


def _h_vec(r, v):
    return np.cross(r, v)


def test_solve_kepler_converges_everywhere_on_a_dense_grid():
    # (6.25, 0.375) once cycled between neighbouring floats near E = 2π and never converged.
    for m in np.linspace(0.0, 2 * np.pi, 400, endpoint=False):
        for e in np.linspace(0.0, 0.95, 40):
            ecc_anom = solve_kepler(m, e)
            assert abs(ecc_anom - e * np.sin(ecc_anom) - m) < 1e-12


_elements = st.tuples(
    st.floats(6.6e6, 4.2e7),  # a
    st.floats(0.0, 0.9),  # e
    st.floats(0.0, np.pi),  # i
    st.floats(0.0, 2 * np.pi),  # raan
    st.floats(0.0, 2 * np.pi),  # argp
    st.floats(-2 * np.pi, 4 * np.pi),  # M, outside [0, 2π) too
)


@settings(max_examples=200, deadline=None)
@given(_elements)
def test_elements_invariants(el):
    a, e, inc, raan, argp, m = el
    r, v = elements_to_rv(a, e, inc, raan, argp, m, MU)
    # Vis-viva energy.
    energy = float(specific_energy_j_kg(r, v, MU))
    assert energy == pytest.approx(-MU / (2 * a), rel=1e-11)
    # Angular momentum magnitude and direction.
    h = _h_vec(r, v)
    hn = np.linalg.norm(h)
    assert hn == pytest.approx(np.sqrt(MU * a * (1 - e * e)), rel=1e-11)
    assert np.arccos(np.clip(h[2] / hn, -1, 1)) == pytest.approx(inc, abs=1e-7)
    # h ∝ [sin i sin Ω, −sin i cos Ω, cos i]
    np.testing.assert_allclose(
        h / hn, [np.sin(inc) * np.sin(raan), -np.sin(inc) * np.cos(raan), np.cos(inc)], atol=1e-10
    )
    # Eccentricity vector: magnitude e, and radius within [a(1−e), a(1+e)].
    e_vec = np.cross(v, h) / MU - r / np.linalg.norm(r)
    assert np.linalg.norm(e_vec) == pytest.approx(e, abs=1e-9)
    rn = np.linalg.norm(r)
    assert a * (1 - e) * (1 - 1e-12) <= rn <= a * (1 + e) * (1 + 1e-12)


@settings(max_examples=100, deadline=None)
@given(st.floats(-10.0, 10.0), st.floats(0.0, 0.99))
def test_solve_kepler_satisfies_equation(m, e):
    ecc_anom = solve_kepler(m, e)
    assert 0.0 - 1e-12 <= ecc_anom <= 2 * np.pi + 1e-12
    resid = (ecc_anom - e * np.sin(ecc_anom)) - np.mod(m, 2 * np.pi)
    assert abs(resid) < 1e-12


def test_elements_consistent_with_two_body_propagation():
    # Propagating the state at M0 for Δt under point-mass gravity lands on the state at M0 + n Δt.
    a, e, inc, raan, argp, m0 = 7.5e6, 0.15, 0.9, 0.4, 2.2, 0.3
    n = np.sqrt(MU / a**3)
    dt = 0.37 * 2 * np.pi / n
    r0, v0 = elements_to_rv(a, e, inc, raan, argp, m0, MU)
    r1, v1 = elements_to_rv(a, e, inc, raan, argp, m0 + n * dt, MU)

    def rhs(_t, y):
        r = y[:3]
        return np.concatenate([y[3:], -MU * r / np.linalg.norm(r) ** 3])

    sol = solve_ivp(rhs, (0.0, dt), np.concatenate([r0, v0]), method="DOP853", rtol=1e-12, atol=1e-6)
    assert sol.success
    np.testing.assert_allclose(sol.y[:3, -1], r1, atol=1e-3)
    np.testing.assert_allclose(sol.y[3:, -1], v1, atol=1e-6)
