"""Property tests of the quaternion algebra in coopsat.geometry.quaternion.

Convention: scalar-first, Hamilton product, ``q_bi`` takes body components to inertial,
``v_i = q ⊗ [0, v_b] ⊗ q*``, kinematics ``q̇ = ½ q ⊗ [0, ω_b]``, error ``q_j* ⊗ q_i``.
"""

import inspect

import jax
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from coopsat.geometry.quaternion import (
    cross,
    dcm_to_quat,
    quat_angle,
    quat_conjugate,
    quat_error,
    quat_exp_rate,
    quat_from_axis_angle,
    quat_kinematics,
    quat_multiply,
    quat_normalize,
    quat_positive,
    quat_rotate,
    quat_to_dcm,
    quat_vector,
)

PROP = settings(max_examples=200, deadline=None)
IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


def _component(lo, hi):
    # Tiny magnitudes are set to exactly zero: XLA on the CPU flushes subnormals to zero, so a
    # component of -1e-309 compares as 0 (see test_positive_* below) -- not what is under test.
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False).map(lambda x: 0.0 if abs(x) < 1e-100 else x)


def _unit(x):
    return x / np.linalg.norm(x)


_c1 = _component(-1.0, 1.0)
# Tuples mapped to arrays draw about twice as fast as hypothesis.extra.numpy.arrays here.
raw_quats = st.tuples(_c1, _c1, _c1, _c1).map(np.array).filter(lambda q: np.linalg.norm(q) >= 0.1)
"""Quaternions with norm in [0.1, 2]: away from the degenerate zero quaternion."""
unit_quats = raw_quats.map(_unit)
unit_vectors = st.tuples(_c1, _c1, _c1).map(np.array).filter(lambda v: np.linalg.norm(v) >= 0.1).map(_unit)
_c10 = _component(-10.0, 10.0)
vectors = st.tuples(_c10, _c10, _c10).map(np.array)


def _same_rotation(p, q, atol=1e-12):
    p, q = np.asarray(p), np.asarray(q)
    s = 1.0 if np.dot(p, q) >= 0 else -1.0
    np.testing.assert_allclose(p, s * q, atol=atol)


class J:
    """Jitted versions for the property tests.

    Eager JAX dispatch costs about a millisecond a call, which makes hundreds of examples per
    property too slow; compiled, a call is about 10 µs. The hand cases, the exactness checks
    and the layout tests call the eager functions.
    """


for _fn in (
    cross, dcm_to_quat, quat_angle, quat_conjugate, quat_error, quat_exp_rate, quat_from_axis_angle,
    quat_kinematics, quat_multiply, quat_normalize, quat_positive, quat_rotate, quat_to_dcm, quat_vector,
):
    _params = inspect.signature(_fn).parameters
    _static = ("axis",) if "axis" in _params and _fn is not quat_from_axis_angle else ()
    setattr(J, _fn.__name__, staticmethod(jax.jit(_fn, static_argnames=_static)))


# --------------------------------------------------------------------------------------------
# Algebra.
# --------------------------------------------------------------------------------------------


@PROP
@given(raw_quats, raw_quats, raw_quats)
def test_multiply_associative(p, q, r):
    lhs = J.quat_multiply(J.quat_multiply(p, q), r)
    rhs = J.quat_multiply(p, J.quat_multiply(q, r))
    np.testing.assert_allclose(lhs, rhs, atol=1e-13)


@PROP
@given(raw_quats, raw_quats)
def test_multiply_norm_and_conjugate(p, q):
    pq = np.asarray(J.quat_multiply(p, q))
    # |p ⊗ q| = |p| |q|
    assert np.linalg.norm(pq) == pytest.approx(np.linalg.norm(p) * np.linalg.norm(q), rel=1e-14)
    # (p ⊗ q)* = q* ⊗ p*
    np.testing.assert_allclose(
        J.quat_conjugate(pq), J.quat_multiply(J.quat_conjugate(q), J.quat_conjugate(p)), atol=1e-15
    )


