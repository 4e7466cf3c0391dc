"""Deep-space formation design (SPEC §4): model, observability decomposition, LMI and Riccati gains.

The references are independent of the module: Kalman ranks and projectors from their
definitions, scipy's Riccati and Lyapunov solvers, matrix exponentials. The LMI tests run on
the paper's numbers (four 700 kg spacecraft in the plane, Bryson weights 10 m, 0.05 m/s,
0.1 N), not on toy problems: conditioning is part of what is tested.
"""

import functools
import re

import numpy as np
import pytest
from scipy.linalg import expm, solve_continuous_are, solve_continuous_lyapunov

from coopsat.design.formation_model import (
    COORDINATES,
    common_mode_projector,
    formation_model,
    observability_decomposition,
    output_map,
    pair_list,
    reference_map,
    reference_state,
    relative_basis,
)
from coopsat.design.formation_synthesis import centroid_gain, lmi_observer_gain, lmi_state_feedback
from coopsat.design.lti import (
    FormationDesignError,
    bryson_weights,
    check_pair,
    kalman_controllability,
    kalman_observability,
    nonzero_setpoint_feedforward,
)
from coopsat.design.riccati import discretize, lqr

N, DIMS, MASS_KG = 4, 2, 700.0
X_POS_M, X_VEL_M_S, U_MAX_N = 10.0, 0.05, 0.1
SQUARE_M = np.array([[-100.0, -100.0], [100.0, -100.0], [100.0, 100.0], [-100.0, 100.0]])
LINE_M = np.array([[0.0, -300.0], [0.0, -100.0], [0.0, 100.0], [0.0, 300.0]])


def rel_err(x, ref):
    return np.linalg.norm(x - ref) / np.linalg.norm(ref)


def ones_d(n, d):
    """(1 ⊗ I_d): the common-mode direction of a stacked per-spacecraft vector."""
    return np.kron(np.ones((n, 1)), np.eye(d))


@functools.cache
def decomposition(coordinates, n=N, d=DIMS):
    return observability_decomposition(formation_model(n, d, MASS_KG), coordinates)


def deep_space_weights(decomp):
    half = decomp.a_o.shape[0] // 2
    x_max = np.r_[np.full(half, X_POS_M), np.full(half, X_VEL_M_S)]
    return bryson_weights(x_max, U_MAX_N, n_u=decomp.b_o.shape[1])


@functools.cache
def riccati(coordinates):
    decomp = decomposition(coordinates)
    q, r = deep_space_weights(decomp)
    res = lqr(decomp.a_o, decomp.b_o, q, r)
    k, x = res.K, res.P
    return q, r, k, x


@functools.cache
def lmi_design(coordinates, objective):
    decomp = decomposition(coordinates)
    q, r, _, _ = riccati(coordinates)
    return lmi_state_feedback(decomp.a_o, decomp.b_o, q, r, objective=objective)


def physical_law(decomp, gain):
    """Force law on the absolute state, u = gain · x_o(x)."""
    return gain @ decomp.t[2 * decomp.dims :]


# --- relative basis -----------------------------------------------------------------------------


def test_hub_basis_rows_are_positions_relative_to_the_hub():
    basis = relative_basis(5, "hub", hub=2)
    expected = np.array(
        [[1, 0, -1, 0, 0], [0, 1, -1, 0, 0], [0, 0, -1, 1, 0], [0, 0, -1, 0, 1]], dtype=float
    )
    np.testing.assert_array_equal(basis, expected)


@pytest.mark.parametrize("n", [2, 3, 4, 7])
def test_orthonormal_basis_is_orthonormal_and_translation_free(n):
    basis = relative_basis(n, "orthonormal")
    assert basis.shape == (n - 1, n)
    np.testing.assert_allclose(basis @ basis.T, np.eye(n - 1), atol=1e-14)
    np.testing.assert_allclose(basis @ np.ones(n), 0.0, atol=1e-14)
    np.testing.assert_array_equal(basis, relative_basis(n, "orthonormal"))


