"""Exact constant-delay margin of leader–follower consensus with multi-hop delay (SPEC §3).

A message relayed over m hops arrives m·τ late, τ the single-hop delay. Linearised about the
leader, the follower errors obey a linear retarded system with commensurate delays

    ẋ(t) = A0 x(t) + Σ_k A_k x(t − m_k τ),   m_k ∈ {1, 2, …},

whose characteristic equation is

    det M(s, τ) = 0,   M(s, τ) = s I − A0 − Σ_k A_k e^{−s m_k τ}.

For a constant τ the system is exponentially stable iff every root lies in Re s < 0. Roots
move continuously with τ (retarded type: none come in from infinity on the right), so the
margin of a system stable at τ = 0 is the smallest τ > 0 at which a root lies on the
imaginary axis. With z = e^{−jωτ} such a root s = jω makes jω an eigenvalue of the
polynomial matrix

    A(z) = A0 + Σ_k A_k z^{m_k}   with |z| = 1,

a problem in two unknowns (ω, z) that :func:`exact_delay_margin` solves exactly by
eliminating ω (Kronecker sum; Chen, Gu & Nett 1995). The margin holds for a constant
delay; a time-varying τ(t) needs a Lyapunov–Krasovskii condition, and this number is then an
upper bound on what any such condition can certify.
"""

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.linalg import eig, eigvals, svd

PROTOCOLS = ("law3", "classical")


def _as_system(a0, terms):
    a0 = np.atleast_2d(np.asarray(a0, dtype=float))
    mats, hops = [], []
    for a_k, m_k in terms:
        if int(m_k) != m_k or m_k < 1:
            raise ValueError(f"delay multiples must be positive integers, got {m_k}")
        mats.append(np.atleast_2d(np.asarray(a_k, dtype=float)))
        hops.append(int(m_k))
    return a0, mats, hops


def _scale(a0, mats):
    """``||A0|| + Σ ||A_k||`` (spectral norms): every imaginary root satisfies ``|ω|`` ≤ it."""
    return float(np.linalg.norm(a0, 2) + sum(np.linalg.norm(a, 2) for a in mats))


def characteristic_matrix(a0, terms, s, tau):
    """``M(s, τ) = s I − A0 − Σ_k A_k e^{−s m_k τ}``.

    Parameters
    ----------
    a0 : array_like, shape (n, n)
    terms : sequence of (array_like (n, n), int)
        Delayed terms ``(A_k, m_k)``: ``A_k`` multiplies ``x(t − m_k τ)``.
    s : complex
        Laplace variable, 1/s.
    tau : float
        Single-hop delay τ, s.

    Returns
    -------
    ndarray, shape (n, n), complex
    """
    a0, mats, hops = _as_system(a0, terms)
    m = s * np.eye(a0.shape[0]) - a0
    for a_k, m_k in zip(mats, hops):
        m = m - a_k * np.exp(-s * m_k * tau)
    return m


@dataclass(frozen=True)
class DelayMargin:
    """Result of :func:`exact_delay_margin`.

    Attributes
    ----------
    tau_s : float
        Exact constant-delay margin, s: the system is exponentially stable for every constant
        single-hop delay in [0, τ*) and has a root on the imaginary axis at τ*. ``inf`` when no
        root reaches the axis for any τ (stable independently of the delay); 0 when the system
        is not exponentially stable without delay.
    omega_rad_s : float
        Frequency ω > 0 of the root ``s = jω`` at τ*, rad/s; nan when ``tau_s`` is 0 or inf.
    stable_without_delay : bool
        ``A0 + Σ A_k`` is Hurwitz.
    crossings : list of (float, float)
        ``(τ, ω)`` of every imaginary-axis root found, sorted by τ: all branches
        ``τ = (φ + 2πk)/ω`` up to ``tau_max_search``, or only the first branch (k = 0) of each
        crossing frequency when it was not given.
    root_speed : float
        ``d Re s / dτ`` of the crossing root at τ*, 1/s²: positive when it moves into the right
        half-plane (it is ≥ 0 at the margin of a system stable at τ = 0; 0 only for a
        tangency); nan when there is no crossing.
    method : str
        How the crossings were found.
    residual : float
        The proof of the crossing at τ*: ``σ_min M(jω*, τ*) / (ω* + ‖A0‖ + Σ‖A_k‖)``, the
        smallest singular value of the characteristic matrix there, relative (at most 10⁻⁹
        for a crossing to be accepted; about 10⁻¹⁶ after the Newton polish); nan when there
        is no crossing.
    """

    tau_s: float
    omega_rad_s: float
    stable_without_delay: bool
    crossings: list
    root_speed: float
    method: str
    residual: float = math.nan