@PROP
@given(raw_quats)
def test_identity_inverse_normalize(q):
    np.testing.assert_allclose(J.quat_multiply(IDENTITY, q), q, atol=1e-15)
    np.testing.assert_allclose(J.quat_multiply(q, IDENTITY), q, atol=1e-15)
    u = np.asarray(J.quat_normalize(q))
    assert np.linalg.norm(u) == pytest.approx(1.0, abs=1e-15)
    np.testing.assert_allclose(u * np.linalg.norm(q), q, atol=1e-15)
    # q ⊗ q* = q* ⊗ q = identity for unit q
    np.testing.assert_allclose(J.quat_multiply(u, J.quat_conjugate(u)), IDENTITY, atol=1e-15)
    np.testing.assert_allclose(J.quat_multiply(J.quat_conjugate(u), u), IDENTITY, atol=1e-15)


def test_conjugate_values():
    np.testing.assert_array_equal(quat_conjugate(np.array([1.0, 2.0, -3.0, 4.0])), [1.0, -2.0, 3.0, -4.0])


# --------------------------------------------------------------------------------------------
# Rotation.
# --------------------------------------------------------------------------------------------


@PROP
@given(unit_quats, vectors, vectors)
def test_rotation_properties(q, v, w):
    rv = np.asarray(J.quat_rotate(q, v))
    # preserves the norm
    assert np.linalg.norm(rv) == pytest.approx(np.linalg.norm(v), rel=1e-13, abs=1e-13)
    # is the sandwich product q ⊗ [0, v] ⊗ q*
    sandwich = np.asarray(J.quat_multiply(J.quat_multiply(q, np.concatenate([[0.0], v])), J.quat_conjugate(q)))
    assert abs(sandwich[0]) < 1e-13
    np.testing.assert_allclose(rv, sandwich[1:], atol=1e-13)
    # q* undoes it
    np.testing.assert_allclose(J.quat_rotate(J.quat_conjugate(q), rv), v, atol=1e-12)
    # preserves cross products (proper rotation, not a reflection)
    np.testing.assert_allclose(
        J.cross(rv, J.quat_rotate(q, w)), J.quat_rotate(q, J.cross(v, w)), atol=1e-11
    )
    # leaves the axis (the vector part of q) fixed
    u = np.asarray(J.quat_vector(q)) * w[0]
    np.testing.assert_allclose(J.quat_rotate(q, u), u, atol=1e-12)
    # equals the DCM, which is orthonormal with det +1
    c = np.asarray(J.quat_to_dcm(q))
    np.testing.assert_allclose(c @ v, rv, atol=1e-12)
    np.testing.assert_allclose(c @ c.T, np.eye(3), atol=1e-14)
    assert np.linalg.det(c) == pytest.approx(1.0, abs=1e-13)
    # the DCM maps back to ±q, in the q0 ≥ 0 hemisphere
    back = np.asarray(J.dcm_to_quat(c))
    assert back[0] >= 0.0
    _same_rotation(back, q, atol=1e-12)
    # kinematics keeps |q| constant: q·q̇ = 0 (Ω(ω) is skew-symmetric)
    assert abs(float(np.dot(q, np.asarray(J.quat_kinematics(q, w))))) < 1e-13


@PROP
@given(unit_quats, unit_quats, vectors)
def test_rotate_composition(p, q, v):
    # p ⊗ q rotates by q first, then by p.
    np.testing.assert_allclose(
        J.quat_rotate(J.quat_multiply(p, q), v), J.quat_rotate(p, J.quat_rotate(q, v)), atol=1e-12
    )


# --------------------------------------------------------------------------------------------
# Error, sign, angle.
# --------------------------------------------------------------------------------------------


@PROP
@given(unit_quats, unit_quats)
def test_error(q_i, q_j):
    np.testing.assert_allclose(J.quat_error(q_i, q_i), IDENTITY, atol=1e-15)
    # q_j ⊗ err = q_i, i.e. err = q_j* ⊗ q_i (NOT q_i ⊗ q_j*).
    err = J.quat_error(q_i, q_j)
    np.testing.assert_allclose(J.quat_multiply(q_j, err), q_i, atol=1e-14)
    np.testing.assert_allclose(err, J.quat_multiply(J.quat_conjugate(q_j), q_i), atol=1e-15)


