"""Linear-quadratic regulators: the one Riccati solver of the package, and the zero-order hold.

Continuous (``discrete_dt_s`` None): the cost ``J = ∫ xᵀQx + uᵀRu dt`` on ``ẋ = Ax + Bu`` is
minimised by ``u = −Kx``, ``K = R⁻¹BᵀP``, P the stabilising solution of the continuous
algebraic Riccati equation (CARE)

    AᵀP + PA − PBR⁻¹BᵀP + Q = 0.

Sampled (``discrete_dt_s`` = T): the command ``u_k`` is held over each period, so (A, B) are
sampled with a zero-order hold, ``x_{k+1} = Φ x_k + Γ u_k`` (:func:`discretize`), and
``J = Σ x_kᵀQx_k + u_kᵀRu_k`` is minimised by ``u_k = −Kx_k``,
``K = (R + ΓᵀPΓ)⁻¹ΓᵀPΦ``, P the stabilising solution of the discrete equation (DARE)

    ΦᵀPΦ − P − ΦᵀPΓ(R + ΓᵀPΓ)⁻¹ΓᵀPΦ + Q = 0.

Both are solved by SciPy (``solve_continuous_are``, ``solve_discrete_are``: the Schur method
on the Hamiltonian or symplectic pencil, with balancing). The answer is not taken on
SciPy's word: :class:`LQRResult` carries the closed-loop poles (checked inside the stability
region) and the relative residual of the Riccati equation at the returned P.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["LQRResult", "discretize", "lqr"]


@dataclass(frozen=True)
class LQRResult:
    """Result of :func:`lqr`: the gain and the proof that it solves the Riccati equation.

    Attributes
    ----------
    K : ndarray, shape (m, n)
        Gain of ``u = −K x`` (continuous) or ``u_k = −K x_k`` held over the period (sampled);
        units of u per unit of x.
    P : ndarray, shape (n, n)
        Stabilising solution of the CARE (continuous) or the DARE of the sampled system,
        symmetrised; the optimal cost from x₀ is ``x₀ᵀ P x₀`` (units of J).
    poles : ndarray, shape (n,), complex
        Closed-loop poles: eigenvalues of ``A − BK`` (s-plane, 1/s; all with Re < 0) or of
        ``Φ − ΓK`` (z-plane, dimensionless; all with modulus < 1).
    residual : float
        ``‖Riccati(P)‖_F / Σ‖term‖_F``: the Frobenius norm of the Riccati equation's
        left-hand side at P over the sum of the norms of its terms (0 for an exact solution;
        10⁻¹⁶–10⁻¹³ in float64 for well-scaled weights, 10⁻¹¹ for the cartwheel's, which span
        eight decades).
    discrete_dt_s : float or None
        Sample period T of the zero-order hold, s; None for the continuous design.
    """

    K: np.ndarray
    P: np.ndarray
    poles: np.ndarray
    residual: float
    discrete_dt_s: float | None


def _matrix(name: str, value) -> np.ndarray:
    m = np.atleast_2d(np.asarray(value, dtype=float))
    if m.ndim != 2 or not np.all(np.isfinite(m)):
        raise ValueError(f"{name} must be a finite 2-D array, got shape {np.shape(value)}")
    return m


def discretize(a, b, period_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Zero-order-hold discretisation ``x_{k+1} = Φ x_k + Γ u_k``.

    Parameters
    ----------
    a : array_like, shape (n, n)
        State matrix, 1/s.
    b : array_like, shape (n, m)
        Input matrix (units of ẋ per unit of u).
    period_s : float
        Sample period T, s (finite, > 0).

    Returns
    -------
    phi : ndarray, shape (n, n)
        ``e^{AT}``.
    gamma : ndarray, shape (n, m)
        ``∫_0^T e^{As} ds B``.

    Notes
    -----
    Both blocks come from one exponential of the augmented matrix ``[[A, B], [0, 0]] T``
    (Van Loan, 1978). The only zero-order hold of :mod:`coopsat.design`.
    """
    from scipy.linalg import expm

    a, b = _matrix("a", a), _matrix("b", b)
    n, m = b.shape
    if a.shape != (n, n):
        raise ValueError(f"shapes do not match: a {a.shape}, b {b.shape}")
    if not (math.isfinite(period_s) and period_s > 0.0):
        raise ValueError(f"period_s must be finite and > 0, got {period_s}")
    aug = np.zeros((n + m, n + m))
    aug[:n, :n], aug[:n, n:] = a, b
    e = expm(aug * period_s)
    return e[:n, :n], e[:n, n:]