@pytest.mark.parametrize("coordinates", COORDINATES)
def test_basis_rows_are_orthogonal_to_ones_and_independent(coordinates):
    basis = relative_basis(6, coordinates)
    np.testing.assert_allclose(basis.sum(axis=1), 0.0, atol=1e-14)
    assert np.linalg.matrix_rank(basis) == 5


@pytest.mark.parametrize(
    ("n", "coordinates", "hub"),
    [(1, "hub", 0), (2.5, "hub", 0), (True, "hub", 0), (4, "hub", 4), (4, "hub", -1), (4, "polar", 0)],
)
def test_bad_basis_arguments_are_rejected(n, coordinates, hub):
    with pytest.raises(ValueError):
        relative_basis(n, coordinates, hub)


# --- model and decomposition --------------------------------------------------------------------


def test_model_outputs_are_pair_differences_and_forces_accelerate():
    rng = np.random.default_rng(1)
    model = formation_model(N, 3, MASS_KG)
    p, v, u = rng.normal(size=(N, 3)), rng.normal(size=(N, 3)), rng.normal(size=(N, 3))
    x = np.concatenate([p.ravel(), v.ravel()])
    rho = model.c @ x
    expected = np.concatenate([p[j] - p[i] for i, j in pair_list(N)])
    np.testing.assert_allclose(rho, expected, atol=1e-14)
    np.testing.assert_allclose(model.a @ x + model.b @ u.ravel(), np.concatenate([v.ravel(), u.ravel() / MASS_KG]))


@pytest.mark.parametrize(("dims", "mass"), [(0, 700.0), (4, 700.0), (2, -1.0), (2, float("nan"))])
def test_bad_model_arguments_are_rejected(dims, mass):
    with pytest.raises(ValueError):
        formation_model(N, dims, mass)


@pytest.mark.parametrize("coordinates", COORDINATES)
@pytest.mark.parametrize(("n", "d"), [(3, 2), (4, 2), (4, 3)])
def test_decomposition_matches_the_kalman_decomposition(coordinates, n, d):
    model = formation_model(n, d, MASS_KG)
    decomp = observability_decomposition(model, coordinates)
    k = 2 * d
    rank, unobservable = kalman_observability(model.a, model.c)
    assert rank == 2 * (n - 1) * d
    # The unobservable subspace is the centroid's: 1 ⊗ I_d in positions and in velocities.
    centroid = np.kron(np.eye(2), ones_d(n, d))
    np.testing.assert_allclose(unobservable @ unobservable.T, centroid @ np.linalg.pinv(centroid), atol=1e-10)
    np.testing.assert_allclose(decomp.t @ decomp.t_inv, np.eye(2 * n * d), atol=1e-13)
    a_bar = decomp.t @ model.a @ decomp.t_inv
    np.testing.assert_allclose(a_bar[k:, :k], 0.0, atol=1e-14)
    np.testing.assert_allclose((model.c @ decomp.t_inv)[:, :k], 0.0, atol=1e-14)
    np.testing.assert_allclose(decomp.a_uo, np.block([[np.zeros((d, d)), np.eye(d)], [np.zeros((d, 2 * d))]]))
    np.testing.assert_allclose(decomp.a_uo_o, 0.0, atol=1e-15)
    x = np.random.default_rng(n * d).normal(size=2 * n * d)
    x_o = (decomp.t @ x)[k:]
    np.testing.assert_allclose(decomp.c_o @ x_o, model.c @ x, atol=1e-12)
    np.testing.assert_allclose(decomp.a_o @ x_o, (decomp.t @ model.a @ x)[k:], atol=1e-12)
    assert kalman_observability(decomp.a_o, decomp.c_o)[0] == 2 * (n - 1) * d
    assert kalman_controllability(decomp.a_o, decomp.b_o)[0] == 2 * (n - 1) * d
    assert (decomp.n, decomp.dims, decomp.coordinates) == (n, d, coordinates)


