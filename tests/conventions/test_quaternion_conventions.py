"""Pin the quaternion convention (scalar-first, Hamilton, q_bi: body -> inertial) against SciPy.

SciPy's ``Rotation`` is scalar-LAST by default; every call here passes ``scalar_first=True``.
SciPy's ``Rotation.apply`` is an active rotation by the matrix ``as_matrix()``, which is the
same operation as ``v_i = C_bi v_b`` for ``q_bi`` (body components to inertial components).
"""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from coopsat.geometry.quaternion import (
    dcm_to_quat,
    quat_angle,
    quat_kinematics,
    quat_multiply,
    quat_rotate,
    quat_to_dcm,
)

RNG_SEED = 20100101


def _random_unit_quats(n, seed=RNG_SEED):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


@pytest.fixture(scope="module")
def quats():
    return _random_unit_quats(64)


@pytest.fixture(scope="module")
def vecs():
    return np.random.default_rng(RNG_SEED + 1).normal(size=(64, 3))


def _rot(q):
    return Rotation.from_quat(np.asarray(q), scalar_first=True)


# --------------------------------------------------------------------------------------------
# Hand-computed 90° case: no library on the other side.
# --------------------------------------------------------------------------------------------

Q_Z90 = np.array([np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4)])


def test_z90_rotates_body_x_to_inertial_y():
    v_i = np.asarray(quat_rotate(Q_Z90, np.array([1.0, 0.0, 0.0])))
    np.testing.assert_allclose(v_i, [0.0, 1.0, 0.0], atol=1e-15)


def test_z90_rotates_body_y_to_inertial_minus_x():
    v_i = np.asarray(quat_rotate(Q_Z90, np.array([0.0, 1.0, 0.0])))
    np.testing.assert_allclose(v_i, [-1.0, 0.0, 0.0], atol=1e-15)


def test_z90_dcm():
    c = np.asarray(quat_to_dcm(Q_Z90))
    np.testing.assert_allclose(c, [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]], atol=1e-15)


def test_z90_angle():
    assert float(quat_angle(Q_Z90)) == pytest.approx(np.pi / 2, abs=1e-15)


def test_z90_is_scipy_z90():
    # Guards against a scalar-last mix-up in the comparisons below.
    np.testing.assert_allclose(_rot(Q_Z90).as_rotvec(), [0.0, 0.0, np.pi / 2], atol=1e-15)
    np.testing.assert_allclose(Rotation.from_euler("z", 90, degrees=True).as_quat(scalar_first=True), Q_Z90, atol=1e-15)


def test_hamilton_basis_products():
    # Hamilton: i j = k, j k = i, k i = j, i i = -1 (a JPL/Shuster product would give i j = -k).
    one, i, j, k = np.eye(4)
    np.testing.assert_allclose(quat_multiply(i, j), k, atol=0)
    np.testing.assert_allclose(quat_multiply(j, k), i, atol=0)
    np.testing.assert_allclose(quat_multiply(k, i), j, atol=0)
    np.testing.assert_allclose(quat_multiply(j, i), -k, atol=0)
    np.testing.assert_allclose(quat_multiply(i, i), -one, atol=0)


# --------------------------------------------------------------------------------------------
# Against SciPy.
# --------------------------------------------------------------------------------------------


def test_rotate_matches_scipy_apply(quats, vecs):
    expected = _rot(quats).apply(vecs)
    np.testing.assert_allclose(np.asarray(quat_rotate(quats, vecs)), expected, atol=1e-13)


def test_dcm_matches_scipy_matrix(quats):
    np.testing.assert_allclose(np.asarray(quat_to_dcm(quats)), _rot(quats).as_matrix(), atol=1e-14)


def test_dcm_times_vector_equals_rotate(quats, vecs):
    c = np.asarray(quat_to_dcm(quats))
    np.testing.assert_allclose(np.einsum("nij,nj->ni", c, vecs), np.asarray(quat_rotate(quats, vecs)), atol=1e-13)


def test_multiply_composes_like_scipy(quats):
    p, q = quats, np.roll(quats, 1, axis=0)
    pq = np.asarray(quat_multiply(p, q))
    expected = (_rot(p) * _rot(q)).as_quat(scalar_first=True)
    # Same rotation; the sign of a product of unit quaternions is determined, but compare up to ±.
    sign = np.sign(np.sum(pq * expected, axis=-1, keepdims=True))
    np.testing.assert_allclose(pq, sign * expected, atol=1e-14)
    # And the composition acts as "apply q first, then p".
    np.testing.assert_allclose(np.asarray(quat_to_dcm(pq)), _rot(p).as_matrix() @ _rot(q).as_matrix(), atol=1e-13)