def _kronecker_pencil(a0, mats, hops):
    """Block-companion pencil ``(P, Q)`` whose eigenvalues z are the roots of
    ``det z^M [A(z) ⊗ I + I ⊗ A(1/z)] = 0``, ``M = max m_k``; shape (2M n², 2M n²) each."""
    n = a0.shape[0]
    big_m = max(hops)
    eye = np.eye(n)
    coef = [np.zeros((n * n, n * n)) for _ in range(2 * big_m + 1)]  # coef[p] multiplies z^p
    coef[big_m] += np.kron(a0, eye) + np.kron(eye, a0)
    for a_k, m_k in zip(mats, hops):
        coef[big_m + m_k] += np.kron(a_k, eye)
        coef[big_m - m_k] += np.kron(eye, a_k)
    d, size = 2 * big_m, n * n
    p = np.eye(d * size, k=size)
    q = np.eye(d * size)
    for i in range(d):
        p[(d - 1) * size :, i * size : (i + 1) * size] = -coef[i]
    q[(d - 1) * size :, (d - 1) * size :] = coef[d]
    return p, q


def _polish_on_circle(a0, mats, hops, theta, lam, scale):
    """Newton on ``Re λ(e^{jθ}) = 0`` along the eigenvalue branch of ``A(e^{jθ})`` through λ.

    ``dλ/dθ = yᴴ A'(θ) x / yᴴ x`` (left and right eigenvectors y, x), with
    ``A'(θ) = Σ_k j m_k A_k e^{j m_k θ}``. Returns the refined ``(θ, λ)``.
    """
    for _ in range(8):
        z = np.exp(1j * theta)
        a_z = a0 + sum(a_k * z**m_k for a_k, m_k in zip(mats, hops))
        w, vl, vr = eig(a_z, left=True, right=True)
        i = int(np.argmin(np.abs(w - lam)))
        lam = w[i]
        da = sum(1j * m_k * a_k * z**m_k for a_k, m_k in zip(mats, hops))
        dlam = (vl[:, i].conj() @ da @ vr[:, i]) / (vl[:, i].conj() @ vr[:, i])
        if abs(lam.real) <= 1e-15 * scale or dlam.real == 0.0:
            break
        theta -= lam.real / dlam.real
    return theta, lam


def _root_speed(a0, terms, omega, tau):
    """``d Re s / dτ`` of the simple root ``s = jω`` at τ, from the singular vectors of M.

    ``ds/dτ = −uᴴ M_τ v / uᴴ M_s v`` with ``M_s = I + Σ m_k τ A_k e^{−s m_k τ}``,
    ``M_τ = Σ m_k s A_k e^{−s m_k τ}``; its sign is the same on every branch k (the τ-dependent
    part of ``1/(ds/dτ)`` is ``−τ/s``, imaginary on the axis).
    """
    s = 1j * omega
    u, _, vh = svd(characteristic_matrix(a0, terms, s, tau))
    left, right = u[:, -1], vh[-1].conj()
    m_s = np.eye(len(right), dtype=complex)
    m_tau = np.zeros_like(m_s)
    for a_k, m_k in terms:
        e = np.asarray(a_k) * np.exp(-s * m_k * tau)
        m_s += m_k * tau * e
        m_tau += m_k * s * e
    return float((-(left.conj() @ m_tau @ right) / (left.conj() @ m_s @ right)).real)


