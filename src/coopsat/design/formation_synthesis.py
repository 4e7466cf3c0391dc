"""Gains of the deep-space formation by the LMIs of the paper: eq. (11), its dual, eq. (15) (SPEC §4).

The model and its observability decomposition are in :mod:`coopsat.design.formation_model`.
The Riccati (LQR) baseline is :func:`coopsat.design.riccati.lqr`, the package's one Riccati
solver, and the zero-order hold is :func:`coopsat.design.riccati.discretize`.

Gains (paper's sign, u = K x). Eq. (11) in standard weights q = Q_oᵀQ_o ⪰ 0, r = Q_uᵀQ_u ≻ 0
(the paper's symmetric Q_o, Q_u give q = Q_o², r = Q_u²; its −Q^{−2} blocks are the same
Schur complement):

    P ≻ 0,  [[A P + P Aᵀ + B Y + Yᵀ Bᵀ, P Q_oᵀ, Yᵀ Q_uᵀ], [Q_o P, −I, 0], [Q_u Y, 0, −I]] ⪯ 0,
    K = Y P⁻¹  (eq. 7).

With X = P⁻¹ this is (A + BK)ᵀX + X(A + BK) + q + KᵀrK ⪯ 0, so J = ∫ xᵀq x + uᵀr u dt
≤ x₀ᵀ X x₀. Objective "gamma" (eq. 11): over the ellipsoid x₀ᵀ X₀ x₀ ≤ 1 the bound is
≤ γ² iff X ⪯ γ² X₀ iff [[γ² X₀, I], [I, P]] ⪰ 0; minimise γ². Objective "trace": minimise
trace Z with [[Z, I], [I, P]] ⪰ 0 (Z ⪰ X). The observer gain L is the dual (A → Aᵀ, B → Cᵀ,
L = Kᵀ, eq. 12); the centroid-holding gain (eq. 15) is the same LMI on the centroid
subsystem driven by the common-mode force.

Finding: min γ does not determine the gain. Every feasible X lies above the stabilising
Riccati solution X_ric (the cost of any gain is at least the optimal cost), and X_ric itself
is feasible, so the optimum is γ² = λ_max(X₀^{−1/2} X_ric X₀^{−1/2}), reached by every X
that satisfies the Riccati inequality with X_ric ⪯ X ⪯ γ² X₀ — generally a whole face, of
which the solver returns one point, generally not X_ric. In hub coordinates the relative
system splits into modal double integrators (D Dᵀ = I + 1 1ᵀ has eigenvalues 1, n − 2 times,
and n); only the least actuated modes set γ, and the gain of the others is free within the
bound. On the deep-space numbers of the tests (n = 4, d = 2, 700 kg, Bryson weights 10 m,
0.05 m/s, 0.1 N, X₀ = I) γ² from the LMI equals λ_max to 5·10⁻⁸ in both coordinates, but
the gain returned differs from the Riccati gain by 26 % (relative Frobenius norm) in hub
coordinates and by 10⁻⁵ in orthonormal ones (CLARABEL 0.11.1: which point is returned
depends on the solver and its path). On the same cost and coordinates the LMI cannot beat
LQR: the quadratic cost matrix of any gain lies above X_ric. The trace objective has the
unique minimiser X = X_ric and returns the Riccati gain −R⁻¹BᵀX_ric (to 5·10⁻⁹ relative in
hub, 2·10⁻⁷ in orthonormal coordinates). The same numeric Bryson weights in hub and in
orthonormal coordinates are different physical costs: the force laws u(p, v) differ by 27 %
(LQR) and 50 % (min γ). Hence any difference between the paper's LMI design and
Riccati-LQR comes from the coordinates, the bounds, the thrust limits and the
decentralisation, not from the LMI.

Conditioning. Every LMI is solved in balanced units (:mod:`coopsat.design.balancing`: Bryson
units, Hamiltonian balancing, a time scale; a congruence, so the set of solutions is the same)
and the answer is mapped back. The ellipsoid's X₀^{−1/2} is normalised to unit norm in the
bound block. Unscaled, neither objective is certified on the deep-space numbers (the best γ
found is 15.4 against the true 545); scaled, each solve takes 0.3–0.7 s. CLARABEL tends to
stall near a 10⁻¹⁰ gap on the min-γ face and call its answer inaccurate, hence the ladder of
tolerances in :data:`FORMATION_SOLVERS`.
"""

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from coopsat.design.balancing import balanced_scales
from coopsat.design.lmi import RTOL, LMIResult, MatrixInequality, solve_lmis
from coopsat.design.lqr_lmi import LQR_SOLVERS
from coopsat.design.lti import FormationDesignError, check_pair, finite_matrix, kalman_observability
from coopsat.design.memo import by_value