def sampled_noise(a, qc, period_s: float) -> np.ndarray:
    """Process noise over one sample of a system driven by continuous white noise.

    Parameters
    ----------
    a : array_like, shape (n, n)
        State matrix, 1/s.
    qc : array_like, shape (n, n)
        Spectral density of the white noise driving ``ẋ`` (symmetric ⪰ 0), units of x² per s.
    period_s : float
        Sample period T, s (finite, > 0).

    Returns
    -------
    ndarray, shape (n, n)
        ``Q = ∫_0^T e^{As} Qc e^{Aᵀs} ds``, symmetrised.

    Notes
    -----
    Van Loan (1978): ``expm([[−A, Qc], [0, Aᵀ]] T) = [[·, Φ⁻¹Q], [0, Φᵀ]]``, so ``Q = Φ (Φ⁻¹Q)``;
    the noise's counterpart of :func:`discretize`.
    """
    from scipy.linalg import expm

    a, qc = _matrix("a", a), _matrix("qc", qc)
    n = a.shape[0]
    if a.shape != (n, n) or qc.shape != (n, n):
        raise ValueError(f"shapes do not match: a {a.shape}, qc {qc.shape}")
    if not (math.isfinite(period_s) and period_s > 0.0):
        raise ValueError(f"period_s must be finite and > 0, got {period_s}")
    e = expm(np.block([[-a, qc], [np.zeros((n, n)), a.T]]) * period_s)
    q = e[n:, n:].T @ e[:n, n:]
    return 0.5 * (q + q.T)

def _relative(lhs: np.ndarray, terms: tuple[np.ndarray, ...]) -> float:
    scale = sum(float(np.linalg.norm(t)) for t in terms)
    return float(np.linalg.norm(lhs)) / scale if scale > 0.0 else float(np.linalg.norm(lhs))


def _one_line(err: Exception) -> str:
    return " ".join(str(err).split()) or type(err).__name__


def lqr(A, B, Q, R, *, discrete_dt_s: float | None = None) -> LQRResult:
    """Infinite-horizon LQR gain, continuous or sampled with a zero-order hold.

    Parameters
    ----------
    A : array_like, shape (n, n)
        Continuous-time state matrix, 1/s.
    B : array_like, shape (n, m)
        Continuous-time input matrix (units of ẋ per unit of u).
    Q : array_like, shape (n, n)
        State weight, symmetric ⪰ 0 (units of J per unit of x², per second when continuous).
    R : array_like, shape (m, m)
        Input weight, symmetric ≻ 0 (likewise per unit of u²).
    discrete_dt_s : float, optional
        None: the continuous design (CARE). A period T, s: (A, B) are sampled with a
        zero-order hold over T (:func:`discretize`) and the discrete design (DARE) returned;
        Q and R then weigh the samples ``x_k``, ``u_k``.

    Returns
    -------
    LQRResult
        ``K`` (m, n) with ``u = −K x``; ``P`` (n, n); ``poles`` (n,) of ``A − BK`` (s-plane)
        or ``Φ − ΓK`` (z-plane); ``residual`` of the Riccati equation; ``discrete_dt_s``.

    Raises
    ------
    ValueError
        One line: shapes that do not match, a non-finite entry, Q not symmetric, R not
        symmetric positive definite, ``discrete_dt_s`` not finite and > 0, or no stabilising solution (SciPy's
        error, or a closed-loop pole outside the stability region).

    Notes
    -----
    Continuous: ``scipy.linalg.solve_continuous_are(A, B, Q, R)``, ``K = R⁻¹BᵀP``.
    Sampled: ``scipy.linalg.solve_discrete_are(Φ, Γ, Q, R)``, ``K = (R + ΓᵀPΓ)⁻¹ΓᵀPΦ``.
    P is symmetrised before K is formed. Examples: the double integrator ``A = [[0, 1],
    [0, 0]]``, ``B = [[0], [1]]``, Q = I, R = 1 gives ``K = [1, √3]``.
    """
    a, b, q, r = _checked_weights(A, B, Q, R)
    if discrete_dt_s is None:
        return _continuous_lqr(a, b, q, r)
    dt = float(discrete_dt_s)
    if not (math.isfinite(dt) and dt > 0.0):
        raise ValueError(f"lqr: discrete_dt_s must be finite and > 0, got {discrete_dt_s}")
    return _sampled_lqr(a, b, q, r, dt)


def _checked_weights(A, B, Q, R, who="lqr"):
    """(A, B, Q, R) as float matrices of matching shapes, Q and R symmetric, R ≻ 0; else one line
    that begins with ``who``."""
    a, b, q, r = (_matrix(name, v) for name, v in (("A", A), ("B", B), ("Q", Q), ("R", R)))
    n, m = b.shape
    if a.shape != (n, n) or q.shape != (n, n) or r.shape != (m, m):
        raise ValueError(
            f"{who}: shapes do not match: A {a.shape}, B {b.shape}, Q {q.shape}, R {r.shape} "
            f"(expected ({n}, {n}), ({n}, {m}), ({n}, {n}), ({m}, {m}))"
        )
    for name, w in (("Q", q), ("R", r)):
        if not np.allclose(w, w.T, rtol=1e-10, atol=0.0):
            raise ValueError(f"{who}: {name} must be symmetric")
    r_min = float(np.linalg.eigvalsh(0.5 * (r + r.T))[0])
    if not r_min > 0.0:
        raise ValueError(f"{who}: R must be positive definite, its smallest eigenvalue is {r_min:.6g}")
    return a, b, q, r


