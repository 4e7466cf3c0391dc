"""Sampled-data stability of the consensus attitude laws (SPEC §1).

A law that is stable in continuous time can be unstable on board, where it is evaluated once
per control period T and held (zero-order hold) in between. This module linearises the closed
loop of laws (3)/(4) about consensus (or about the reference, for tracking), forms the exact
one-period map

    x_{k+1} = Φ(T) x_k,   Φ(T) = e^{AT} − Γ(T) G,   Γ(T) = ∫_0^T e^{As} ds B,

and reports its spectral radius and the largest period for which it is below 1. PWM thrusters
in their proportional band deliver the same impulse per period as the held torque, so the same
map governs them near consensus (below the minimum pulse they deliver nothing: a dead band).

Linearisation (per spacecraft i, body axes; ε_i the vector part of the error quaternion with
respect to the reference, or to the common attitude for synchronisation; δω_i = ω_i − ω_r):

    ε̇_i  = ½ δω_i − ω_r × ε_i
    I_i δω̇_i = ([I_i ω_r]× − [ω_r]× I_i) δω_i + u_i
    u_i = −Σ_j a_ij [α (ε_i − ε_j) + β (δω_i − δω_j)] − K ε_i − D δω_i

For synchronisation (K = D = 0, ω_r = 0) the consensus subspace (all ε_i equal, all δω_i
equal) is invariant and carries eigenvalues 1 of Φ (the common drift, which the law leaves
alone); stability is decided on the disagreement subspace, the quotient by it.
"""

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from coopsat.design.riccati import discretize
from coopsat.design.memo import by_value
from coopsat.network.topology import laplacian


def _skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def linearize_consensus_loop(inertia_kgm2, adjacency, alpha, beta, k_p=0.0, k_d=0.0, omega_ref_rad_s=(0.0, 0.0, 0.0)):
    """Continuous-time linear model ``ẋ = A x + B u``, ``u = −G x`` of laws (3)/(4).

    Parameters
    ----------
    inertia_kgm2 : array_like, shape (n, 3, 3)
    adjacency : array_like, shape (n, n)
        ``A[i, j]`` = weight with which i hears j.
    alpha, beta : float
        Consensus gains α (N·m), β (N·m·s/rad).
    k_p, k_d : float
        Tracking gains K (N·m), D (N·m·s/rad); zero for synchronisation.
    omega_ref_rad_s : array_like, shape (3,)
        Reference body rate, rad/s (zero for synchronisation).

    Returns
    -------
    a : ndarray, shape (6n, 6n)
    b : ndarray, shape (6n, 3n)
    g : ndarray, shape (3n, 6n)
        State ordered per spacecraft as ``[ε (3), δω (3)]``; input per spacecraft (3).

    Notes
    -----
    2010 consensus paper, laws (3)–(4), linearised as in the module docstring.
    """
    inertia = np.asarray(inertia_kgm2, dtype=float)
    adj = np.asarray(adjacency, dtype=float)
    w_r = np.asarray(omega_ref_rad_s, dtype=float)
    n = inertia.shape[0]
    lap = laplacian(adj)
    a = np.zeros((6 * n, 6 * n))
    b = np.zeros((6 * n, 3 * n))
    for i in range(n):  # design time, n small: assembling a dense model is fine here
        e, w = slice(6 * i, 6 * i + 3), slice(6 * i + 3, 6 * i + 6)
        inv = np.linalg.inv(inertia[i])
        a[e, e] = -_skew(w_r)
        a[e, w] = 0.5 * np.eye(3)
        a[w, w] = inv @ (_skew(inertia[i] @ w_r) - _skew(w_r) @ inertia[i])
        b[w, 3 * i : 3 * i + 3] = inv
    g_eps = np.kron(alpha * lap + k_p * np.eye(n), np.eye(3))
    g_w = np.kron(beta * lap + k_d * np.eye(n), np.eye(3))
    g = np.zeros((3 * n, 6 * n))
    for i in range(n):
        g[:, 6 * i : 6 * i + 3] = g_eps[:, 3 * i : 3 * i + 3]
        g[:, 6 * i + 3 : 6 * i + 6] = g_w[:, 3 * i : 3 * i + 3]
    return a, b, g