def test_common_mode_force_moves_only_the_centroid():
    decomp = decomposition("hub")
    f = np.array([0.03, -0.02])
    np.testing.assert_allclose(decomp.b_o @ ones_d(N, DIMS) @ f, 0.0, atol=1e-18)
    np.testing.assert_allclose(decomp.b_uo @ ones_d(N, DIMS) @ f, np.r_[0.0, 0.0, f / MASS_KG], atol=1e-18)


def test_kalman_ranks_survive_extreme_units():
    model = formation_model(4, 3, 1e6)  # B = 10⁻⁶
    assert kalman_controllability(model.a, model.b)[0] == 24
    assert kalman_observability(model.a, 1e-9 * model.c)[0] == 18


@pytest.mark.parametrize("coordinates", COORDINATES)
def test_output_and_reference_maps(coordinates):
    decomp = decomposition(coordinates)
    model = formation_model(N, DIMS, MASS_KG)
    x = np.concatenate([SQUARE_M.ravel(), np.zeros(N * DIMS)])
    rho = model.c @ x
    rel = np.kron(decomp.basis, np.eye(DIMS)) @ SQUARE_M.ravel()
    np.testing.assert_allclose(output_map(decomp) @ rho, rel, atol=1e-11)
    target = reference_state(decomp, SQUARE_M)
    np.testing.assert_allclose(target, np.r_[rel, np.zeros_like(rel)], atol=1e-11)
    np.testing.assert_allclose(reference_state(decomp, SQUARE_M + [5.0, -7.0]), target, atol=1e-11)
    np.testing.assert_allclose(reference_map(decomp) @ rho, target, atol=1e-11)
    # Redundant pairs: noise on the measurements is averaged (least squares), not passed on.
    noise = np.random.default_rng(3).normal(scale=0.01, size=rho.shape)
    estimate = output_map(decomp) @ (rho + noise)
    c_pos = decomp.c_o[:, : rel.size]
    best = np.linalg.lstsq(c_pos, rho + noise, rcond=None)[0]
    np.testing.assert_allclose(estimate, best, atol=1e-12)
    with pytest.raises(ValueError):
        reference_state(decomp, SQUARE_M[:3])


# --- stabilisability checks ---------------------------------------------------------------------


def test_missing_thrusters_are_reported_as_not_controllable():
    model = formation_model(N, DIMS, MASS_KG)
    b = model.b.copy()
    b[:, 2:4] = 0.0  # spacecraft 2 has no thrust
    with pytest.raises(FormationDesignError, match=r"^state feedback: \(A, B\) is not controllable \(rank 12 of 16\)"):
        check_pair(model.a, b, what="state feedback")
    decomp = decomposition("hub")
    b_o = decomp.b_o.copy()
    b_o[:, [0, 2]] = 0.0  # spacecraft 0 and 1 cannot push along x
    with pytest.raises(FormationDesignError) as info:
        lmi_state_feedback(decomp.a_o, b_o, *riccati("hub")[:2], names=("A_o", "B_o"))
    message = str(info.value)
    assert "(A_o, B_o) is not controllable (rank 10 of 12)" in message
    assert message.startswith("state feedback (eq. 11): ") and "\n" not in message


def test_lost_measurements_are_reported_as_not_observable():
    decomp = decomposition("hub")
    c_o = decomp.c_o.copy()
    for row, (i, j) in enumerate(pair_list(N)):
        if 3 in (i, j):  # nothing measures spacecraft 3
            c_o[DIMS * row : DIMS * (row + 1)] = 0.0
    with pytest.raises(FormationDesignError) as info:
        lmi_observer_gain(decomp.a_o, c_o, np.eye(12), np.eye(12), names=("A_o", "C_o"))
    message = str(info.value)
    assert "observer (dual of eq. 11): (A_o, C_o) is not observable (rank 8 of 12)" in message
    assert "\n" not in message