#: Objectives of :func:`lmi_state_feedback`.
OBJECTIVES = ("gamma", "trace")

#: CLARABEL at the tolerances of :data:`~coopsat.design.lqr_lmi.LQR_SOLVERS`, then looser, then
#: SCS. The min-γ optimum is a whole face (module docstring) on which CLARABEL can stall at a
#: gap of about 10⁻¹⁰ and report "inaccurate"; the next rung accepts that. Every answer is
#: re-checked, whichever rung gives it.
FORMATION_SOLVERS = (
    LQR_SOLVERS[0],
    ("CLARABEL", {"tol_gap_abs": 1e-10, "tol_gap_rel": 1e-10, "tol_feas": 1e-10}),
    ("CLARABEL", {}),
    LQR_SOLVERS[1],
)


@dataclass(frozen=True)
class LMIGain:
    """A gain from the LMI of eq. (11) (or its dual).

    Attributes
    ----------
    gain : ndarray, shape (m, n)
        ``u = gain @ x`` (the paper's sign, K_o = Y P⁻¹); for the observer, L (n, p).
    p : ndarray, shape (n, n)
        P in physical units (for the observer, of the dual problem).
    y : ndarray, shape (m, n)
        Y in physical units (for the observer, of the dual problem).
    gamma : float
        Guaranteed cost bound γ (√ of the bound on J over the initial ellipsoid); NaN for the
        trace objective.
    objective : str
        "gamma" or "trace".
    result : LMIResult
        The certified solve (in balanced units).
    closed_loop_eigs : ndarray, shape (n,)
        Eigenvalues of A + B·gain (observer: A + L C), 1/s.
    """

    gain: np.ndarray
    p: np.ndarray
    y: np.ndarray
    gamma: float
    objective: str
    result: LMIResult
    closed_loop_eigs: np.ndarray


def _psd_factor(q):
    """Q with QᵀQ = q (rows: the numerically nonzero eigen-directions)."""
    lam, vec = np.linalg.eigh(0.5 * (q + q.T))
    keep = lam > 1e-12 * max(lam[-1], 0.0)
    return np.sqrt(lam[keep])[:, None] * vec[:, keep].T


def _spd(name, value, size):
    m = finite_matrix(name, value)
    if m.shape != (size, size) or not np.allclose(m, m.T, rtol=1e-10, atol=0.0):
        raise ValueError(f"{name} must be a symmetric ({size}, {size}) matrix, got shape {m.shape}")
    m = 0.5 * (m + m.T)
    if np.linalg.eigvalsh(m)[0] <= 0.0:
        raise ValueError(f"{name} must be positive definite")
    return m


def _inv_sqrt(m):
    lam, vec = np.linalg.eigh(m)
    return (vec / np.sqrt(lam)) @ vec.T


def _gamma_text(gamma):
    return "none" if gamma is None or not math.isfinite(gamma) else f"{gamma:.6g}"


def _validated_eq11(a, b, q, r, x0_shape, objective, gamma_max, what, names):
    """The inputs of :func:`_solve_eq11` checked: ``(a, b, q, r, x0)`` as arrays, or the error."""
    a, b = finite_matrix("a", a), finite_matrix("b", b)
    n, m = b.shape
    if a.shape != (n, n):
        raise ValueError(f"shapes do not match: a {a.shape}, b {b.shape}")
    q = finite_matrix("q", q)
    symmetric = q.shape == (n, n) and np.allclose(q, q.T, rtol=1e-10, atol=0.0)
    if not symmetric or np.linalg.eigvalsh(0.5 * (q + q.T))[0] < -1e-12 * np.abs(q).max():
        raise ValueError(f"q must be a symmetric positive semidefinite ({n}, {n}) matrix")
    r = _spd("r", r, m)
    x0 = np.eye(n) if x0_shape is None else _spd("x0_shape", x0_shape, n)
    if objective not in OBJECTIVES:
        raise ValueError(f"objective must be one of {OBJECTIVES}, got {objective!r}")
    if gamma_max is not None and objective != "gamma":
        raise ValueError("gamma_max applies to the 'gamma' objective only")
    check_pair(a, b, what=what, names=names)
    rank, _ = kalman_observability(a, _psd_factor(q))
    if rank < n:
        raise FormationDesignError(
            f"{what}: ({names[0]}, Q_o) is not observable (rank {rank} of {n}): the cost must see "
            "every mode for P = X⁻¹ to be finite"
        )
    return a, b, q, r, x0


