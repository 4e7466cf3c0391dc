"""Deep-space formation: model, observability decomposition, LMI gains (SPEC §4).

The Riccati (LQR) baseline is :func:`coopsat.design.riccati.lqr`, the package's one Riccati
solver; the zero-order hold :func:`discretize` is :func:`coopsat.design.riccati.discretize`.

Model (paper eq. (2), (18)). n spacecraft of mass m, each a double integrator in inertial axes
(d = 2 in the plane, or 3). Absolute state ``x = [p; v]``, p = (p_1, …, p_n) spacecraft-major
(p_1x, p_1y, [p_1z], p_2x, …) in m, v likewise in m/s; input u = per-spacecraft force in the
same order, N:

    ẋ = A x + B u,   A = [[0, I], [0, 0]],   B = [[0], [I/m]],
    ρ = C x,         ρ_ij = p_j − p_i for every pair i < j (lexicographic), m.

Eq. (18) adds the differential solar gravity and radiation pressure. Near 1 AU the gravity
gradient is μ_s/r³ ≈ 4·10⁻¹⁴ s⁻² (a time constant of 58 days; 4·10⁻¹¹ m/s² across 1 km), and
the radiation-pressure difference is a near-constant bias of order 10⁻⁸ m/s² (4.6 µN/m² on
15 m², 700 kg, reflectivities differing by 0.1), both far below the smallest thrust
(1 mN/700 kg = 1.4·10⁻⁶ m/s²). The design model leaves them out; the truth model keeps them.

Coordinates. Relative positions determine p only up to a common translation: the centroid
(position and velocity, 2d states) is unobservable. With a basis D of the vectors orthogonal
to 1 (:func:`relative_basis`; "hub": rows e_j − e_hub, positions relative to one hub
spacecraft, the paper's ρ_1j; "orthonormal": D Dᵀ = I),

    x̄ = T x = [x_ō; x_o],  x_ō = [p̄; v̄] (centroid),  x_o = [(D ⊗ I_d) p; (D ⊗ I_d) v],

gives the observability decomposition of eq. (3): ẋ_ō = A_ō x_ō + A_ōo x_o + B_ō u,
ẋ_o = A_o x_o + B_o u, ρ = C_o x_o (here A_ōo = 0: the centroid of free double integrators
does not feel the relative state).

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

Conditioning. The physical problem mixes 10¹ m, 10⁻² m/s, 10⁻¹ N, B = 1/700 and time
constants of 10²–10³ s. Every LMI is solved in balanced units: states and inputs scaled by
the square roots of the weights' diagonals (Bryson's x_max, u_max), then by the symplectic
diagonal scaling that balances the Hamiltonian matrix; time by 1/√(‖Â‖‖B̂‖) (the bandwidth of
a unit-weight double integrator) and cost by the same factor; the answer is mapped back. The
ellipsoid's X₀^{−1/2} is normalised to unit norm in the bound block. The scaling is a
congruence of the LMI, so the set of solutions is the same; only the solver's view of it
changes. Unscaled, neither objective is certified on the deep-space numbers (the best γ found
is 15.4 against the true 545); scaled, each solve takes 0.3–0.7 s. CLARABEL tends to stall
near a 10⁻¹⁰ gap on the min-γ face and call its answer inaccurate, hence the ladder of
tolerances in :data:`FORMATION_SOLVERS`.
"""

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.linalg import matrix_balance

from coopsat.design.lmi import LQR_SOLVERS, RTOL, LMIResult, MatrixInequality, solve_lmis
from coopsat.design.riccati import discretize  # noqa: F401  (re-exported: the one zero-order hold)
from coopsat.design.memo import by_value

#: Coordinates of the observable (relative) subsystem, see :func:`relative_basis`.
COORDINATES = ("hub", "orthonormal")

#: Objectives of :func:`lmi_state_feedback`.
OBJECTIVES = ("gamma", "trace")

