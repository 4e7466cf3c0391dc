"""Euler's equation with wheel momentum: I ω̇ = τ − ω × (I ω + h)."""

import numpy as np
import pytest

from coopsat.dynamics.rigid_body import matvec3, omega_dot_b, rotational_energy_j

# A symmetric positive-definite, genuinely non-diagonal inertia (kg·m²).
I_FULL = np.array(
    [
        [12.0, -1.5, 0.8],
        [-1.5, 9.0, 0.6],
        [0.8, 0.6, 7.0],
    ]
)
OMEGA = np.array([0.12, -0.31, 0.07])
TORQUE = np.array([0.02, 0.01, -0.03])
H_WHEELS = np.array([0.4, -0.25, 0.9])


def test_inertia_fixture_is_spd_and_non_diagonal():
    np.testing.assert_array_equal(I_FULL, I_FULL.T)
    assert np.all(np.linalg.eigvalsh(I_FULL) > 0)
    assert np.count_nonzero(I_FULL - np.diag(np.diag(I_FULL))) == 6


def test_full_inertia_with_wheels_hand_computation():
    # Written out component by component, not with np.cross, so that a sign or order slip in
    # either side shows.
    iw = I_FULL @ OMEGA
    h = iw + H_WHEELS
    wx, wy, wz = OMEGA
    w_cross_h = np.array([wy * h[2] - wz * h[1], wz * h[0] - wx * h[2], wx * h[1] - wy * h[0]])
    expected = np.linalg.solve(I_FULL, TORQUE - w_cross_h)
    got = np.asarray(omega_dot_b(OMEGA, TORQUE, I_FULL, np.linalg.inv(I_FULL), H_WHEELS))
    np.testing.assert_allclose(got, expected, rtol=1e-13, atol=1e-16)
    # And it satisfies Euler's equation as written, with the inertia in front of ω̇.
    np.testing.assert_allclose(I_FULL @ got + np.cross(OMEGA, iw + H_WHEELS), TORQUE, atol=1e-15)


def test_wheel_momentum_enters_as_gyroscopic_term():
    # Zero ω: no gyroscopic term whatever h is.
    i_inv = np.linalg.inv(I_FULL)
    got = np.asarray(omega_dot_b(np.zeros(3), TORQUE, I_FULL, i_inv, H_WHEELS))
    np.testing.assert_allclose(got, i_inv @ TORQUE, rtol=1e-14)
    # Only the wheel part changes when h changes: Δω̇ = −I⁻¹ (ω × Δh).
    a = np.asarray(omega_dot_b(OMEGA, TORQUE, I_FULL, i_inv, H_WHEELS))
    b = np.asarray(omega_dot_b(OMEGA, TORQUE, I_FULL, i_inv, np.zeros(3)))
    np.testing.assert_allclose(a - b, -i_inv @ np.cross(OMEGA, H_WHEELS), rtol=1e-12, atol=1e-16)


def test_diagonal_path_equals_full_matrix_path():
    moments = np.array([10.0, 7.0, 4.0])
    full = np.asarray(omega_dot_b(OMEGA, TORQUE, np.diag(moments), np.diag(1.0 / moments), H_WHEELS))
    diag = np.asarray(omega_dot_b(OMEGA, TORQUE, moments, 1.0 / moments, H_WHEELS))
    np.testing.assert_allclose(diag, full, rtol=1e-14, atol=1e-17)
    # And the textbook principal-axis form, e.g. I1 ω̇1 = τ1 − (I3 − I2) ω2 ω3 − (ω2 h3 − ω3 h2).
    i1, i2, i3 = moments
    w1, w2, w3 = OMEGA
    h1, h2, h3 = H_WHEELS
    expected = np.array(
        [
            (TORQUE[0] - (i3 - i2) * w2 * w3 - (w2 * h3 - w3 * h2)) / i1,
            (TORQUE[1] - (i1 - i3) * w3 * w1 - (w3 * h1 - w1 * h3)) / i2,
            (TORQUE[2] - (i2 - i1) * w1 * w2 - (w1 * h2 - w2 * h1)) / i3,
        ]
    )
    np.testing.assert_allclose(diag, expected, rtol=1e-13, atol=1e-17)


def test_diagonal_path_batched():
    rng = np.random.default_rng(1)
    n = 5
    moments = rng.uniform(2.0, 12.0, size=(n, 3))
    w, tau, h = (rng.normal(size=(n, 3)) for _ in range(3))
    full = np.stack([np.diag(m) for m in moments])
    a = np.asarray(omega_dot_b(w, tau, full, np.linalg.inv(full), h))
    b = np.asarray(omega_dot_b(w, tau, moments, 1.0 / moments, h))
    np.testing.assert_allclose(b, a, rtol=1e-13, atol=1e-15)


def _batch(n=6, seed=2):
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(n, 3, 3))
    inertia = np.einsum("nij,nkj->nik", a, a) + 3.0 * np.eye(3)  # SPD, full
    return {
        "w": rng.normal(size=(n, 3)),
        "tau": rng.normal(size=(n, 3)),
        "h": rng.normal(size=(n, 3)),
        "inertia": inertia,
        "inv": np.linalg.inv(inertia),
        "moments": rng.uniform(1.0, 5.0, size=(n, 3)),
    }


def test_batched_full_matches_per_spacecraft():
    b = _batch()
    got = np.asarray(omega_dot_b(b["w"], b["tau"], b["inertia"], b["inv"], b["h"]))
    for k in range(len(got)):
        i = b["inertia"][k]
        expected = np.linalg.solve(i, b["tau"][k] - np.cross(b["w"][k], i @ b["w"][k] + b["h"][k]))
        np.testing.assert_allclose(got[k], expected, rtol=1e-11, atol=1e-13)