def _solve_balanced_eq11(a_t, b_t, q_o, q_u, x0_t, objective):
    """Eq. (11) in balanced units, re-checked; returns the result and the norm by which the
    bound block's X̃₀^{−1/2} was divided (1 for "trace", where it has none)."""
    import cvxpy as cp

    n, m = b_t.shape
    p_var = cp.Variable((n, n), symmetric=True, name="P")
    y_var = cp.Variable((m, n), name="Y")
    k_o, k_u = q_o.shape[0], m
    main = cp.bmat(
        [
            [a_t @ p_var + p_var @ a_t.T + b_t @ y_var + y_var.T @ b_t.T, p_var @ q_o.T, y_var.T @ q_u.T],
            [q_o @ p_var, -np.eye(k_o), np.zeros((k_o, k_u))],
            [q_u @ y_var, np.zeros((k_u, k_o)), -np.eye(k_u)],
        ]
    )
    variables = {"P": p_var, "Y": y_var}
    w_scale = 1.0
    if objective == "gamma":
        g_var = cp.Variable(name="gamma_sq")
        # Congruence with diag(X̃₀^{-1/2}, I) of [[g X̃₀, I], [I, P]]: same inequality, and a
        # badly shaped ellipsoid does not unbalance the block.
        w = _inv_sqrt(x0_t)
        w_scale = np.linalg.norm(w, 2)
        w = w / w_scale
        bound = cp.bmat([[g_var * np.eye(n), w], [w, p_var]])
        variables["gamma_sq"] = g_var
        cost = cp.Minimize(g_var)
    else:
        z_var = cp.Variable((n, n), symmetric=True, name="Z")
        bound = cp.bmat([[z_var, np.eye(n)], [np.eye(n), p_var]])
        variables["Z"] = z_var
        cost = cp.Minimize(cp.trace(z_var))
    # At the optimum the main and bound blocks are singular (the Riccati equation holds with
    # equality along some direction): they are re-checked non-strictly; P ≻ 0 strictly.
    result = solve_lmis(
        [
            MatrixInequality("P ≻ 0", p_var, ">"),
            MatrixInequality("eq. 11", main, "<="),
            MatrixInequality("cost bound" if objective == "gamma" else "trace bound", bound, ">="),
        ],
        variables,
        objective=cost,
        solvers=FORMATION_SOLVERS,
        rtol=RTOL,
    )
    return result, w_scale


def _physical_gain(result, a_t, b_t, s, s_u, tau, sigma, what, names):
    """K, P, Y in physical units and the closed-loop eigenvalues (1/s) from a certified solve;
    raises unless the gain makes the balanced closed loop Hurwitz."""
    p_t, y_t = result.variables["P"], result.variables["Y"]
    p_t = 0.5 * (p_t + p_t.T)
    k_t = np.linalg.solve(p_t, y_t.T).T
    eig_t = np.linalg.eigvals(a_t + b_t @ k_t)
    if not eig_t.real.max() < -RTOL * np.abs(eig_t).max():
        raise FormationDesignError(
            f"{what}: the gain does not make {names[0]} + {names[1]}K Hurwitz "
            f"(max Re λ = {eig_t.real.max() / tau:.3g} 1/s)"
        )
    gain = s_u[:, None] * k_t / s[None, :]
    p_phys = p_t * np.outer(s, s) / sigma
    y_phys = y_t * np.outer(s_u, s) / sigma
    return gain, p_phys, y_phys, eig_t / tau