def test_error_with_itself_is_identity_eager():
    q = _unit(np.array([0.3, -0.4, 0.5, 0.6]))
    np.testing.assert_allclose(quat_error(q, q), IDENTITY, atol=1e-15)


def test_error_order_hand_case():
    # i w.r.t. j, with j = 90° about z and i = 90° about z then 90° about body x:
    # the error is 90° about x (the body-frame relative rotation).
    c, s = np.cos(np.pi / 4), np.sin(np.pi / 4)
    q_j = np.array([c, 0.0, 0.0, s])
    q_x = np.array([c, s, 0.0, 0.0])
    q_i = np.asarray(quat_multiply(q_j, q_x))
    np.testing.assert_allclose(quat_error(q_i, q_j), q_x, atol=1e-15)
    # The other order, q_i ⊗ q_j*, is the inertial-frame relative rotation: about inertial y here.
    np.testing.assert_allclose(quat_multiply(q_i, quat_conjugate(q_j)), [c, 0.0, s, 0.0], atol=1e-15)


@PROP
@given(unit_quats, vectors)
def test_positive_hemisphere_same_rotation_and_angle(q, v):
    p = np.asarray(J.quat_positive(q))
    assert p[0] >= 0.0
    assert np.array_equal(p, q) or np.array_equal(p, -q)
    np.testing.assert_allclose(J.quat_rotate(p, v), J.quat_rotate(q, v), atol=1e-12)
    a = float(J.quat_angle(q))
    assert 0.0 <= a <= np.pi + 1e-15
    assert float(J.quat_angle(-q)) == pytest.approx(a, abs=1e-15)
    assert float(J.quat_angle(p)) == pytest.approx(a, abs=1e-15)


def test_positive_flips_negative_scalar():
    q = np.array([-0.5, 0.5, -0.5, 0.5])
    np.testing.assert_array_equal(quat_positive(q), -q)
    np.testing.assert_array_equal(quat_positive(-q), -q)


@PROP
@given(unit_vectors, st.floats(min_value=0.0, max_value=np.pi), vectors)
def test_axis_angle(axis, a, v):
    q = J.quat_from_axis_angle(axis, a)
    assert np.linalg.norm(np.asarray(q)) == pytest.approx(1.0, abs=1e-15)
    assert float(J.quat_angle(q)) == pytest.approx(a, abs=1e-13)
    # Right-handed (Rodrigues): v cos a + (k × v) sin a + k (k·v)(1 − cos a), for ±a.
    for ang in (a, -a):
        expected = v * np.cos(ang) + np.cross(axis, v) * np.sin(ang) + axis * np.dot(axis, v) * (1 - np.cos(ang))
        np.testing.assert_allclose(J.quat_rotate(J.quat_from_axis_angle(axis, ang), v), expected, atol=1e-12)


def test_angle_eager_hand_values():
    z = np.array([0.0, 0.0, 1.0])
    for a in (0.0, 1e-8, 0.5, np.pi / 2, np.pi - 1e-8, np.pi):
        assert float(quat_angle(quat_from_axis_angle(z, a))) == pytest.approx(a, abs=1e-15)


# --------------------------------------------------------------------------------------------
# Kinematics and the exact constant-rate solution.
# --------------------------------------------------------------------------------------------


def _integrate(q0, omega, t_end):
    sol = solve_ivp(
        lambda _t, q: np.asarray(J.quat_kinematics(q, omega)),
        (0.0, t_end),
        q0,
        method="DOP853",
        rtol=1e-12,
        atol=1e-14,
    )
    assert sol.success
    return sol.y[:, -1]


@pytest.mark.parametrize("fn", [quat_exp_rate, J.quat_exp_rate], ids=["eager", "jit"])
def test_exp_rate_zero_omega_is_identity_exactly(fn):
    for t in (0.0, 1.0, 1e6):
        np.testing.assert_array_equal(fn(np.zeros(3), t), IDENTITY)


def test_exp_rate_zero_time_is_identity():
    np.testing.assert_array_equal(quat_exp_rate(np.array([0.3, -0.2, 0.1]), 0.0), IDENTITY)