def test_multiply_sign_is_exact_hamilton(quats):
    # SciPy's composition returns the Hamilton product itself (no sign canonicalisation unless asked),
    # but do not rely on that: check the scalar part from the textbook formula p0 q0 - p.q.
    p, q = quats, np.roll(quats, 1, axis=0)
    pq = np.asarray(quat_multiply(p, q))
    np.testing.assert_allclose(pq[:, 0], p[:, 0] * q[:, 0] - np.sum(p[:, 1:] * q[:, 1:], axis=-1), atol=1e-15)
    vec = p[:, :1] * q[:, 1:] + q[:, :1] * p[:, 1:] + np.cross(p[:, 1:], q[:, 1:])
    np.testing.assert_allclose(pq[:, 1:], vec, atol=1e-15)


def test_dcm_to_quat_round_trip(quats):
    q_back = np.asarray(dcm_to_quat(quat_to_dcm(quats)))
    sign = np.sign(np.sum(q_back * quats, axis=-1, keepdims=True))
    np.testing.assert_allclose(q_back, sign * quats, atol=1e-13)
    assert np.all(q_back[:, 0] >= 0.0)


def test_dcm_to_quat_of_scipy_matrix(quats):
    q_back = np.asarray(dcm_to_quat(_rot(quats).as_matrix()))
    sign = np.sign(np.sum(q_back * quats, axis=-1, keepdims=True))
    np.testing.assert_allclose(q_back, sign * quats, atol=1e-13)


@pytest.mark.parametrize(
    "rotvec",
    [
        [np.pi, 0.0, 0.0],  # 180° cases exercise every Shepperd branch
        [0.0, np.pi, 0.0],
        [0.0, 0.0, np.pi],
        [np.pi / np.sqrt(2), np.pi / np.sqrt(2), 0.0],
        [0.0, 0.0, 0.0],
        [1e-9, -2e-9, 3e-9],
        [3.1, 0.0, 0.1],
    ],
)
def test_dcm_to_quat_hard_cases(rotvec):
    r = Rotation.from_rotvec(rotvec)
    q_ref = r.as_quat(scalar_first=True)
    q = np.asarray(dcm_to_quat(r.as_matrix()))
    sign = np.sign(np.dot(q, q_ref)) or 1.0
    np.testing.assert_allclose(q, sign * q_ref, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(q), 1.0, atol=1e-15)


def test_angle_matches_scipy_magnitude(quats):
    np.testing.assert_allclose(np.asarray(quat_angle(quats)), _rot(quats).magnitude(), atol=1e-13)


# --------------------------------------------------------------------------------------------
# The 2010 consensus paper's matrices.
# --------------------------------------------------------------------------------------------


def _omega_matrix(w):
    wx, wy, wz = w
    return np.array(
        [
            [0.0, -wx, -wy, -wz],
            [wx, 0.0, wz, -wy],
            [wy, -wz, 0.0, wx],
            [wz, wy, -wx, 0.0],
        ]
    )


def _product_matrix(q):
    q0, q1, q2, q3 = q
    return np.array(
        [
            [q0, -q1, -q2, -q3],
            [q1, q0, -q3, q2],
            [q2, q3, q0, -q1],
            [q3, -q2, q1, q0],
        ]
    )


def test_kinematics_is_paper_eq1(quats, vecs):
    qdot = np.asarray(quat_kinematics(quats, vecs))
    expected = np.stack([0.5 * _omega_matrix(w) @ q for q, w in zip(quats, vecs)])
    np.testing.assert_allclose(qdot, expected, atol=1e-15)


def test_kinematics_is_half_q_times_pure_omega(quats, vecs):
    pure = np.concatenate([np.zeros((len(vecs), 1)), vecs], axis=-1)
    np.testing.assert_allclose(
        np.asarray(quat_kinematics(quats, vecs)), 0.5 * np.asarray(quat_multiply(quats, pure)), atol=1e-15
    )


def test_paper_product_matrix(quats):
    r = np.roll(quats, 3, axis=0)
    expected = np.stack([_product_matrix(q) @ rr for q, rr in zip(quats, r)])
    np.testing.assert_allclose(np.asarray(quat_multiply(quats, r)), expected, atol=1e-15)


def test_kinematics_body_rate_convention():
    # q̇ = ½ q ⊗ [0, ω_b] means ω is in BODY components, which for C = C_bi(q) is Ċ = C [ω_b]×
    # (an inertial-frame rate would give Ċ = [ω_i]× C instead; the two differ for q ≠ 1).
    q = Q_Z90
    w = np.array([0.0, 0.3, 0.0])
    qdot = np.asarray(quat_kinematics(q, w))
    h = 1e-6
    c_dot = (np.asarray(quat_to_dcm(q + h * qdot)) - np.asarray(quat_to_dcm(q - h * qdot))) / (2 * h)
    c = np.asarray(quat_to_dcm(q))
    wx = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    np.testing.assert_allclose(c_dot, c @ wx, atol=1e-9)