def _continuous_lqr(a, b, q, r):
    """CARE design (:func:`lqr` with ``discrete_dt_s=None``)."""
    from scipy.linalg import solve_continuous_are

    try:
        p = solve_continuous_are(a, b, q, r)
    except (np.linalg.LinAlgError, ValueError) as err:
        raise ValueError(f"lqr: the continuous Riccati equation has no stabilising solution (scipy: {_one_line(err)})") from None
    p = 0.5 * (p + p.T)
    k = np.linalg.solve(r, b.T @ p)
    poles = np.linalg.eigvals(a - b @ k)
    pbk = p @ b @ k  # P B R⁻¹ Bᵀ P
    residual = _relative(a.T @ p + p @ a - pbk + q, (a.T @ p, p @ a, pbk, q))
    if not np.all(poles.real < 0.0):
        raise ValueError(f"lqr: no stabilising solution: a closed-loop pole lies outside the stability region "
                         f"(max Re = {poles.real.max():.3g} 1/s)")
    return LQRResult(K=k, P=p, poles=poles, residual=residual, discrete_dt_s=None)


def _sampled_lqr(a, b, q, r, dt):
    """ZOH + DARE design (:func:`lqr` with ``discrete_dt_s=dt``)."""
    from scipy.linalg import solve_discrete_are

    phi, gam = discretize(a, b, dt)
    try:
        p = solve_discrete_are(phi, gam, q, r)
    except (np.linalg.LinAlgError, ValueError) as err:
        raise ValueError(f"lqr: the discrete Riccati equation has no stabilising solution (scipy: {_one_line(err)})") from None
    p = 0.5 * (p + p.T)
    k = np.linalg.solve(r + gam.T @ p @ gam, gam.T @ p @ phi)
    poles = np.linalg.eigvals(phi - gam @ k)
    ptp = phi.T @ p @ phi
    cross = phi.T @ p @ gam @ k  # ΦᵀPΓ(R + ΓᵀPΓ)⁻¹ΓᵀPΦ
    residual = _relative(ptp - p - cross + q, (ptp, p, cross, q))
    if not np.all(np.abs(poles) < 1.0):
        raise ValueError(f"lqr: no stabilising solution: a closed-loop pole lies outside the stability region "
                         f"(max |z| = {np.abs(poles).max():.6g})")
    return LQRResult(K=k, P=p, poles=poles, residual=residual, discrete_dt_s=dt)


def steady_kalman(phi, h, q, r) -> tuple[np.ndarray, np.ndarray]:
    """Steady-state covariances of a discrete Kalman filter (the dual of the sampled LQR).

    Parameters
    ----------
    phi : array_like, shape (n, n)
        One step's state transition.
    h : array_like, shape (m, n)
        Measurement matrix.
    q : array_like, shape (n, n)
        Process noise per step, symmetric ⪰ 0.
    r : array_like, shape (m, m)
        Measurement noise, symmetric ≻ 0.

    Returns
    -------
    prior, posterior : ndarray (n, n)
        The covariance before and after a measurement, in the steady state.

    Raises
    ------
    ValueError
        One line, as :func:`lqr`'s (the same checks on the dual problem: Φᵀ, Hᵀ for A, B).

    Notes
    -----
    ``P = scipy.linalg.solve_discrete_are(Φᵀ, Hᵀ, Q, R)`` (the filter's Riccati equation
    ``P = Φ (P − P Hᵀ (H P Hᵀ + R)⁻¹ H P) Φᵀ + Q``); posterior ``P − P Hᵀ (H P Hᵀ + R)⁻¹ H P``.
    """
    from scipy.linalg import solve_discrete_are

    a, b, q, r = _checked_weights(np.asarray(phi, dtype=float).T, np.asarray(h, dtype=float).T, q, r, "steady_kalman")
    try:
        p = solve_discrete_are(a, b, q, r)
    except (np.linalg.LinAlgError, ValueError) as err:
        raise ValueError(f"steady_kalman: the filter's Riccati equation has no stabilising solution (scipy: {_one_line(err)})") from None
    p = 0.5 * (p + p.T)
    hp = b.T @ p
    posterior = p - hp.T @ np.linalg.solve(hp @ b + r, hp)
    return p, 0.5 * (posterior + posterior.T)