def test_exp_rate_differentiable_at_zero_omega():
    # d/dω exp(½ [0, ω] t) at ω = 0 is ½ t [0; I₃]; with t = 2 that is [0; I₃].
    jac = np.asarray(jax.jacfwd(quat_exp_rate)(np.zeros(3), 2.0))
    assert np.all(np.isfinite(jac))
    np.testing.assert_allclose(jac, np.vstack([np.zeros((1, 3)), np.eye(3)]), atol=1e-15)


def test_exp_rate_differentiable_near_zero_omega():
    # To first order in ω: q0 ≈ 1 − t²|ω|²/8 so dq0/dω ≈ −t² ω / 4, and dq_vec/dω ≈ ½ t I₃.
    w = np.array([1e-9, -2e-9, 3e-9])
    jac = np.asarray(jax.jacfwd(quat_exp_rate)(w, 2.0))
    np.testing.assert_allclose(jac, np.vstack([-w[None, :], np.eye(3)]), atol=1e-15)


@pytest.mark.parametrize(
    ("omega", "t"),
    [
        ([0.0, 0.0, 0.5], 3.0),
        ([0.1, -0.2, 0.3], 10.0),
        ([2.0, 1.0, -3.0], 1.7),
        ([1e-6, 0.0, 0.0], 100.0),
    ],
)
def test_exp_rate_solves_kinematics_from_identity(omega, t):
    omega = np.asarray(omega)
    np.testing.assert_allclose(quat_exp_rate(omega, t), _integrate(IDENTITY, omega, t), atol=1e-10)


@settings(max_examples=25, deadline=None)
@given(unit_quats, st.tuples(*[st.floats(-2.0, 2.0)] * 3).map(np.array), st.floats(0.0, 5.0))
def test_exp_rate_propagates_any_initial_attitude(q0, omega, t):
    # q(t) = q(0) ⊗ exp(½ [0, ω] t) for a constant BODY rate (right multiplication).
    expected = _integrate(q0, omega, t) if t > 0 else q0
    np.testing.assert_allclose(J.quat_multiply(q0, J.quat_exp_rate(omega, t)), expected, atol=1e-10)


@PROP
@given(st.tuples(*[st.floats(-3.0, 3.0)] * 3).map(np.array).filter(lambda w: np.linalg.norm(w) > 1e-3),
       st.floats(-10.0, 10.0))
def test_exp_rate_is_axis_angle(omega, t):
    rate = np.linalg.norm(omega)
    np.testing.assert_allclose(
        J.quat_exp_rate(omega, t), J.quat_from_axis_angle(omega / rate, rate * t), atol=1e-13
    )


# --------------------------------------------------------------------------------------------
# Layout: component axis 0 vs -1, and leading-axis vectorisation.
# --------------------------------------------------------------------------------------------

N = 7