@pytest.mark.parametrize("path", ["full", "diagonal"])
def test_axis0_equals_transposed_axis_last(path):
    b = _batch()
    if path == "full":
        i_last, inv_last = b["inertia"], b["inv"]
        # Component-major layout for matrices is (3, 3, n) (what the engine builds with moveaxis).
        i_first, inv_first = np.moveaxis(i_last, 0, -1), np.moveaxis(inv_last, 0, -1)
    else:
        i_last, inv_last = b["moments"], 1.0 / b["moments"]
        i_first, inv_first = i_last.T, inv_last.T
    last = np.asarray(omega_dot_b(b["w"], b["tau"], i_last, inv_last, b["h"], axis=-1))
    first = np.asarray(omega_dot_b(b["w"].T, b["tau"].T, i_first, inv_first, b["h"].T, axis=0))
    assert first.shape == (3, len(last))
    np.testing.assert_allclose(first, last.T, rtol=1e-14, atol=1e-16)
    e_last = np.asarray(rotational_energy_j(b["w"], i_last, axis=-1))
    e_first = np.asarray(rotational_energy_j(b["w"].T, i_first, axis=0))
    np.testing.assert_allclose(e_first, e_last, rtol=1e-14)


@pytest.mark.parametrize("axis", [-1, 0])
def test_matvec3_is_m_at_v_not_transposed(axis):
    # Inertias are symmetric, so omega_dot_b cannot tell m @ v from mᵀ @ v; matvec3 itself
    # promises m @ v, checked here with non-symmetric matrices.
    rng = np.random.default_rng(5)
    m = rng.normal(size=(4, 3, 3))
    v = rng.normal(size=(4, 3))
    expected = np.einsum("nij,nj->ni", m, v)
    if axis == 0:
        got = np.asarray(matvec3(np.moveaxis(m, 0, -1), v.T, axis=0)).T
    else:
        got = np.asarray(matvec3(m, v, axis=-1))
    np.testing.assert_allclose(got, expected, rtol=1e-14, atol=1e-15)
    # The unbatched case.
    np.testing.assert_allclose(matvec3(m[0], v[0]), m[0] @ v[0], rtol=1e-14, atol=1e-15)


@pytest.mark.parametrize("k", [0, 1, 2])
@pytest.mark.parametrize("path", ["full", "diagonal"])
def test_torque_free_principal_axis_spin_is_equilibrium(k, path):
    moments = np.array([10.0, 7.0, 4.0])
    omega = np.zeros(3)
    omega[k] = 0.8
    if path == "full":
        # A rotated body: the principal axes are the columns of R, inertia R diag(I) Rᵀ.
        c, s = np.cos(0.4), np.sin(0.4)
        r = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ np.array(
            [[1.0, 0.0, 0.0], [0.0, np.cos(0.9), -np.sin(0.9)], [0.0, np.sin(0.9), np.cos(0.9)]]
        )
        inertia = r @ np.diag(moments) @ r.T
        inertia_inv = np.linalg.inv(inertia)
        omega = r @ omega
    else:
        inertia, inertia_inv = moments, 1.0 / moments
    got = np.asarray(omega_dot_b(omega, np.zeros(3), inertia, inertia_inv, np.zeros(3)))
    np.testing.assert_allclose(got, np.zeros(3), atol=1e-15)


def test_non_principal_spin_is_not_equilibrium():
    # Guards the test above: a spin off the principal axes of an asymmetric body does precess.
    got = np.asarray(omega_dot_b(np.array([0.5, 0.5, 0.0]), np.zeros(3), I_FULL, np.linalg.inv(I_FULL), np.zeros(3)))
    assert np.linalg.norm(got) > 1e-3


def test_torque_free_conserves_energy_and_momentum_rates():
    # With τ = 0 and h = 0: d/dt(½ ωᵀIω) = ωᵀ I ω̇ = −ω·(ω × Iω) = 0, and d/dt |Iω|² = 0.
    w = OMEGA
    wdot = np.asarray(omega_dot_b(w, np.zeros(3), I_FULL, np.linalg.inv(I_FULL), np.zeros(3)))
    assert abs(w @ I_FULL @ wdot) < 1e-16
    assert abs((I_FULL @ w) @ (I_FULL @ wdot)) < 1e-15


def test_rotational_energy():
    e = float(rotational_energy_j(OMEGA, I_FULL))
    assert e == pytest.approx(0.5 * OMEGA @ I_FULL @ OMEGA, rel=1e-14)
    moments = np.array([10.0, 7.0, 4.0])
    e_diag = float(rotational_energy_j(OMEGA, moments))
    assert e_diag == pytest.approx(0.5 * np.sum(moments * OMEGA**2), rel=1e-14)
    assert e_diag == pytest.approx(float(rotational_energy_j(OMEGA, np.diag(moments))), rel=1e-14)
    # Hand value: ½ (10·1 + 7·4 + 4·9) = 37 for ω = [1, 2, 3].
    assert float(rotational_energy_j(np.array([1.0, 2.0, 3.0]), moments)) == pytest.approx(37.0, rel=1e-15)


def test_rotational_energy_batched():
    b = _batch()
    got = np.asarray(rotational_energy_j(b["w"], b["inertia"]))
    assert got.shape == (len(b["w"]),)
    np.testing.assert_allclose(got, 0.5 * np.einsum("ni,nij,nj->n", b["w"], b["inertia"], b["w"]), rtol=1e-13)