def test_centroid_is_the_undetectable_part_and_stable_modes_pass():
    model = formation_model(N, DIMS, MASS_KG)
    expected = r"not observable \(rank 12 of 16\) and not detectable: unobservable modes at 0, 0, 0, 0"
    with pytest.raises(FormationDesignError, match=expected):
        check_pair(model.a, model.b, model.c)
    decomp = decomposition("orthonormal")
    assert check_pair(decomp.a_o, decomp.b_o, decomp.c_o) is None
    assert check_pair(np.diag([-1.0, 0.0]), np.array([[0.0], [1.0]])) is None  # stabilisable


def test_weights_that_miss_a_mode_are_rejected():
    decomp = decomposition("hub")
    q, r, _, _ = riccati("hub")
    blind = q.copy()
    blind[:6, :6] = 0.0  # velocities only: the positions are not seen by the cost
    with pytest.raises(FormationDesignError, match=r"\(A, Q_o\) is not observable"):
        lmi_state_feedback(decomp.a_o, decomp.b_o, blind, r)
    with pytest.raises(ValueError, match="positive definite"):
        lmi_state_feedback(decomp.a_o, decomp.b_o, q, 0.0 * r)
    with pytest.raises(ValueError, match="objective"):
        lmi_state_feedback(decomp.a_o, decomp.b_o, q, r, objective="h2")
    with pytest.raises(ValueError, match="gamma_max"):
        lmi_state_feedback(decomp.a_o, decomp.b_o, q, r, objective="trace", gamma_max=1.0)


# --- LMI state feedback on the deep-space numbers -----------------------------------------------


@pytest.mark.parametrize("coordinates", COORDINATES)
def test_trace_objective_returns_the_riccati_gain(coordinates):
    decomp = decomposition(coordinates)
    _, _, k, x = riccati(coordinates)
    design = lmi_design(coordinates, "trace")
    assert design.result.certified
    assert rel_err(design.gain, -k) < 1e-5
    assert rel_err(np.linalg.inv(design.p), x) < 1e-5
    assert rel_err(design.y @ np.linalg.inv(design.p), design.gain) < 1e-8  # K = Y P⁻¹ (eq. 7)
    eigs = np.linalg.eigvals(decomp.a_o + decomp.b_o @ design.gain)
    assert eigs.real.max() < 0.0
    np.testing.assert_allclose(np.sort_complex(design.closed_loop_eigs), np.sort_complex(eigs), rtol=1e-6)
    assert np.isnan(design.gamma)


@pytest.mark.parametrize("coordinates", COORDINATES)
def test_min_gamma_is_the_riccati_bound_and_the_gain_meets_it(coordinates):
    decomp = decomposition(coordinates)
    q, r, _, x = riccati(coordinates)
    design = lmi_design(coordinates, "gamma")
    bound = np.linalg.eigvalsh(x).max()  # X₀ = I
    assert design.result.certified
    assert abs(design.gamma**2 / bound - 1.0) < 1e-5
    a_cl = decomp.a_o + decomp.b_o @ design.gain
    assert np.linalg.eigvals(a_cl).real.max() < 0.0
    # The true cost matrix of the gain found: above the Riccati solution (the LMI cannot beat
    # LQR), and within the certified bound over the ellipsoid.
    x_k = solve_continuous_lyapunov(a_cl.T, -(q + design.gain.T @ r @ design.gain))
    assert np.linalg.eigvalsh(x_k - x).min() > -1e-6 * bound
    assert np.linalg.eigvalsh(x_k).max() <= design.gamma**2 * (1.0 + 1e-5)


def test_min_gamma_with_a_shaped_ellipsoid():
    decomp = decomposition("hub")
    q, r, _, x = riccati("hub")
    x0_shape, _ = bryson_weights(np.r_[np.full(6, 20.0), np.full(6, 0.1)], 1.0)
    design = lmi_state_feedback(decomp.a_o, decomp.b_o, q, r, x0_shape=x0_shape)
    w = np.diag(1.0 / np.sqrt(np.diag(x0_shape)))
    assert abs(design.gamma**2 / np.linalg.eigvalsh(w @ x @ w).max() - 1.0) < 1e-5