def _unit_circle_roots(a0, mats, hops, scale):
    """The z within 1e-4 of the unit circle where ``A(z) ⊗ I + I ⊗ A(1/z)`` is singular: the
    finite generalised eigenvalues of the Kronecker-sum pencil (:func:`exact_delay_margin`)."""
    p, q = _kronecker_pencil(a0, mats, hops)
    alpha, beta = eig(p, q, right=False, homogeneous_eigvals=True)
    if np.any((np.abs(alpha) < 1e-12 * scale) & (np.abs(beta) < 1e-12)):
        raise ValueError("the Kronecker-sum pencil is singular; the crossings are not isolated")
    finite = np.abs(beta) > 1e-12 * np.abs(alpha)
    z_all = alpha[finite] / beta[finite]
    return z_all[np.abs(np.abs(z_all) - 1.0) < 1e-4]


def _crossings(a0, mats, hops, on_circle, scale):
    """Distinct verified crossings ``(ω, φ)`` (ω > 0, φ = −arg z mod 2π) from the candidate z,
    and the relative residual σ_min M(jω, φ/ω) / (ω + scale) of each (:func:`exact_delay_margin`)."""
    terms = list(zip(mats, hops))
    found = []  # distinct (ω, φ) pairs
    residuals = {}  # (ω, φ) -> σ_min M(jω, φ/ω) / (ω + scale)
    for z in on_circle:
        z = z / abs(z)
        a_z = a0 + sum(a_k * z**m_k for a_k, m_k in terms)
        for lam in eigvals(a_z):
            if abs(lam.real) > 1e-4 * scale:
                continue
            theta, lam = _polish_on_circle(a0, mats, hops, float(np.angle(z)), lam, scale)
            omega, z_c = float(lam.imag), np.exp(1j * theta)
            if omega < 0.0:
                omega, z_c = -omega, z_c.conjugate()
            if omega <= 1e-8 * scale:
                continue
            phi = float(np.mod(-np.angle(z_c), 2.0 * np.pi))
            sigma = svd(characteristic_matrix(a0, terms, 1j * omega, phi / omega), compute_uv=False)[-1]
            new = all(abs(omega - o) > 1e-8 * omega or abs(phi - p) > 1e-8 for o, p in found)
            if sigma <= 1e-9 * (omega + scale) and new:
                found.append((omega, phi))
                residuals[(omega, phi)] = float(sigma / (omega + scale))
    return found, residuals


def _crossing_delays(found, tau_max_search):
    """``(τ, ω)`` of every branch ``τ = (φ + 2πk)/ω`` up to ``tau_max_search`` (the first of each
    crossing without it), by increasing τ."""
    crossings = []
    for omega, phi in found:
        last = 0 if tau_max_search is None else math.floor((tau_max_search * omega - phi) / (2.0 * np.pi))
        crossings += [((phi + 2.0 * np.pi * k) / omega, omega) for k in range(last + 1)]
    crossings.sort()
    return crossings