#: CLARABEL at the tolerances of :data:`~coopsat.design.lmi.LQR_SOLVERS`, then looser, then
#: SCS. The min-γ optimum is a whole face (module docstring) on which CLARABEL can stall at a
#: gap of about 10⁻¹⁰ and report "inaccurate"; the next rung accepts that. Every answer is
#: re-checked, whichever rung gives it.
FORMATION_SOLVERS = (
    LQR_SOLVERS[0],
    ("CLARABEL", {"tol_gap_abs": 1e-10, "tol_gap_rel": 1e-10, "tol_feas": 1e-10}),
    ("CLARABEL", {}),
    LQR_SOLVERS[1],
)


class FormationDesignError(ValueError):
    """A formation design step failed; the message (one line) says which and why."""


# --- model --------------------------------------------------------------------------------------


def relative_basis(n, coordinates="hub", hub=0):
    """Basis D of the relative (translation-free) combinations of n spacecraft.

    Parameters
    ----------
    n : int
        Number of spacecraft, ≥ 2.
    coordinates : {"hub", "orthonormal"}
        "hub": one row e_j − e_hub for each j ≠ hub, ascending j (positions relative to the hub
        spacecraft). "orthonormal": the Helmert basis, row k ∝ (1, …, 1, −k, 0, …, 0) with k
        ones, so D Dᵀ = I.
    hub : int
        Index of the hub spacecraft, 0 ≤ hub < n ("hub" coordinates only).

    Returns
    -------
    ndarray, shape (n − 1, n)
        Rows sum to zero and are linearly independent.
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
        raise ValueError(f"n must be an integer ≥ 2, got {n!r}")
    if coordinates not in COORDINATES:
        raise ValueError(f"coordinates must be one of {COORDINATES}, got {coordinates!r}")
    if coordinates == "hub":
        if isinstance(hub, bool) or not isinstance(hub, (int, np.integer)) or not 0 <= hub < n:
            raise ValueError(f"hub must be an integer in [0, {n}), got {hub!r}")
        others = [j for j in range(n) if j != hub]
        basis = np.eye(n)[others]
        basis[:, hub] = -1.0
        return basis
    basis = np.zeros((n - 1, n))
    for k in range(1, n):
        basis[k - 1, :k] = 1.0
        basis[k - 1, k] = -float(k)
        basis[k - 1] /= math.sqrt(k * (k + 1))
    return basis


def pair_list(n):
    """Pairs (i, j), i < j, in lexicographic order: the order of the outputs ρ_ij.

    Parameters
    ----------
    n : int

    Returns
    -------
    tuple of (int, int), length n (n − 1) / 2
    """
    return tuple((i, j) for i in range(n) for j in range(i + 1, n))


@dataclass(frozen=True)
class FormationModel:
    """Linear model of n free double integrators measured by relative positions.

    Attributes
    ----------
    n : int
        Number of spacecraft.
    dims : int
        Spatial dimension d.
    mass_kg : float
        Mass of each spacecraft, kg.
    a : ndarray, shape (2nd, 2nd)
    b : ndarray, shape (2nd, nd)
        ``ẋ = a x + b u``; x = [p; v] (m, m/s), u = forces (N), spacecraft-major.
    c : ndarray, shape (n (n − 1) d / 2, 2nd)
        ``ρ = c x``: ρ_ij = p_j − p_i, pairs as :func:`pair_list`, d rows each.
    """

    n: int
    dims: int
    mass_kg: float
    a: np.ndarray
    b: np.ndarray
    c: np.ndarray


def _pair_incidence(n):
    inc = np.zeros((n * (n - 1) // 2, n))
    for row, (i, j) in enumerate(pair_list(n)):
        inc[row, i], inc[row, j] = -1.0, 1.0
    return inc


def formation_model(n, dims, mass_kg):
    """The formation of eq. (2)/(18) without differential gravity and radiation pressure.

    Parameters
    ----------
    n : int
        Number of spacecraft, ≥ 2.
    dims : int
        Spatial dimension, 1 to 3.
    mass_kg : float
        Mass of each spacecraft, kg.

    Returns
    -------
    FormationModel

    Notes
    -----
    See the module docstring for why the environment is left out of the design model.
    """
    relative_basis(n)  # validates n
    if isinstance(dims, bool) or not isinstance(dims, (int, np.integer)) or not 1 <= dims <= 3:
        raise ValueError(f"dims must be 1, 2 or 3, got {dims!r}")
    if not (math.isfinite(mass_kg) and mass_kg > 0.0):
        raise ValueError(f"mass_kg must be finite and > 0, got {mass_kg}")
    nd = n * dims
    a = np.block([[np.zeros((nd, nd)), np.eye(nd)], [np.zeros((nd, 2 * nd))]])
    b = np.vstack([np.zeros((nd, nd)), np.eye(nd) / mass_kg])
    c_p = np.kron(_pair_incidence(n), np.eye(dims))
    c = np.hstack([c_p, np.zeros_like(c_p)])
    return FormationModel(n=int(n), dims=int(dims), mass_kg=float(mass_kg), a=a, b=b, c=c)


# --- Kalman ranks and stabilisability ----------------------------------------------------------


def _matrix(name, value):
    m = np.atleast_2d(np.asarray(value, dtype=float))
    if m.ndim != 2 or not np.all(np.isfinite(m)):
        raise ValueError(f"{name} must be a finite 2-D array, got shape {np.shape(value)}")
    return m


def kalman_observability(a, c, rtol=1e-9):
    """Rank of the observability matrix and an orthonormal basis of the unobservable subspace.

    Parameters
    ----------
    a : array_like, shape (n, n)
    c : array_like, shape (p, n)
    rtol : float
        Singular values at or below ``rtol`` times the largest count as zero.

    Returns
    -------
    rank : int
    unobservable : ndarray, shape (n, n − rank)
        Orthonormal columns spanning the kernel of [C; CA; …; CA^{n−1}].

    Notes
    -----
    The kernel does not change under A → A/‖A‖ (a time scale) or under scaling the rows of C
    (output units), so both are normalised before the SVD; that keeps the powers of A from
    drowning one block in another when the units differ by orders of magnitude.
    """
    a, c = _matrix("a", a), _matrix("c", c)
    n = a.shape[0]
    if a.shape != (n, n) or c.shape[1] != n:
        raise ValueError(f"shapes do not match: a {a.shape}, c {c.shape}")
    row_norms = np.linalg.norm(c, axis=1)
    rows = c[row_norms > 0.0] / row_norms[row_norms > 0.0, None]
    if rows.shape[0] == 0:
        return 0, np.eye(n)
    norm_a = np.linalg.norm(a, 2)
    a_s = a / norm_a if norm_a > 0.0 else a
    blocks = [rows]
    for _ in range(n - 1):
        blocks.append(blocks[-1] @ a_s)
    _, sv, vt = np.linalg.svd(np.vstack(blocks))
    rank = int(np.sum(sv > rtol * sv[0]))
    return rank, vt[rank:].T


def kalman_controllability(a, b, rtol=1e-9):
    """Rank of the controllability matrix and an orthonormal basis of its orthogonal complement.

    Parameters
    ----------
    a : array_like, shape (n, n)
    b : array_like, shape (n, m)
    rtol : float
        As :func:`kalman_observability`.

    Returns
    -------
    rank : int
    uncontrollable : ndarray, shape (n, n − rank)
        Orthonormal columns spanning the orthogonal complement of range [B, AB, …]; the
        uncontrollable dynamics are ``uncontrollableᵀ a uncontrollable``.
    """
    a, b = _matrix("a", a), _matrix("b", b)
    return kalman_observability(a.T, b.T, rtol)


def _unstable_modes(a, basis):
    """Eigenvalues of the dynamics on ``basis`` (an invariant subspace or its quotient) that are
    not in the open left half-plane, tiny ones shown as 0."""
    if basis.shape[1] == 0:
        return np.zeros(0, dtype=complex)
    scale = max(np.linalg.norm(a, 2), np.finfo(float).tiny)
    eig = np.linalg.eigvals(basis.T @ a @ basis)
    # A nilpotent block of size k has eigenvalues ~ε^{1/k}‖A‖ in floating point: √ε is zero.
    tol = math.sqrt(np.finfo(float).eps) * scale
    eig = np.where(np.abs(eig) < tol, 0.0, eig)
    return eig[eig.real >= -tol]


def _format_eigs(eig):
    def one(z):
        return f"{z.real:.3g}" if z.imag == 0.0 else f"{z.real:.3g}{z.imag:+.3g}j"

    return ", ".join(one(complex(z)) for z in eig)


def check_pair(a, b, c=None, what="system", names=("A", "B", "C"), rtol=1e-9):
    """Raise unless (a, b) is stabilisable and (a, c) detectable.

    Parameters
    ----------
    a : array_like, shape (n, n)
    b : array_like, shape (n, m), or None
        Checked for stabilisability when given.
    c : array_like, shape (p, n), optional
        Checked for detectability when given.
    what : str
        The design step, first in the message ("state feedback", "observer").
    names : (str, str, str)
        Symbols of a, b, c in the message.
    rtol : float
        Rank tolerance, see :func:`kalman_observability`.

    Raises
    ------
    FormationDesignError
        One line, e.g. "state feedback: (A_o, B_o) is not controllable (rank 10 of 12) and
        not stabilisable: uncontrollable modes at 0, 0".

    Notes
    -----
    Stabilisability and detectability are what the LMIs of eq. (11) need; a double
    integrator's uncontrollable or unobservable modes sit at 0, so for this formation they
    coincide with controllability and observability.
    """
    if b is None and c is None:
        raise ValueError("check_pair needs b or c")
    a = _matrix("a", a)
    n = a.shape[0]
    if b is not None:
        rank, basis = kalman_controllability(a, b, rtol)
        bad = _unstable_modes(a, basis)
        if bad.size:
            raise FormationDesignError(
                f"{what}: ({names[0]}, {names[1]}) is not controllable (rank {rank} of {n}) and not "
                f"stabilisable: uncontrollable modes at {_format_eigs(bad)}"
            )
    if c is not None:
        rank, basis = kalman_observability(a, c, rtol)
        bad = _unstable_modes(a, basis)
        if bad.size:
            raise FormationDesignError(
                f"{what}: ({names[0]}, {names[2]}) is not observable (rank {rank} of {n}) and not "
                f"detectable: unobservable modes at {_format_eigs(bad)}"
            )


# --- observability decomposition ---------------------------------------------------------------


@dataclass(frozen=True)
class Decomposition:
    """Observability decomposition of eq. (3), ``x̄ = t x = [x_ō; x_o]``.

    Attributes
    ----------
    t : ndarray, shape (2nd, 2nd)
        Rows: centroid position (d), centroid velocity (d), (D ⊗ I_d) p, (D ⊗ I_d) v.
    t_inv : ndarray, shape (2nd, 2nd)
    a_uo : ndarray, shape (2d, 2d)
        A_ō, the centroid dynamics.
    a_uo_o : ndarray, shape (2d, 2(n − 1)d)
        A_ōo (zero for this model).
    a_o : ndarray, shape (2(n − 1)d, 2(n − 1)d)
    b_uo : ndarray, shape (2d, nd)
    b_o : ndarray, shape (2(n − 1)d, nd)
    c_o : ndarray, shape (n (n − 1) d / 2, 2(n − 1)d)
        ``ρ = c_o x_o``, all pairs as the model's outputs.
    basis : ndarray, shape (n − 1, n)
        D of :func:`relative_basis`.
    coordinates : str
        "hub" or "orthonormal".
    """

    t: np.ndarray
    t_inv: np.ndarray
    a_uo: np.ndarray
    a_uo_o: np.ndarray
    a_o: np.ndarray
    b_uo: np.ndarray
    b_o: np.ndarray
    c_o: np.ndarray
    basis: np.ndarray
    coordinates: str

    @property
    def n(self):
        """Number of spacecraft."""
        return self.basis.shape[1]

    @property
    def dims(self):
        """Spatial dimension d."""
        return self.t.shape[0] // (2 * self.n)


def observability_decomposition(model, coordinates="hub", hub=0):
    """Structured observability decomposition (eq. 3) of a :class:`FormationModel`.

    Parameters
    ----------
    model : FormationModel
    coordinates : {"hub", "orthonormal"}
    hub : int
        See :func:`relative_basis`.

    Returns
    -------
    Decomposition

    Raises
    ------
    FormationDesignError
        If the transformed system does not have the block structure of eq. (3) (the model is
        not a formation of double integrators measured by relative positions).
    """
    n, d = model.n, model.dims
    basis = relative_basis(n, coordinates, hub)
    eye = np.eye(d)
    mean = np.kron(np.full((1, n), 1.0 / n), eye)
    rel = np.kron(basis, eye)
    zm, zr = np.zeros_like(mean), np.zeros_like(rel)
    t = np.block([[mean, zm], [zm, mean], [rel, zr], [zr, rel]])
    ones = np.kron(np.ones((n, 1)), eye)
    # D⁺ = Dᵀ(DDᵀ)⁻¹ and 1ᵀD⁺ = (D1)ᵀ(DDᵀ)⁻¹ = 0: [1, D⁺] inverts [1ᵀ/n; D] exactly.
    rel_inv = np.kron(np.linalg.pinv(basis), eye)
    zo, zi = np.zeros_like(ones), np.zeros_like(rel_inv)
    t_inv = np.block([[ones, zo, rel_inv, zi], [zo, ones, zi, rel_inv]])
    a_bar, b_bar, c_bar = t @ model.a @ t_inv, t @ model.b, model.c @ t_inv
    k = 2 * d
    residuals = {
        "T T⁻¹ − I": np.abs(t @ t_inv - np.eye(t.shape[0])).max(),
        "lower-left block of T A T⁻¹": np.abs(a_bar[k:, :k]).max() / max(np.abs(a_bar).max(), 1.0),
        "centroid columns of C T⁻¹": np.abs(c_bar[:, :k]).max() / max(np.abs(c_bar).max(), 1.0),
    }
    for name, value in residuals.items():
        if value > 1e-12:
            raise FormationDesignError(f"observability decomposition: {name} is {value:.3g}, not 0")
    return Decomposition(
        t=t,
        t_inv=t_inv,
        a_uo=a_bar[:k, :k],
        a_uo_o=a_bar[:k, k:],
        a_o=a_bar[k:, k:],
        b_uo=b_bar[:k],
        b_o=b_bar[k:],
        c_o=c_bar[:, k:],
        basis=basis,
        coordinates=coordinates,
    )


def output_map(decomp):
    """Matrix from the pair measurements ρ to the position part (D ⊗ I_d) p of x_o.

    Parameters
    ----------
    decomp : Decomposition

    Returns
    -------
    ndarray, shape ((n − 1) d, n (n − 1) d / 2)

    Notes
    -----
    The pairs are redundant (n(n − 1)/2 of them for n − 1 independent relative positions); the
    pseudo-inverse of the position columns of C_o is exact on consistent measurements and the
    least-squares estimate on noisy ones (equal, independent noise on every pair).
    """
    half = decomp.a_o.shape[0] // 2
    return np.linalg.pinv(decomp.c_o[:, :half])


def reference_map(decomp):
    """M_ρ of the paper (§3.1): the target ``x_o = M_ρ ρ_cmd`` for commanded pair positions.

    Parameters
    ----------
    decomp : Decomposition

    Returns
    -------
    ndarray, shape (2(n − 1) d, n (n − 1) d / 2)
        Positions from :func:`output_map`, velocities zero. The paper's reference gain is
        ``F = −K_o M_ρ``.
    """
    pos = output_map(decomp)
    return np.vstack([pos, np.zeros_like(pos)])


def reference_state(decomp, positions_m):
    """Target observable state for target absolute positions.

    Parameters
    ----------
    decomp : Decomposition
    positions_m : array_like, shape (n, d)
        Target position of each spacecraft, m; a common translation does not change the
        result.

    Returns
    -------
    ndarray, shape (2(n − 1) d,)
        ``[(D ⊗ I_d) p; 0]``.
    """
    n, d = decomp.n, decomp.dims
    p = np.asarray(positions_m, dtype=float)
    if p.shape != (n, d):
        raise ValueError(f"positions_m must have shape ({n}, {d}), got {p.shape}")
    rel = np.kron(decomp.basis, np.eye(d)) @ p.ravel()
    return np.concatenate([rel, np.zeros_like(rel)])


# --- LMI gains ----------------------------------------------------------------------------------


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


def _weight_scales(diagonal):
    """1/√w for each positive weight; the geometric mean of those for zero weights."""
    diagonal = np.asarray(diagonal, dtype=float)
    positive = diagonal > 0.0
    if not positive.any():
        return np.ones_like(diagonal)
    scales = np.empty_like(diagonal)
    scales[positive] = 1.0 / np.sqrt(diagonal[positive])
    scales[~positive] = math.exp(np.mean(np.log(scales[positive])))
    return scales


def _time_scale(a, b, s, s_u):
    """τ = 1/√(‖S⁻¹AS‖‖S⁻¹BS_u‖) (s): Ã = τ S⁻¹AS and B̃ = τ S⁻¹BS_u both of order one."""
    norm_a = np.linalg.norm(a * (s[None, :] / s[:, None]), 2)
    norm_b = np.linalg.norm(b * (s_u[None, :] / s[:, None]), 2)
    if norm_a > 0.0 and norm_b > 0.0:
        return 1.0 / math.sqrt(norm_a * norm_b)
    return 1.0 / max(norm_a, norm_b, np.finfo(float).tiny)


def _balance(a, b, q, r):
    """State scales s, input scales s_u and time scale τ (s): x = S x̃, u = S_u ũ, t = τ t̃.

    First states and inputs in units of Bryson's x_max and u_max (1/√ of the weights'
    diagonals) and τ from :func:`_time_scale` (the bandwidth of a unit-weight double
    integrator); then a symplectic diagonal scaling diag(D, D⁻¹) of the Hamiltonian matrix
    [[Ã, −B̃ r̃⁻¹ B̃ᵀ], [−q̃, −Ãᵀ]], D = √(d_x/d_λ) from its diagonal balancing (as scipy's
    Riccati solver does), which also covers weights whose diagonal says little about the
    dynamics (an observer's noise intensities), and τ again.
    """
    n = a.shape[0]
    s, s_u = _weight_scales(np.diag(q)), _weight_scales(np.diag(r))
    tau = _time_scale(a, b, s, s_u)
    a_t = tau * a * (s[None, :] / s[:, None])
    b_t = tau * b * (s_u[None, :] / s[:, None])
    r_t = r * np.outer(s_u, s_u)
    ham = np.block([[a_t, -b_t @ np.linalg.solve(r_t, b_t.T)], [-q * np.outer(s, s), -a_t.T]])
    _, (scale, _) = matrix_balance(ham, permute=False, separate=True)
    s = s * np.sqrt(scale[:n] / scale[n:])
    return s, s_u, _time_scale(a, b, s, s_u)


def _psd_factor(q):
    """Q with QᵀQ = q (rows: the numerically nonzero eigen-directions)."""
    lam, vec = np.linalg.eigh(0.5 * (q + q.T))
    keep = lam > 1e-12 * max(lam[-1], 0.0)
    return np.sqrt(lam[keep])[:, None] * vec[:, keep].T


def _spd(name, value, size):
    m = _matrix(name, value)
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


@by_value
def _solve_eq11(a, b, q, r, x0_shape, objective, gamma_max, what, names):
    """Eq. (11) for u = K x on (a, b) with weights (q, r); returns (K, P, Y, γ, result, eigs)."""
    a, b = _matrix("a", a), _matrix("b", b)
    n, m = b.shape
    if a.shape != (n, n):
        raise ValueError(f"shapes do not match: a {a.shape}, b {b.shape}")
    q = _matrix("q", q)
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

    s, s_u, tau = _balance(a, b, q, r)
    # ∫ xᵀq x + uᵀr u dt = τ ∫ x̃ᵀ(SqS)x̃ + ũᵀ(S_u r S_u)ũ dt̃: with the cost scale σ = τ the
    # balanced weights are S q S and S_u r S_u, and J = σ J̃.
    sigma = tau
    a_t = tau * a * (s[None, :] / s[:, None])
    b_t = tau * b * (s_u[None, :] / s[:, None])
    q_o = _psd_factor(q * np.outer(s, s))
    q_u = np.linalg.cholesky(r * np.outer(s_u, s_u)).T
    x0_t = x0 * np.outer(s, s)

    import cvxpy as cp

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
    return gain, p_phys, y_phys, (gamma if objective == "gamma" else math.nan), result, eig_t / tau


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
    a, c = _matrix("a", a), _matrix("c", c)
    check_pair(a, None, c, what=what, names=(names[0], "", names[1]))
    dual_names = (f"{names[0]}ᵀ", f"{names[1]}ᵀ")
    gain, p, y, gamma, result, _ = _solve_eq11(a.T, c.T, q, r, x0_shape, objective, None, what, dual_names)
    ell = gain.T
    eigs = np.linalg.eigvals(a + ell @ c)
    return LMIGain(gain=ell, p=p, y=y, gamma=gamma, objective=objective, result=result, closed_loop_eigs=eigs)


def nonzero_setpoint_feedforward(a, b, c, k):
    """Feed-forward N of the non-zero set-point law ``u = −k x + N y_d`` (eq. 17).

    Parameters
    ----------
    a : array_like, shape (n, n)
    b : array_like, shape (n, m)
    c : array_like, shape (p, n)
    k : array_like, shape (m, n)
        ``u = −k x``, A − BK Hurwitz.

    Returns
    -------
    ndarray, shape (m, p)
        ``pinv(C (BK − A)⁻¹ B)``.

    Notes
    -----
    Eq. (17) inverts C(BK − A)⁻¹B, the DC gain from a constant input offset to y. Here there
    are more inputs than independent outputs (and the pair outputs are redundant), so the
    inverse does not exist: the pseudo-inverse gives the minimum-norm feed-forward, which
    reaches every y_d in the range of C exactly. In the observable coordinates B_o annihilates
    the common-mode force, so that force lies in the kernel of the DC gain and the minimum-norm
    feed-forward contains none.
    """
    a, b, c, k = (_matrix(name, v) for name, v in (("a", a), ("b", b), ("c", c), ("k", k)))
    dc = c @ np.linalg.solve(b @ k - a, b)
    return np.linalg.pinv(dc)


def bryson_weights(x_max, u_max, n_x=None, n_u=None):
    """Bryson's rule: diagonal weights 1/x_max², 1/u_max².

    Parameters
    ----------
    x_max : float or array_like, shape (n_x,)
        Largest acceptable value of each state (its unit).
    u_max : float or array_like, shape (n_u,)
        Largest acceptable value of each input (its unit).
    n_x, n_u : int, optional
        Lengths to broadcast scalars (or shorter broadcastable arrays) to.

    Returns
    -------
    q : ndarray, shape (n_x, n_x)
    r : ndarray, shape (n_u, n_u)
    """

    def weights(name, value, size):
        v = np.atleast_1d(np.asarray(value, dtype=float))
        if size is not None:
            v = np.broadcast_to(v, (size,))
        if v.ndim != 1 or not np.all(np.isfinite(v)) or np.any(v <= 0.0):
            raise ValueError(f"{name} must be finite and > 0, got {value!r}")
        return np.diag(1.0 / v**2)

    return weights("x_max", x_max, n_x), weights("u_max", u_max, n_u)


# --- centroid holding (eq. 15) ------------------------------------------------------------------


def common_mode_projector(n, dims):
    """Projector removing the common-mode (centroid-moving) part of a stacked force vector.

    Parameters
    ----------
    n : int
    dims : int

    Returns
    -------
    ndarray, shape (nd, nd)
        ``I − (1 1ᵀ / n) ⊗ I_d``, symmetric, idempotent; the forces it returns sum to zero.
    """
    relative_basis(n)  # validates n
    return np.eye(n * dims) - np.kron(np.full((n, n), 1.0 / n), np.eye(dims))


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