def test_min_gamma_does_not_determine_the_gain():
    """Hub coordinates split into modal double integrators (D Dᵀ = I + 1 1ᵀ): the best-actuated
    mode, along 1, does not set γ. Weighting it more gives another gain with the same γ."""
    decomp = decomposition("hub")
    q, r, k, x = riccati("hub")
    gamma_sq = lmi_design("hub", "gamma").gamma ** 2
    q_alt = q.copy()
    q_alt[:6, :6] += 9.0 * q[0, 0] * np.kron(np.full((3, 3), 1.0 / 3.0), np.eye(DIMS))
    k_alt = lqr(decomp.a_o, decomp.b_o, q_alt, r).K
    a_cl = decomp.a_o - decomp.b_o @ k_alt
    x_alt = solve_continuous_lyapunov(a_cl.T, -(q + k_alt.T @ r @ k_alt))  # cost under the original q
    assert rel_err(k_alt, k) > 0.05
    assert abs(np.linalg.eigvalsh(x_alt).max() / gamma_sq - 1.0) < 1e-5
    assert np.linalg.eigvalsh(x_alt - x).min() > -1e-6 * gamma_sq


def test_gamma_max_below_the_optimum_names_the_best_gamma():
    decomp = decomposition("hub")
    q, r, _, x = riccati("hub")
    with pytest.raises(FormationDesignError) as info:
        lmi_state_feedback(decomp.a_o, decomp.b_o, q, r, gamma_max=100.0)
    message = str(info.value)
    pattern = r"state feedback \(eq\. 11\): the minimum γ = (\S+) exceeds gamma_max = 100 \(status optimal\)"
    found = re.fullmatch(pattern, message)
    assert found is not None, message
    assert float(found.group(1)) == pytest.approx(np.sqrt(np.linalg.eigvalsh(x).max()), rel=1e-5)  # 544.965


# --- coordinates --------------------------------------------------------------------------------


def test_riccati_force_law_is_coordinate_free_when_the_cost_is():
    hub, orth = decomposition("hub"), decomposition("orthonormal")
    q_h, r, k_h, _ = riccati("hub")
    gamma = np.kron(orth.basis @ np.linalg.pinv(hub.basis), np.eye(DIMS))
    g = np.kron(np.eye(2), gamma)  # x_o(orthonormal) = G x_o(hub)
    np.testing.assert_allclose(orth.a_o, g @ hub.a_o @ np.linalg.inv(g), atol=1e-14)
    np.testing.assert_allclose(orth.b_o, g @ hub.b_o, atol=1e-16)
    g_inv = np.linalg.inv(g)
    k_o = lqr(orth.a_o, orth.b_o, g_inv.T @ q_h @ g_inv, r).K
    assert rel_err(physical_law(orth, k_o), physical_law(hub, k_h)) < 1e-8


def test_same_numeric_weights_are_different_costs_in_hub_and_orthonormal():
    hub, orth = decomposition("hub"), decomposition("orthonormal")
    lqr_diff = rel_err(physical_law(orth, riccati("orthonormal")[2]), physical_law(hub, riccati("hub")[2]))
    assert lqr_diff == pytest.approx(0.267, abs=0.005)  # deterministic: scipy's Riccati solver
    gamma_diff = rel_err(
        physical_law(orth, lmi_design("orthonormal", "gamma").gain), physical_law(hub, lmi_design("hub", "gamma").gain)
    )
    assert gamma_diff > 0.05  # 0.50 with CLARABEL 0.11.1; which point of the face depends on the solver


@pytest.mark.parametrize("coordinates", COORDINATES)
def test_scalar_input_weight_gives_no_common_mode_force(coordinates):
    decomp = decomposition(coordinates)
    q, _, _, _ = riccati(coordinates)
    k = lqr(decomp.a_o, decomp.b_o, q, 37.0 * np.eye(N * DIMS)).K
    np.testing.assert_allclose(ones_d(N, DIMS).T @ k, 0.0, atol=1e-12 * np.abs(k).max())
    gain = lmi_design(coordinates, "trace").gain
    assert np.abs(ones_d(N, DIMS).T @ gain).max() < 1e-6 * np.abs(gain).max()