@by_value
def _solve_eq11(a, b, q, r, x0_shape, objective, gamma_max, what, names):
    """Eq. (11) for u = K x on (a, b) with weights (q, r); returns (K, P, Y, γ, result, eigs)."""
    a, b, q, r, x0 = _validated_eq11(a, b, q, r, x0_shape, objective, gamma_max, what, names)
    s, s_u, tau = balanced_scales(a, b, q, r)
    # ∫ xᵀq x + uᵀr u dt = τ ∫ x̃ᵀ(SqS)x̃ + ũᵀ(S_u r S_u)ũ dt̃: with the cost scale σ = τ the
    # balanced weights are S q S and S_u r S_u, and J = σ J̃.
    sigma = tau
    a_t = tau * a * (s[None, :] / s[:, None])
    b_t = tau * b * (s_u[None, :] / s[:, None])
    q_o = _psd_factor(q * np.outer(s, s))
    q_u = np.linalg.cholesky(r * np.outer(s_u, s_u)).T
    x0_t = x0 * np.outer(s, s)
    result, w_scale = _solve_balanced_eq11(a_t, b_t, q_o, q_u, x0_t, objective)
    gamma = math.nan
    if "gamma_sq" in result.variables:
        gamma = math.sqrt(max(float(result.variables["gamma_sq"]), 0.0) * sigma) * w_scale
    if not result.certified:
        best = gamma if objective == "gamma" and result.variables else None
        raise FormationDesignError(
            f"{what}: LMI not certified (status {result.status}, solver {result.solver}); best γ = {_gamma_text(best)}"
        )
    if gamma_max is not None and not gamma <= gamma_max:
        raise FormationDesignError(
            f"{what}: the minimum γ = {gamma:.6g} exceeds gamma_max = {gamma_max:.6g} (status {result.status})"
        )
    gain, p_phys, y_phys, eigs = _physical_gain(result, a_t, b_t, s, s_u, tau, sigma, what, names)
    return gain, p_phys, y_phys, (gamma if objective == "gamma" else math.nan), result, eigs


def lmi_state_feedback(
    a, b, q, r, x0_shape=None, objective="gamma", gamma_max=None, what="state feedback (eq. 11)", names=("A", "B")
):
    """State-feedback gain ``u = K x`` from the LMI of eq. (11).

    Parameters
    ----------
    a : array_like, shape (n, n)
    b : array_like, shape (n, m)
    q : array_like, shape (n, n)
        State weight Q_oᵀQ_o, symmetric ⪰ 0, with (a, Q_o) observable.
    r : array_like, shape (m, m)
        Input weight Q_uᵀQ_u, symmetric ≻ 0.
    x0_shape : array_like, shape (n, n), optional
        X₀ of the initial-state ellipsoid x₀ᵀ X₀ x₀ ≤ 1 (default identity). "gamma" only.
    objective : {"gamma", "trace"}
        "gamma": minimise γ², the bound on J over the ellipsoid (eq. 11). "trace": minimise
        trace Z, Z ⪰ P⁻¹, whose optimum is the Riccati solution.
    gamma_max : float, optional
        Largest acceptable γ ("gamma" only).
    what : str
        Name of the design step in error messages.
    names : (str, str)
        Symbols of a and b in error messages.

    Returns
    -------
    LMIGain

    Raises
    ------
    FormationDesignError
        (a, b) not stabilisable, (a, Q_o) not observable, the LMI not certified, γ above
        ``gamma_max``, or A + BK not Hurwitz; one line naming ``what``.

    Notes
    -----
    Eq. (11) with the objectives of the module docstring, solved in balanced units (module
    docstring, "Conditioning"). Optimal points are on the boundary: the eq. 11 and bound
    blocks are re-checked non-strictly, P ≻ 0 strictly, and the closed loop separately by its
    eigenvalues (max Re λ < −10⁻⁶ max |λ|). min γ does not determine K (module docstring);
    "trace" returns −R⁻¹BᵀX_ric, the LQR gain.
    """
    gain, p, y, gamma, result, eigs = _solve_eq11(a, b, q, r, x0_shape, objective, gamma_max, what, names)
    return LMIGain(gain=gain, p=p, y=y, gamma=gamma, objective=objective, result=result, closed_loop_eigs=eigs)


def lmi_observer_gain(a, c, q, r, x0_shape=None, objective="gamma", what="observer (dual of eq. 11)", names=("A", "C")):
    """Observer gain L with A + L C Hurwitz, by the dual of eq. (11).

    Parameters
    ----------
    a : array_like, shape (n, n)
    c : array_like, shape (p, n)
    q : array_like, shape (n, n)
        Weight of the dual state (process side), symmetric ⪰ 0.
    r : array_like, shape (p, p)
        Weight of the dual input (measurement side), symmetric ≻ 0.
    x0_shape, objective, what
        As :func:`lmi_state_feedback`.
    names : (str, str)
        Symbols of a and c in error messages.

    Returns
    -------
    LMIGain
        ``gain`` = L, shape (n, p); ``p``, ``y`` those of the dual problem.

    Notes
    -----
    Paper eq. (12) sign: the observer is ẋ̂ = (A + BK + LC) x̂ − L ρ + …, so L enters as
    A + L C. (A, C) detectable ⇔ (Aᵀ, Cᵀ) stabilisable; eq. (11) on (Aᵀ, Cᵀ) gives K with
    Aᵀ + CᵀK Hurwitz and L = Kᵀ.
    """
    a, c = finite_matrix("a", a), finite_matrix("c", c)
    check_pair(a, None, c, what=what, names=(names[0], "", names[1]))
    dual_names = (f"{names[0]}ᵀ", f"{names[1]}ᵀ")
    gain, p, y, gamma, result, _ = _solve_eq11(a.T, c.T, q, r, x0_shape, objective, None, what, dual_names)
    ell = gain.T
    eigs = np.linalg.eigvals(a + ell @ c)
    return LMIGain(gain=ell, p=p, y=y, gamma=gamma, objective=objective, result=result, closed_loop_eigs=eigs)