def exact_delay_margin(a0, terms, tau_max_search=None):
    """Exact constant-delay margin of ``ẋ = A0 x + Σ_k A_k x(t − m_k τ)``.

    Parameters
    ----------
    a0 : array_like, shape (n, n)
        Undelayed state matrix, 1/s.
    terms : sequence of (array_like (n, n), int)
        ``(A_k, m_k)``: ``A_k`` (1/s) multiplies ``x(t − m_k τ)``, ``m_k`` a positive integer
        (the number of hops of that message).
    tau_max_search : float, optional
        List in ``crossings`` every branch with τ ≤ this, s (stability switches). The margin
        itself does not depend on it.

    Returns
    -------
    DelayMargin

    Notes
    -----
    Chen, Gu & Nett (1995), "A new method for computing delay margins for stability of linear
    delay systems", Systems & Control Letters 26; Gu, Kharitonov & Chen, *Stability of
    Time-Delay Systems* (2003), §2.4. A root ``s = jω`` at delay τ means that, with
    ``z = e^{−jωτ}`` on the unit circle, ``jω`` is an eigenvalue of ``A(z)`` — and, the
    matrices being real, ``−jω`` one of ``A(z̄) = A(1/z)``. So ``A(z) ⊗ I + I ⊗ A(1/z)`` is
    singular: multiplied by ``z^M`` this is a polynomial eigenproblem in z alone, solved exactly
    as the generalised eigenvalues of its block-companion pencil (QZ; the unused infinite
    eigenvalues come from a singular leading coefficient). For each z within 1e-4 of the unit
    circle, the eigenvalues of ``A(z)`` near the imaginary axis are refined by Newton on
    ``Re λ(e^{jθ}) = 0`` along their branch, which brings the residual of M to machine
    precision; ``ω = Im λ`` and ``τ = (φ + 2πk)/ω`` with ``φ = −arg z mod 2π``, k ≥ 0. A
    candidate is kept only if ``σ_min M(jω, τ) ≤ 1e-9 (ω + ||A0|| + Σ||A_k||)``. Frequencies
    below 1e-8 (||A0|| + Σ||A_k||) are dropped: ``s = 0`` is a root only with ``z = 1``, i.e.
    ``A0 + Σ A_k`` singular, which the Hurwitz test has already excluded (the pencil does
    report ``ω = 0`` pairs with ``z ≠ 1``, which are no roots). Every crossing has
    ``|ω| ≤ ||A0|| + Σ||A_k||``. Roots of a retarded system depend continuously on τ, so if
    ``A0 + Σ A_k`` is Hurwitz the smallest crossing τ is the margin, and the root there moves
    right (``root_speed`` ≥ 0); the sign of ``d Re s/dτ`` at (ω, z) is the same on every branch
    k, as in Cooke & van den Driessche (1986).
    """
    a0, mats, hops = _as_system(a0, terms)
    terms = list(zip(mats, hops))
    scale = _scale(a0, mats)
    a_sum = a0 + sum(mats) if mats else a0
    method = "Kronecker-sum pencil in z = e^{-jωτ} (Chen, Gu & Nett 1995)"
    if np.max(eigvals(a_sum).real) >= 0.0:
        return DelayMargin(0.0, math.nan, False, [], math.nan, method)
    if not mats:
        return DelayMargin(math.inf, math.nan, True, [], math.nan, method)

    found, residuals = _crossings(a0, mats, hops, _unit_circle_roots(a0, mats, hops, scale), scale)
    if not found:
        return DelayMargin(math.inf, math.nan, True, [], math.nan, method)
    crossings = _crossing_delays(found, tau_max_search)
    tau_1, omega_1, phi_1 = min((phi / omega, omega, phi) for omega, phi in found)
    return DelayMargin(
        tau_s=float(tau_1),
        omega_rad_s=float(omega_1),
        stable_without_delay=True,
        crossings=crossings,
        root_speed=_root_speed(a0, terms, omega_1, tau_1),
        method=method,
        residual=residuals[(omega_1, phi_1)],
    )


def _cheb(n):
    """Chebyshev extremal nodes ``x_i = cos(iπ/n)`` and differentiation matrix (Trefethen 2000, cheb.m)."""
    x = np.cos(np.pi * np.arange(n + 1) / n)
    c = np.ones(n + 1)
    c[0] = c[-1] = 2.0
    c *= (-1.0) ** np.arange(n + 1)
    dx = x[:, None] - x[None, :]
    d = np.outer(c, 1.0 / c) / (dx + np.eye(n + 1))
    d -= np.diag(d.sum(axis=1))
    return x, d


def _lagrange_row(x, point):
    """Values at ``point`` of the Lagrange basis on the Chebyshev extremal nodes x (barycentric)."""
    hit = np.isclose(x, point, rtol=0.0, atol=1e-14)
    if hit.any():
        return hit.astype(float)
    w = (-1.0) ** np.arange(len(x))
    w[0] *= 0.5
    w[-1] *= 0.5
    t = w / (point - x)
    return t / t.sum()