# --- non-zero set point (eq. 17) ----------------------------------------------------------------


def test_nonzero_setpoint_law_settles_on_the_commanded_pairs():
    model = formation_model(N, DIMS, MASS_KG)
    q, r = bryson_weights(np.r_[np.full(8, X_POS_M), np.full(8, X_VEL_M_S)], U_MAX_N, n_u=8)
    k = lqr(model.a, model.b, q, r).K
    n_ff = nonzero_setpoint_feedforward(model.a, model.b, model.c, k)
    y_d = model.c @ np.r_[LINE_M.ravel(), np.zeros(8)]
    dc = model.c @ np.linalg.solve(model.b @ k - model.a, model.b)
    np.testing.assert_allclose(dc @ n_ff @ y_d, y_d, atol=1e-9 * np.abs(y_d).max())
    # Closed loop from the square, exactly: the augmented state [x; 1] under expm.
    aug = np.zeros((17, 17))
    aug[:16, :16] = model.a - model.b @ k
    aug[:16, 16] = model.b @ n_ff @ y_d
    slowest = -np.linalg.eigvals(model.a - model.b @ k).real.max()
    x_end = expm(aug * 30.0 / slowest) @ np.r_[SQUARE_M.ravel(), np.zeros(8), 1.0]
    np.testing.assert_allclose(model.c @ x_end[:16], y_d, atol=1e-6 * np.abs(y_d).max())


@pytest.mark.parametrize("coordinates", COORDINATES)
def test_setpoint_feedforward_in_relative_coordinates(coordinates):
    decomp = decomposition(coordinates)
    _, _, k, _ = riccati(coordinates)
    n_ff = nonzero_setpoint_feedforward(decomp.a_o, decomp.b_o, decomp.c_o, k)
    y_d = formation_model(N, DIMS, MASS_KG).c @ np.r_[LINE_M.ravel(), np.zeros(8)]
    np.testing.assert_allclose(ones_d(N, DIMS).T @ n_ff, 0.0, atol=1e-12 * np.abs(n_ff).max())
    x_ss = np.linalg.solve(decomp.b_o @ k - decomp.a_o, decomp.b_o @ n_ff @ y_d)
    np.testing.assert_allclose(x_ss, reference_state(decomp, LINE_M), atol=1e-8 * np.abs(y_d).max())


# --- observer -----------------------------------------------------------------------------------

#: Process intensities (m², m²/s²) and measurement variance (1 cm)², per relative state / pair.
W_PROCESS = np.diag(np.r_[np.full(6, 1e-4), np.full(6, 1e-8)])
V_MEASUREMENT = 1e-4 * np.eye(12)


@pytest.mark.parametrize("coordinates", COORDINATES)
def test_observer_trace_gain_is_the_kalman_gain(coordinates):
    decomp = decomposition(coordinates)
    sigma = solve_continuous_are(decomp.a_o.T, decomp.c_o.T, W_PROCESS, V_MEASUREMENT)
    kalman = -sigma @ decomp.c_o.T @ np.linalg.inv(V_MEASUREMENT)  # A + L C sign
    design = lmi_observer_gain(decomp.a_o, decomp.c_o, W_PROCESS, V_MEASUREMENT, objective="trace")
    assert design.gain.shape == (12, 12)
    assert rel_err(design.gain, kalman) < 1e-4


def test_observer_error_decays():
    decomp = decomposition("hub")
    design = lmi_observer_gain(decomp.a_o, decomp.c_o, W_PROCESS, V_MEASUREMENT)
    a_err = decomp.a_o + design.gain @ decomp.c_o
    eigs = np.linalg.eigvals(a_err)
    assert eigs.real.max() < 0.0
    np.testing.assert_allclose(np.sort_complex(design.closed_loop_eigs), np.sort_complex(eigs), rtol=1e-8)
    sigma = solve_continuous_are(decomp.a_o.T, decomp.c_o.T, W_PROCESS, V_MEASUREMENT)
    assert abs(design.gamma**2 / np.linalg.eigvalsh(sigma).max() - 1.0) < 1e-5
    e0 = np.r_[np.full(6, 5.0), np.full(6, 0.01)]
    t_end = 20.0 / -eigs.real.max()
    assert np.linalg.norm(expm(a_err * t_end) @ e0) < 1e-6 * np.linalg.norm(e0)