def centroid_gain(decomp, q, r, objective="gamma", x0_shape=None, gamma_max=None):
    """Centroid-holding gain of eq. (15): ``f_c = gain @ x_ō``.

    Parameters
    ----------
    decomp : Decomposition
    q : array_like, shape (2d, 2d)
        Weight on the centroid state [p̄; v̄].
    r : array_like, shape (d, d)
        Weight on the common-mode force f_c (N).
    objective, x0_shape, gamma_max
        As :func:`lmi_state_feedback`.

    Returns
    -------
    LMIGain
        ``gain`` of shape (d, 2d).

    Notes
    -----
    The common-mode force f_c is applied to every spacecraft, u = (1 ⊗ I_d) f_c + Π u_rel
    with Π = :func:`common_mode_projector`, so the centroid sees B_c = B_ō (1 ⊗ I_d)
    (acceleration f_c/m) and the relative law moves it not at all. The paper's x_ō is
    "not observable": the flight software estimates it open-loop (paper §3.2).
    """
    ones = np.kron(np.ones((decomp.n, 1)), np.eye(decomp.dims))
    return lmi_state_feedback(
        decomp.a_uo,
        decomp.b_uo @ ones,
        q,
        r,
        x0_shape=x0_shape,
        objective=objective,
        gamma_max=gamma_max,
        what="centroid holding (eq. 15)",
        names=("A_ō", "B_c"),
    )


# --- public name (coopsat.design) ---------------------------------------------------------------


def formation_lmi(
    a: ArrayLike,
    b: ArrayLike,
    q: ArrayLike,
    r: ArrayLike,
    *,
    x0_shape: ArrayLike | None = None,
    objective: str = "gamma",
    gamma_max: float | None = None,
) -> LMIGain:
    """Guaranteed-cost state-feedback gain of the deep-space formation by the LMI of eq. (11).

    Parameters
    ----------
    a : array_like, shape (n, n)
        State matrix, 1/s: e.g. ``Decomposition.a_o`` of the relative (observable) subsystem.
    b : array_like, shape (n, m)
        Input matrix: e.g. ``Decomposition.b_o`` (1/kg, forces in N).
    q : array_like, shape (n, n)
        State weight, symmetric ⪰ 0, with (a, q) observable (e.g. :func:`bryson_weights`).
    r : array_like, shape (m, m)
        Input weight, symmetric ≻ 0.
    x0_shape : array_like, shape (n, n), optional
        X₀ of the initial-state ellipsoid ``x₀ᵀ X₀ x₀ ≤ 1`` (default identity; "gamma" only).
    objective : {"gamma", "trace"}
        "gamma": minimise the cost bound γ over the ellipsoid (eq. 11); "trace": minimise
        trace P⁻¹, whose optimum is the LQR gain.
    gamma_max : float, optional
        Largest acceptable γ.

    Returns
    -------
    LMIGain
        ``gain`` (m, n) with ``u = gain @ x`` (the paper's sign, opposite to
        :func:`coopsat.design.lqr`), ``p``, ``y`` in physical units, the certified bound
        ``gamma`` (J ≤ γ² over the ellipsoid; nan for "trace"), ``closed_loop_eigs`` of
        ``a + b·gain`` (1/s, all with Re < 0), and ``result`` (the re-checked solve:
        ``certified``, ``status``, ``solver``, per-inequality ``margins``).

    Raises
    ------
    FormationDesignError
        (a, b) not stabilisable, (a, q) not observable, the LMI not certified, γ above
        ``gamma_max``, or a + b·gain not Hurwitz (a ValueError; one line).

    Notes
    -----
    :func:`lmi_state_feedback` (eq. 11, solved in balanced units), under its public name. The
    observer gain of eq. (12) is its dual, :func:`lmi_observer_gain`; the centroid-holding
    gain of eq. (15), :func:`centroid_gain`.
    """
    return lmi_state_feedback(a, b, q, r, x0_shape=x0_shape, objective=objective, gamma_max=gamma_max)