def rightmost_root(a0, terms, tau, n_nodes=32):
    """Real part of the rightmost characteristic root at the constant single-hop delay τ.

    Parameters
    ----------
    a0 : array_like, shape (n, n)
    terms : sequence of (array_like (n, n), int)
        As :func:`exact_delay_margin`.
    tau : float
        Single-hop delay, s.
    n_nodes : int
        Chebyshev intervals N on the history window [−M τ, 0] (M = max m_k).

    Returns
    -------
    float
        ``max Re s`` over the characteristic roots, 1/s: negative iff exponentially stable, and
        then the decay rate of the slowest mode.

    Notes
    -----
    Breda, Maset & Vermiglio (2005), "Pseudospectral differencing methods for characteristic
    roots of delay differential equations", SIAM J. Sci. Comput. 27. The infinitesimal
    generator of the solution semigroup acts on the history φ on [−Mτ, 0] as ``φ ↦ φ'`` with
    the domain condition ``φ'(0) = A0 φ(0) + Σ A_k φ(−m_k τ)``; collocating φ at N + 1
    Chebyshev nodes gives an ``n(N + 1)`` matrix whose rightmost eigenvalues converge
    spectrally to the rightmost roots. The accuracy depends on ``|ω| M τ`` of the rightmost
    root: N = 32 gives about machine precision where it is below 10 (as in this module's tests);
    for longer windows compare with 2N.
    """
    a0, mats, hops = _as_system(a0, terms)
    n = a0.shape[0]
    if tau == 0.0 or not mats:
        return float(np.max(eigvals(a0 + sum(mats) if mats else a0).real))
    h = max(hops) * tau
    x, d = _cheb(n_nodes)
    gen = np.kron(2.0 / h * d, np.eye(n))
    gen[:n, :] = 0.0
    gen[:n, :n] = a0
    for a_k, m_k in zip(mats, hops):
        gen[:n, :] += np.kron(_lagrange_row(x, 1.0 - 2.0 * m_k * tau / h)[None, :], a_k)
    return float(np.max(eigvals(gen).real))


def simulate_dde(a0, terms, tau, x0, t_final, dt):
    """Fixed-step RK4 solution with the constant history ``x(θ) = x0`` for θ ≤ 0.

    Parameters
    ----------
    a0, terms
        The system ``(n, n)`` and its delayed terms, as :func:`exact_delay_margin`.
    tau : float
        Constant single-hop delay, s; ``tau / dt`` must be a positive integer.
    x0 : array_like, shape (n,)
    t_final : float
        s.
    dt : float
        Step, s.

    Returns
    -------
    t : ndarray, shape (K + 1,)
        s.
    x : ndarray, shape (K + 1, n)

    Notes
    -----
    The delayed states fall on stored steps at the RK4 stages at t and t + dt; at t + dt/2
    they come from the cubic Hermite interpolant of the stored states and derivatives,
    ``(x_a + x_b)/2 + dt (f_a − f_b)/8``, so the scheme keeps fourth order away from the
    derivative jumps at t = m_k τ (Bellen & Zennaro, *Numerical Methods for Delay
    Differential Equations*, 2003, §4).
    """
    a0, mats, hops = _as_system(a0, terms)
    lag = round(tau / dt)
    if lag < 1 or not math.isclose(lag * dt, tau, rel_tol=1e-9):
        raise ValueError(f"tau / dt must be a positive integer, got {tau / dt}")
    steps = int(round(t_final / dt))
    shifts = [m_k * lag for m_k in hops]
    pad = max(shifts, default=0)
    x = np.empty((pad + steps + 1, a0.shape[0]))
    f = np.zeros_like(x)  # right derivative at each stored step; zero on the constant history
    x[: pad + 1] = np.asarray(x0, dtype=float)

    def hermite_mid(j):
        # On [−dt, 0] the history is constant: its derivative at 0⁻ is 0, not f[pad].
        return x[j] if j + 1 <= pad else 0.5 * (x[j] + x[j + 1]) + dt / 8.0 * (f[j] - f[j + 1])

    zero = np.zeros(a0.shape[0])
    for i in range(pad, pad + steps):
        d0 = sum((a_k @ x[i - s] for a_k, s in zip(mats, shifts)), zero)
        dm = sum((a_k @ hermite_mid(i - s) for a_k, s in zip(mats, shifts)), zero)
        d1 = sum((a_k @ x[i + 1 - s] for a_k, s in zip(mats, shifts)), zero)
        k1 = a0 @ x[i] + d0
        f[i] = k1
        k2 = a0 @ (x[i] + 0.5 * dt * k1) + dm
        k3 = a0 @ (x[i] + 0.5 * dt * k2) + dm
        k4 = a0 @ (x[i] + dt * k3) + d1
        x[i + 1] = x[i] + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    t = dt * np.arange(steps + 1)
    return t, x[pad:]