# --- centroid holding (eq. 15) ------------------------------------------------------------------


def test_common_mode_projector():
    proj = common_mode_projector(N, 3)
    ones = ones_d(N, 3)
    np.testing.assert_allclose(proj @ proj, proj, atol=1e-15)
    np.testing.assert_allclose(proj, proj.T)
    np.testing.assert_allclose(proj @ ones, 0.0, atol=1e-15)
    u = np.random.default_rng(5).normal(size=N * 3)
    np.testing.assert_allclose(ones.T @ proj @ u, 0.0, atol=1e-14)
    np.testing.assert_allclose(proj @ u - u, -ones @ (ones.T @ u) / N, atol=1e-14)


def test_centroid_gain_and_the_assembled_loop():
    decomp = decomposition("hub")
    ones = ones_d(N, DIMS)
    q_c, r_c = bryson_weights([X_POS_M, X_POS_M, X_VEL_M_S, X_VEL_M_S], [0.4, 0.4])
    design = centroid_gain(decomp, q_c, r_c, objective="trace")
    k_c = lqr(decomp.a_uo, decomp.b_uo @ ones, q_c, r_c).K
    assert design.gain.shape == (DIMS, 2 * DIMS)
    assert rel_err(design.gain, -k_c) < 1e-5
    # u = (1 ⊗ I) K_c x_ō + Π K_o x_o on the absolute model: both loops close, and decouple.
    k_o = lmi_design("hub", "trace").gain
    model = formation_model(N, DIMS, MASS_KG)
    k = 2 * DIMS
    law = ones @ design.gain @ decomp.t[:k] + common_mode_projector(N, DIMS) @ k_o @ decomp.t[k:]
    eigs = np.linalg.eigvals(model.a + model.b @ law)
    expected = np.r_[design.closed_loop_eigs, np.linalg.eigvals(decomp.a_o + decomp.b_o @ k_o)]
    np.testing.assert_allclose(np.sort_complex(eigs), np.sort_complex(expected), rtol=1e-6, atol=1e-9)
    assert eigs.real.max() < 0.0


# --- small utilities ----------------------------------------------------------------------------


def test_discretize_double_integrator_and_stable_system():
    t = 2.5
    phi, gam = discretize([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0 / MASS_KG]], t)
    np.testing.assert_allclose(phi, [[1.0, t], [0.0, 1.0]], atol=1e-14)
    np.testing.assert_allclose(gam, [[t**2 / (2 * MASS_KG)], [t / MASS_KG]], rtol=1e-12)
    a = np.array([[-1.0, 2.0], [0.0, -3.0]])
    b = np.array([[1.0], [2.0]])
    phi, gam = discretize(a, b, 0.4)
    np.testing.assert_allclose(phi, expm(0.4 * a), rtol=1e-12)
    np.testing.assert_allclose(gam, np.linalg.solve(a, (expm(0.4 * a) - np.eye(2)) @ b), rtol=1e-12)
    with pytest.raises(ValueError):
        discretize(a, b, 0.0)


def test_bryson_weights():
    q, r = bryson_weights([10.0, 0.05], 0.1)
    np.testing.assert_allclose(q, np.diag([0.01, 400.0]))
    np.testing.assert_allclose(r, [[100.0]])
    q, r = bryson_weights(2.0, [0.1, 0.2], n_x=3)
    np.testing.assert_allclose(q, 0.25 * np.eye(3))
    np.testing.assert_allclose(r, np.diag([100.0, 25.0]))
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError):
            bryson_weights(bad, 1.0)