def period_map(a, b, g, period_s):
    """One-period map ``Φ = e^{AT} − Γ G`` of the loop with the input held over T.

    Returns
    -------
    ndarray, shape (m, m)

    Notes
    -----
    ``e^{AT}`` and ``Γ = ∫_0^T e^{As} ds B`` come from one exponential of the augmented
    matrix ``[[A, B], [0, 0]] T`` (Van Loan, 1978): :func:`coopsat.design.riccati.discretize`.
    """
    phi, gam = discretize(a, b, period_s)
    return phi - gam @ g


def consensus_subspace(n):
    """Orthonormal basis of {all ε_i equal, all δω_i equal}, shape (6n, 6)."""
    v = np.zeros((6 * n, 6))
    for k in range(6):
        v[k::6, k] = 1.0 / np.sqrt(n)
    return v


@dataclass(frozen=True)
class SampledDataStability:
    """Result of :func:`analyze_sampled_data`.

    Attributes
    ----------
    period_s : float
        Control period analysed, s.
    spectral_radius : float
        Of the one-period map (on the disagreement subspace for synchronisation).
    max_stable_period_s : float
        Largest T such that the map is stable for every period in (0, T]; ``inf`` if stable up
        to the search limit (1000 s), 0 if unstable already at 1 µs.
    continuous_max_real : float
        Largest real part of the continuous-time closed-loop eigenvalues (same subspace), 1/s.
    dominant : tuple of (int, int)
        (spacecraft index, body axis) carrying the largest share of the most unstable (or
        slowest) mode of Φ at ``period_s``: where the instability lives.
    stable : bool
        ``spectral_radius < 1``.
    """

    period_s: float
    spectral_radius: float
    max_stable_period_s: float
    continuous_max_real: float
    dominant: tuple
    stable: bool


def _reduced(a, b, g, quotient):
    if not quotient:
        return a, b, g, np.eye(a.shape[0])
    n = a.shape[0] // 6
    from scipy.linalg import null_space  # here: a build whose result is kept on disk needs no scipy

    w = null_space(consensus_subspace(n).T)  # orthonormal complement, (6n, 6n-6)
    return w.T @ a @ w, w.T @ b, g @ w, w


def max_stable_period(a, b, g, quotient, t_min_s=1e-6, t_max_s=1e3, n_grid=64):
    """Largest T with a stable one-period map for all periods up to T.

    Scans a logarithmic grid from ``t_min_s`` up (ratio about 1.4 between points) and
    refines the first crossing of ρ = 1 by Brent's method. Returns ``inf`` if no crossing below
    ``t_max_s``, 0 if already unstable at ``t_min_s`` (gains too high for any practical period,
    or a continuous-time loop that is itself unstable).
    """
    from scipy.optimize import brentq  # 0.25 s of import: only when the result is not kept on disk

    ar, br, gr, _ = _reduced(a, b, g, quotient)

    def rho_minus_one(t):
        return float(np.max(np.abs(np.linalg.eigvals(period_map(ar, br, gr, t))))) - 1.0

    grid = np.geomspace(t_min_s, t_max_s, n_grid)
    prev = grid[0]
    if rho_minus_one(prev) >= 0.0:
        return 0.0
    for t in grid[1:]:
        if rho_minus_one(t) >= 0.0:
            return float(brentq(rho_minus_one, prev, t, xtol=1e-12 * t, rtol=1e-10))
        prev = t
    return float("inf")


