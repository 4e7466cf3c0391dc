"""Quasi-nonsingular relative orbital elements: exact round trips through the elements and the
inertial states, D'Amico's first-order mapping to the chief's LVLH frame as an independent
check, the near-circular and equatorial cases, and the refused inputs."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from coopsat.astro.constants import MU_EARTH_M3_S2
from coopsat.astro.kepler import elements_to_rv
from coopsat.astro.roe import elements_from_roe, roe_from_elements, roe_from_rv, rv_from_roe
from coopsat.geometry.frames import eci_to_lvlh

MU = MU_EARTH_M3_S2
TWO_PI = 2.0 * np.pi
PROP = settings(max_examples=50, deadline=None)

CHIEFS = {
    # (a_m, e, i_rad, raan_rad, argp_rad, mean_anomaly_rad)
    "leo_circular_sso": (7000e3, 0.0, np.radians(97.4), np.radians(30.0), 0.0, np.radians(45.0)),
    "leo_near_circular": (6878e3, 1e-4, np.radians(97.4), np.radians(300.0), np.radians(120.0), np.radians(250.0)),
    "eccentric_iss_incl": (8000e3, 0.1, np.radians(51.6), np.radians(200.0), np.radians(60.0), np.radians(300.0)),
}


def wrap(angle_rad):
    return np.angle(np.exp(1j * np.asarray(angle_rad)))


def assert_same_elements(got, want, atol):
    got, want = np.asarray(got), np.asarray(want)
    assert got[0] == pytest.approx(want[0], rel=atol)
    np.testing.assert_allclose(got[1:3], want[1:3], rtol=0, atol=atol)
    np.testing.assert_allclose(wrap(got[3:] - want[3:]), 0.0, rtol=0, atol=atol)


# ----------------------------------------------------------------------------- definition


def test_definition_on_a_hand_worked_pair():
    chief = (7000e3, 0.01, 1.0, 0.5, 0.3, 2.0)
    deputy = (7007e3, 0.02, 1.1, 0.6, 0.4, 2.1)
    want = [
        1e-3,
        0.2 + 0.1 * np.cos(1.0),
        0.02 * np.cos(0.4) - 0.01 * np.cos(0.3),
        0.02 * np.sin(0.4) - 0.01 * np.sin(0.3),
        0.1,
        0.1 * np.sin(1.0),
    ]
    np.testing.assert_allclose(roe_from_elements(chief, deputy), want, rtol=0, atol=1e-14)


def test_angle_differences_wrap_to_minus_pi_excluded_pi_included():
    chief = (7000e3, 0.0, 1.0, 0.1, 0.0, 0.0)
    # The deputy just past the chief's u = 0 from the other side of 2π: a small lead, not ~2π.
    roe = roe_from_elements(chief, (7000e3, 0.0, 1.0, 0.1, 0.0, TWO_PI - 1e-3))
    assert roe[1] == pytest.approx(-1e-3, abs=1e-15)
    # Half a revolution ahead or behind is the same point: both are +π.
    for m_d in (np.pi, -np.pi, 3.0 * np.pi):
        assert roe_from_elements(chief, (7000e3, 0.0, 1.0, 0.1, 0.0, m_d))[1] == np.pi
    # A node offset across Ω = 0 wraps as well.
    roe = roe_from_elements(chief, (7000e3, 0.0, 1.0, 0.1 + TWO_PI - 2e-3, 0.0, 0.0))
    assert roe[5] == pytest.approx(-2e-3 * np.sin(1.0), abs=1e-15)


# ----------------------------------------------------------------------------- round trips


_ANGLE = st.floats(0.0, TWO_PI, exclude_max=True)


@PROP
@given(
    name=st.sampled_from(sorted(CHIEFS)),
    a_scale=st.floats(0.9, 1.1),
    e_d=st.floats(1e-3, 0.3),
    i_d=st.floats(0.05, np.pi - 0.05),
    raan_d=_ANGLE,
    argp_d=_ANGLE,
    m_d=_ANGLE,
)
def test_elements_to_roe_to_elements(name, a_scale, e_d, i_d, raan_d, argp_d, m_d):
    chief = CHIEFS[name]
    deputy = (chief[0] * a_scale, e_d, i_d, raan_d, argp_d, m_d)
    # e_d ≥ 1e-3 keeps ω_d well conditioned: its rounding error is about 1e-16/e_d.
    assert_same_elements(elements_from_roe(chief, roe_from_elements(chief, deputy)), deputy, atol=1e-12)


@PROP
@given(
    name=st.sampled_from(sorted(CHIEFS)),
    d_a=st.floats(-0.1, 0.1),
    d_lambda=st.floats(-2.0, 2.0),
    d_ex=st.floats(-0.05, 0.05),
    d_ey=st.floats(-0.05, 0.05),
    d_ix=st.floats(-0.5, 0.5),
    d_iy=st.floats(-0.5, 0.5),
)
def test_roe_to_elements_to_roe(name, d_a, d_lambda, d_ex, d_ey, d_ix, d_iy):
    # Ranges chosen so that every draw is a valid deputy whose angle offsets need no wrapping:
    # sin i_c ≥ sin 51.6° keeps |ΔΩ| ≤ 0.64 rad, so |Δu| ≤ 2 + 0.64 < π; e_d ≤ 0.1 + 0.071;
    # i_c ± 0.5 stays in [0, π] for both inclinations.
    chief = CHIEFS[name]
    roe = np.array([d_a, d_lambda, d_ex, d_ey, d_ix, d_iy])
    np.testing.assert_allclose(roe_from_elements(chief, elements_from_roe(chief, roe)), roe, rtol=0, atol=1e-12)


ROE_CASES = {
    "formation_100m": np.array([0.0, 100.0, 50.0, -80.0, 30.0, 60.0]) / 7000e3,
    "drifting_km": np.array([2e3, -5e3, 1e3, 1e3, -2e3, 3e3]) / 7000e3,
    "far_apart": np.array([0.02, 2.5, 0.03, -0.04, 0.2, -0.3]),
}


@pytest.mark.parametrize("roe_name", sorted(ROE_CASES))
@pytest.mark.parametrize("chief_name", sorted(CHIEFS))
def test_rv_to_roe_to_rv(chief_name, roe_name):
    chief = CHIEFS[chief_name]
    r_c, v_c = elements_to_rv(*chief, MU)
    r_d, v_d = elements_to_rv(*elements_from_roe(chief, ROE_CASES[roe_name]), MU)
    r, v = rv_from_roe(r_c, v_c, roe_from_rv(r_c, v_c, r_d, v_d, MU), MU)
    np.testing.assert_allclose(r, r_d, rtol=0, atol=1e-6)
    np.testing.assert_allclose(v, v_d, rtol=0, atol=1e-9)


def test_rv_round_trip_with_a_circular_deputy_of_a_circular_chief():
    # Both states have e of order 1e-16 from rounding, so both ω are arbitrary or set to 0:
    # only u and the (tiny) e vectors enter, and the state comes back.
    chief = CHIEFS["leo_circular_sso"]
    r_c, v_c = elements_to_rv(*chief, MU)
    r_d, v_d = elements_to_rv(7000.1e3, 0.0, chief[2] + 1e-5, chief[3] - 1e-5, 0.0, chief[5] + 2e-5, MU)
    r, v = rv_from_roe(r_c, v_c, roe_from_rv(r_c, v_c, r_d, v_d, MU), MU)
    np.testing.assert_allclose(r, r_d, rtol=0, atol=1e-6)
    np.testing.assert_allclose(v, v_d, rtol=0, atol=1e-9)


# ----------------------------------------------------------------------------- near-circular


@pytest.mark.parametrize("argp_c", [0.0, 1.0, 2.5, 4.0, 5.5])
def test_roe_continuous_as_the_chief_becomes_circular(argp_c):
    # Classical differences break here: a chief with e = 1e-9 has an ω anywhere in [0, 2π), so
    # Δω and ΔM jump by O(1) between these chiefs. The ROE change by O(e) = O(1e-9) only.
    u_c, i_c, raan_c = 0.7, np.radians(97.4), 0.3
    r_d, v_d = elements_to_rv(7001e3, 2e-4, i_c + 1e-4, raan_c + 2e-4, 0.4, u_c - 0.4 + 3e-5, MU)
    r_0, v_0 = elements_to_rv(7000e3, 0.0, i_c, raan_c, 0.0, u_c, MU)
    r_1, v_1 = elements_to_rv(7000e3, 1e-9, i_c, raan_c, argp_c, u_c - argp_c, MU)
    roe_0 = roe_from_rv(r_0, v_0, r_d, v_d, MU)
    roe_1 = roe_from_rv(r_1, v_1, r_d, v_d, MU)
    np.testing.assert_allclose(roe_1, roe_0, rtol=0, atol=5e-9)


# ----------------------------------------------------------------------------- first-order mapping


def _damico_rtn(roe, u, a, n):
    """D'Amico's (2010, chapter 2) first-order map at t = 0, near-circular chief: RTN position, m,
    and velocity, m/s (the velocity is the time derivative of the position map, with u̇ = n and
    the along-track drift −(3/2) n δa)."""
    d_a, d_lambda, d_ex, d_ey, d_ix, d_iy = roe
    c, s = np.cos(u), np.sin(u)
    rho = a * np.array([d_a - d_ex * c - d_ey * s, d_lambda + 2 * d_ex * s - 2 * d_ey * c, d_ix * s - d_iy * c])
    rho_dot = a * n * np.array([d_ex * s - d_ey * c, -1.5 * d_a + 2 * (d_ex * c + d_ey * s), d_ix * c + d_iy * s])
    return rho, rho_dot


def _lvlh_to_rtn(vec_lvlh):
    # coopsat.geometry.frames: x along-track (T), y = −h/|h| (−N), z nadir (−R).
    x, y, z = vec_lvlh
    return np.array([-z, x, -y])


_RNG = np.random.default_rng(2006)
_DIRECTIONS = [np.array([1.0, 0, 0, 0, 0, 0]), np.array([0, 0, 1.0, 0, 0, 0]), np.array([0, 0, 0, 0, 0, 1.0])] + [
    d / np.linalg.norm(d) for d in _RNG.normal(size=(5, 6))
]


@pytest.mark.parametrize("e_c", [0.0, 1e-4])
@pytest.mark.parametrize("u_c", [0.0, 1.0, 2.5, 4.0, 5.5])
@pytest.mark.parametrize("k", range(len(_DIRECTIONS)))
def test_lvlh_offset_matches_damico_first_order_mapping(k, u_c, e_c):
    a, i_c, raan_c, argp_c = 7000e3, np.radians(97.4), np.radians(30.0), np.radians(40.0)
    chief = (a, e_c, i_c, raan_c, argp_c, u_c - argp_c)
    roe = _DIRECTIONS[k] * 100.0 / a  # a |δα| = 100 m
    r_c, v_c = elements_to_rv(*chief, MU)
    r_d, v_d = elements_to_rv(*elements_from_roe(chief, roe), MU)
    rho_lvlh, rho_dot_lvlh = eci_to_lvlh(r_c, v_c, r_d, v_d)
    n = np.sqrt(MU / a**3)
    rho_want, rho_dot_want = _damico_rtn(roe, u_c, a, n)
    # The mapping drops terms of second order in δα (curvature of the along-track arc, the
    # product of the along-track and node offsets, ...: each a |δα|² times a factor of order 1,
    # here 1.4e-3 m) and, for e_c > 0, terms of order e_c a |δα| (the chief's radius and rate
    # vary by e_c about their means, and its true and mean u differ by up to 2 e_c: 1e-2 m
    # each). Five times the sum of both allows for the O(1) factors; an error in any
    # first-order coefficient would be of order a |δα| = 100 m.
    d_alpha = np.linalg.norm(roe)
    tol_m = 5.0 * a * (d_alpha**2 + e_c * d_alpha)
    np.testing.assert_allclose(_lvlh_to_rtn(np.asarray(rho_lvlh)), rho_want, rtol=0, atol=tol_m)
    np.testing.assert_allclose(_lvlh_to_rtn(np.asarray(rho_dot_lvlh)), rho_dot_want, rtol=0, atol=n * tol_m)


# ----------------------------------------------------------------------------- equatorial chief


def test_equatorial_chief_drops_the_node_offset_and_keeps_the_longitude():
    chief = (7000e3, 0.001, 0.0, 0.0, 1.0, 2.0)
    deputy = (7000.1e3, 0.001, 1e-4, 0.5, 0.6, 2.3)
    roe = roe_from_elements(chief, deputy)
    assert roe[5] == 0.0
    back = elements_from_roe(chief, roe)
    assert back[3] == 0.0  # the deputy's node put on the chief's
    # The mean longitude Ω + ω + M (all that defines a near-equatorial deputy's position along
    # the orbit) and the e vector are kept.
    assert wrap(back[3:].sum() - np.sum(deputy[3:])) == pytest.approx(0.0, abs=1e-14)
    assert back[1] == pytest.approx(deputy[1], abs=1e-15)
    assert wrap(back[4] - deputy[4]) == pytest.approx(0.0, abs=1e-12)


# ----------------------------------------------------------------------------- refused inputs

LEO = CHIEFS["leo_circular_sso"]


@pytest.mark.parametrize(
    ("chief", "roe", "cause"),
    [
        (LEO, [-1.2, 0, 0, 0, 0, 0], "non-positive deputy semi-major axis"),
        (LEO, [-1.0, 0, 0, 0, 0, 0], "non-positive deputy semi-major axis"),
        (LEO, [0, 0, 1.0, 0, 0, 0], "deputy eccentricity"),
        (CHIEFS["eccentric_iss_incl"], [0, 0, 0.7, 0.7, 0, 0], "deputy eccentricity"),
        ((7000e3, 0.0, 0.0, 0.0, 0.0, 0.0), [0, 0, 0, 0, 0.1, 1e-6], "equatorial chief"),
        ((7000e3, 0.0, np.pi, 0.0, 0.0, 0.0), [0, 0, 0, 0, -0.1, 1e-6], "equatorial chief"),
        ((7000e3, 0.0, 0.1, 0.0, 0.0, 0.0), [0, 0, 0, 0, -0.2, 0], "deputy inclination"),
        (LEO, [0, 0, 0, 0, 1.5, 0], "deputy inclination"),
    ],
)
def test_invalid_roe_are_refused_with_one_line(chief, roe, cause):
    with pytest.raises(ValueError, match=cause) as info:
        elements_from_roe(chief, roe)
    message = str(info.value)
    assert message.startswith("roe: ") and "\n" not in message
    r_c, v_c = elements_to_rv(*chief, MU)
    with pytest.raises(ValueError, match=cause):
        rv_from_roe(r_c, v_c, roe, MU)


def test_semi_major_axis_message_gives_the_values():
    with pytest.raises(ValueError) as info:
        elements_from_roe(LEO, [-1.2, 0, 0, 0, 0, 0])
    assert str(info.value) == "roe: δa = -1.2 gives a non-positive deputy semi-major axis (-1.4e+06 m)"
