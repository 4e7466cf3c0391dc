"""The deep-space formation's design model and its observability decomposition (SPEC §4).

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

The gains designed on it are in :mod:`coopsat.design.formation_synthesis`.
"""

import math
from dataclasses import dataclass

import numpy as np

from coopsat.design.lti import FormationDesignError

#: Coordinates of the observable (relative) subsystem, see :func:`relative_basis`.
COORDINATES = ("hub", "orthonormal")


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