@pytest.fixture(scope="module")
def batch():
    rng = np.random.default_rng(7)
    q = rng.normal(size=(N, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    p = rng.normal(size=(N, 4))
    p /= np.linalg.norm(p, axis=-1, keepdims=True)
    q[0] *= -1.0 if q[0, 0] > 0 else 1.0  # at least one negative scalar part
    p[1] *= 3.0  # one non-unit quaternion for normalize
    return {"q": q, "p": p, "v": rng.normal(size=(N, 3)), "w": rng.normal(size=(N, 3))}


_LAYOUT_CASES = {
    "quat_multiply": (quat_multiply, ("p", "q")),
    "quat_conjugate": (quat_conjugate, ("q",)),
    "quat_normalize": (quat_normalize, ("p",)),
    "quat_positive": (quat_positive, ("q",)),
    "quat_error": (quat_error, ("q", "p")),
    "quat_rotate": (quat_rotate, ("q", "v")),
    "quat_kinematics": (quat_kinematics, ("q", "w")),
    "cross": (cross, ("v", "w")),
    "quat_vector": (quat_vector, ("q",)),
}


@pytest.mark.parametrize("name", sorted(_LAYOUT_CASES))
def test_axis0_equals_transposed_axis_last(batch, name):
    fn, keys = _LAYOUT_CASES[name]
    last = np.asarray(fn(*(batch[k] for k in keys), axis=-1))
    first = np.asarray(fn(*(batch[k].T for k in keys), axis=0))
    assert first.shape == last.T.shape
    np.testing.assert_allclose(first, last.T, atol=1e-15)


@pytest.mark.parametrize("name", sorted(_LAYOUT_CASES))
def test_axis_last_matches_single_calls(batch, name):
    fn, keys = _LAYOUT_CASES[name]
    stacked = np.asarray(fn(*(batch[k] for k in keys)))
    for n in range(N):
        np.testing.assert_allclose(stacked[n], fn(*(batch[k][n] for k in keys)), atol=1e-15)


@pytest.mark.parametrize("name", sorted(_LAYOUT_CASES))
def test_axis0_three_dimensional(batch, name):
    # Component-major with two trailing batch axes, (4, 2, 3): axis 0 must not be confused
    # with a batch axis.
    fn, keys = _LAYOUT_CASES[name]
    rng = np.random.default_rng(11)
    args_last = [rng.normal(size=(2, 3, batch[k].shape[-1])) for k in keys]
    last = np.asarray(fn(*args_last, axis=-1))
    first = np.asarray(fn(*(np.moveaxis(a, -1, 0) for a in args_last), axis=0))
    np.testing.assert_allclose(first, np.moveaxis(last, -1, 0), atol=1e-14)


def test_leading_axes_vectorisation():
    rng = np.random.default_rng(3)
    q = rng.normal(size=(2, 3, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    p = rng.normal(size=(2, 3, 4))
    p /= np.linalg.norm(p, axis=-1, keepdims=True)
    v = rng.normal(size=(2, 3, 3))
    t = rng.uniform(0, 4, size=(2, 3))
    out = {
        "mul": np.asarray(quat_multiply(p, q)),
        "rot": np.asarray(quat_rotate(q, v)),
        "err": np.asarray(quat_error(q, p)),
        "dcm": np.asarray(quat_to_dcm(q)),
        "angle": np.asarray(quat_angle(q)),
        "exp": np.asarray(quat_exp_rate(v, t)),
        "kin": np.asarray(quat_kinematics(q, v)),
        "pos": np.asarray(quat_positive(q)),
        "d2q": np.asarray(dcm_to_quat(quat_to_dcm(q))),
    }
    assert out["mul"].shape == (2, 3, 4)
    assert out["rot"].shape == (2, 3, 3)
    assert out["dcm"].shape == (2, 3, 3, 3)
    assert out["angle"].shape == (2, 3)
    assert out["d2q"].shape == (2, 3, 4)
    for a in range(2):
        for b in range(3):
            np.testing.assert_allclose(out["mul"][a, b], quat_multiply(p[a, b], q[a, b]), atol=1e-15)
            np.testing.assert_allclose(out["rot"][a, b], quat_rotate(q[a, b], v[a, b]), atol=1e-15)
            np.testing.assert_allclose(out["err"][a, b], quat_error(q[a, b], p[a, b]), atol=1e-15)
            np.testing.assert_allclose(out["dcm"][a, b], quat_to_dcm(q[a, b]), atol=1e-15)
            np.testing.assert_allclose(out["angle"][a, b], quat_angle(q[a, b]), atol=1e-15)
            np.testing.assert_allclose(out["exp"][a, b], quat_exp_rate(v[a, b], t[a, b]), atol=1e-15)
            np.testing.assert_allclose(out["kin"][a, b], quat_kinematics(q[a, b], v[a, b]), atol=1e-15)
            np.testing.assert_allclose(out["pos"][a, b], quat_positive(q[a, b]), atol=0)
            np.testing.assert_allclose(out["d2q"][a, b], dcm_to_quat(quat_to_dcm(q[a, b])), atol=1e-15)


def test_broadcast_single_quaternion_over_vectors():
    q = np.asarray(quat_from_axis_angle(np.array([0.0, 0.0, 1.0]), np.pi / 2))
    v = np.eye(3)
    np.testing.assert_allclose(quat_rotate(q[None], v), [[0, 1, 0], [-1, 0, 0], [0, 0, 1]], atol=1e-15)