def leader_follower_error_system(a, b, k, hops, protocol, weights=None):
    """Tracking-error system ``η_i = x_i − x_0`` of leader–follower consensus with relayed messages.

    Parameters
    ----------
    a : array_like, shape (n, n)
        Per-agent (per-axis) state matrix; the leader runs ``ẋ0 = a x0``.
    b : array_like, shape (n, p)
    k : array_like, shape (p, n)
        Gain K.
    hops : array_like of int, shape (N, N + 1)
        ``hops[i, j]``: number of hops from agent j to follower i (agent 0 is the leader,
        follower i is agent i + 1); 0 = not heard (and on the follower's own column).
    protocol : {"law3", "classical"}
        ``"law3"``: ``u_i = K Σ_j w_ij (x_j(t − m_ji τ) − x_i(t))`` (paper eq. 3, own state
        current); ``"classical"``: ``u_i = K Σ_j w_ij (x_j(t − m_ji τ) − x_i(t − m_ji τ))``.
        The sum runs over every agent heard, leader included.
    weights : array_like, shape (N, N + 1), optional
        ``w_ij``; 1 for every agent heard when omitted.

    Returns
    -------
    a0 : ndarray, shape (nN, nN)
    terms : list of (ndarray (nN, nN), int)
        One ``(A_m, m)`` per hop count m present with a nonzero matrix, m increasing. Error
        state stacked follower by follower.

    Notes
    -----
    With ``G_m[i, j] = w_ij`` if follower i hears follower j over m hops, ``deg_m[i]`` the
    weight i receives over m hops (leader included) and ``deg = Σ_m deg_m``, the leader's
    error being zero:
    law (3): ``A0 = I ⊗ a − diag(deg) ⊗ bK``, ``A_m = G_m ⊗ bK``;
    classical: ``A0 = I ⊗ a``, ``A_m = (G_m − diag(deg_m)) ⊗ bK``.
    """
    if protocol not in PROTOCOLS:
        raise ValueError(f"protocol must be one of {PROTOCOLS}, got {protocol!r}")
    a, b, k = (np.atleast_2d(np.asarray(v, dtype=float)) for v in (a, b, k))
    hops = np.asarray(hops, dtype=int)
    n_f = hops.shape[0]
    if hops.shape != (n_f, n_f + 1) or np.any(hops[np.arange(n_f), np.arange(1, n_f + 1)] != 0):
        raise ValueError("hops must be (N, N + 1) with a zero on each follower's own column")
    w = (hops > 0).astype(float) if weights is None else np.asarray(weights, dtype=float) * (hops > 0)
    bk = b @ k
    eye = np.eye(n_f)
    a0 = np.kron(eye, a)
    if protocol == "law3":
        a0 = a0 - np.kron(np.diag(w.sum(axis=1)), bk)
    terms = []
    for m in range(1, int(hops.max(initial=0)) + 1):
        w_m = w * (hops == m)
        g_m = w_m[:, 1:]
        coupling = g_m if protocol == "law3" else g_m - np.diag(w_m.sum(axis=1))
        if np.any(coupling != 0.0):
            terms.append((np.kron(coupling, bk), m))
    return a0, terms


# --- public name (coopsat.design) ----------------------------------------------------------------


def delay_margin(
    a0: ArrayLike, terms: Sequence[tuple[ArrayLike, int]], *, tau_max_search: float | None = None
) -> DelayMargin:
    """Exact constant-delay margin of ``ẋ = A0 x + Σ_k A_k x(t − m_k τ)`` (``coopsat.design``).

    Parameters as :func:`exact_delay_margin` (``tau_max_search`` keyword-only).

    Returns
    -------
    DelayMargin
        ``tau_s`` = τ* (s; inf when stable for every delay, 0 when unstable without delay),
        ``omega_rad_s`` of the crossing root, and its proof: ``stable_without_delay``,
        ``residual`` (relative σ_min of the characteristic matrix at (jω*, τ*)),
        ``root_speed`` (d Re s/dτ ≥ 0), ``crossings``, ``method``.

    Raises
    ------
    ValueError
        Multiples that are not positive integers, or a singular Kronecker-sum pencil.

    Notes
    -----
    :func:`exact_delay_margin` (Chen, Gu & Nett 1995), under its public name. For the scalar
    ``ẋ = −k x(t − τ)`` the margin is ``π/(2k)`` at ``ω = k``.
    """
    return exact_delay_margin(a0, terms, tau_max_search)