@by_value
def analyze_sampled_data(inertia_kgm2, adjacency, period_s, alpha, beta, k_p=0.0, k_d=0.0, omega_ref_rad_s=(0, 0, 0)):
    """Stability of laws (3)/(4) sampled every ``period_s`` with a zero-order hold.

    Parameters
    ----------
    inertia_kgm2 : (n, 3, 3)
    adjacency : (n, n)
    period_s : float
        Control period T, s.
    alpha, beta, k_p, k_d, omega_ref_rad_s
        As :func:`linearize_consensus_loop`.

    Returns
    -------
    SampledDataStability
    """
    a, b, g = linearize_consensus_loop(inertia_kgm2, adjacency, alpha, beta, k_p, k_d, omega_ref_rad_s)
    quotient = k_p == 0.0 and k_d == 0.0
    ar, br, gr, w = _reduced(a, b, g, quotient)
    phi = period_map(ar, br, gr, period_s)
    lam, vec = np.linalg.eig(phi)
    k = int(np.argmax(np.abs(lam)))
    mode = np.abs(w @ vec[:, k]).reshape(-1, 2, 3)  # (n, [ε, δω], axis)
    share = mode.sum(axis=1)
    sc, axis = np.unravel_index(int(np.argmax(share)), share.shape)
    rho = float(np.abs(lam[k]))
    return SampledDataStability(
        period_s=float(period_s),
        spectral_radius=rho,
        max_stable_period_s=max_stable_period(a, b, g, quotient),
        continuous_max_real=float(np.max(np.linalg.eigvals(ar - br @ gr).real)),
        dominant=(int(sc), int(axis)),
        stable=rho < 1.0,
    )


def sampled_pd_radius(gain_p, gain_d, gain_i, period_s):
    """Spectral radius of the sampled PID loop of ``ẍ = u``, ``u = −g_p x − g_d ẋ − g_i ∫x``, the
    command held over the period and the integral advanced as 
    :func:`coopsat.control.pid.integrate_error`.

    Parameters
    ----------
    gain_p, gain_d, gain_i : float
        Gains per unit mass or inertia (1/s², 1/s, 1/s³).
    period_s : float
        Control period T, s.

    Returns
    -------
    float
        Spectral radius of the one-period map (< 1: stable)."""
    t = period_s
    # State (x, ẋ, ∫x) at a sample; u = −(g_p, g_d, g_i)·state, held for T.
    a = np.array([[1.0, t, 0.0], [0.0, 1.0, 0.0], [t, 0.0, 1.0]])
    b = np.array([t * t / 2.0, t, 0.0])
    k = np.array([gain_p, gain_d, gain_i])
    m = a - np.outer(b, k)
    if gain_i == 0.0:
        m = m[:2, :2]
    return float(np.max(np.abs(np.linalg.eigvals(m))))


# --- public name (coopsat.design) ---------------------------------------------------------------


def sampled_data_check(
    inertia_kgm2: ArrayLike,
    adjacency: ArrayLike,
    period_s: float,
    alpha: float,
    beta: float,
    *,
    k_p: float = 0.0,
    k_d: float = 0.0,
    omega_ref_rad_s: ArrayLike = (0.0, 0.0, 0.0),
) -> SampledDataStability:
    """Stability of the consensus attitude laws (3)/(4) evaluated every ``period_s`` and held.

    Parameters
    ----------
    inertia_kgm2 : array_like, shape (n, 3, 3)
        Inertia of each spacecraft, kg·m².
    adjacency : array_like, shape (n, n)
        ``A[i, j]`` = weight with which i hears j.
    period_s : float
        Control period T, s.
    alpha, beta : float
        Consensus gains α (N·m) and β (N·m·s/rad).
    k_p, k_d : float
        Tracking gains K (N·m) and D (N·m·s/rad); both 0 for synchronisation (then the
        analysis is on the disagreement subspace).
    omega_ref_rad_s : array_like, shape (3,)
        Reference body rate, rad/s.

    Returns
    -------
    SampledDataStability
        The proof: ``spectral_radius`` of the exact one-period map at ``period_s`` and
        ``stable`` (< 1), the largest stable period ``max_stable_period_s`` (s), the
        continuous loop's ``continuous_max_real`` (1/s) and the ``dominant`` (spacecraft,
        axis) of the slowest mode.

    Notes
    -----
    :func:`analyze_sampled_data`, under its public name.
    """
    return analyze_sampled_data(inertia_kgm2, adjacency, period_s, alpha, beta, k_p, k_d, omega_ref_rad_s)
