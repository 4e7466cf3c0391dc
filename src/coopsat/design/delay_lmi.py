"""Delay-dependent stability by an LMI: one certificate for every delay up to a bound (SPEC §3).

Delay-dependent stability (:func:`certify_delay_bound`) concerns the retarded system

    ẋ(t) = A0 x(t) + Σ_k A_k x(t − m_k d(t)),   0 ≤ d(t) ≤ h,

with d(t) arbitrary (piecewise continuous, no bound on its rate) and multipliers m_k > 0: a
message relayed over m hops arrives m·d(t) late (SPEC §3, m_k ∈ {1, 2}). Terms with equal
multipliers share a delayed state and are summed; distinct multipliers are distinct delays
τ_k(t) = m_k d(t) ∈ [0, h_k], h_k = m_k h, treated as independent — sound, and conservative
because the true delays move together.

Condition (Jensen inequality with the reciprocally convex combination; Park, Ko & Jeong 2011,
Theorem 1, extended to several delays and to a decay rate α). With

    V = xᵀ P x + Σ_k ∫_{t−h_k}^t e^{α(s−t)} xᵀ Q_k x ds
              + Σ_k h_k ∫_{−h_k}^0 ∫_{t+θ}^t e^{α(s−t)} ẋᵀ R_k ẋ ds dθ,

ξ = [x; x(t−τ_1); x(t−h_1); …; x(t−τ_N); x(t−h_N)], ẋ = F ξ, F = A0 E_0 + Σ_k A_k E_τk
(E_· selects a block of ξ), c_k = e^{−α h_k}, Γ_k = [E_0 − E_τk; E_τk − E_hk]: if

    P ≻ 0,  Q_k ≻ 0,  R_k ≻ 0,  [[R_k, X_k], [X_kᵀ, R_k]] ≻ 0,
    Φ = He(E_0ᵀ P F) + α E_0ᵀ P E_0
        + Σ_k [E_0ᵀ Q_k E_0 − c_k E_hkᵀ Q_k E_hk + h_k² Fᵀ R_k F
               − c_k Γ_kᵀ [[R_k, X_k], [X_kᵀ, R_k]] Γ_k] ≺ 0,

then V̇ + α V ≤ ξᵀ Φ ξ < 0 for every delay with 0 ≤ τ_k(t) ≤ h_k, so V(t) ≤ V(0) e^{−αt} and
‖x(t)‖ ≤ √(V(0)/λ_min(P)) e^{−αt/2}. Jensen's inequality bounds h_k ∫_{t−τ}^t ẋᵀRẋ by
(h_k/τ) ζ₁ᵀRζ₁ and the rest of the interval likewise; the reciprocally convex combination
removes the dependence on τ. The functional has no term with a moving limit, so no bound on
ḋ is needed. The Wirtinger-based inequality (Seuret & Gouaisbaut 2013) adds two integral
states per delay; with this functional it returned the same delay bounds, to the bisection
tolerance, on the double-integrator leader–follower systems of the tests (one follower,
classical; two followers, both protocols; three gains each) at about ten times the solve
time, so the Jensen form is the one kept.

The searches for the largest certified delay bound and decay rate are in
:mod:`coopsat.design.delay_bounds`, the gain search in :mod:`coopsat.design.delay_gain`.

The paper's own LMI (eq. 7) has a zero diagonal block beside nonzero off-diagonal blocks and
can hold only if PS = 0 (SPEC §3); it is not used.

References
----------
K. Gu, "An integral-inequality approach to robust stability of time-delay systems", Proc.
39th IEEE CDC, 2000 (Jensen's inequality in this form).
P. Park, J. W. Ko, C. Jeong, "Reciprocally convex approach to stability of systems with
time-varying delays", Automatica 47(1):235–238, 2011.
A. Seuret, F. Gouaisbaut, "Wirtinger-based integral inequality: application to time-delay
systems", Automatica 49(9):2860–2866, 2013.
S. Mondié, V. L. Kharitonov, "Exponential estimates for retarded time-delay systems: an LMI
approach", IEEE TAC 50(2):268–273, 2005 (the e^{α(s−t)} weighting).
"""

import math
from dataclasses import dataclass, fields

import numpy as np

from coopsat.design.lmi import DEFAULT_SOLVERS, RTOL, LMIProgram, LMIResult, MatrixInequality

CONDITION = (
    "Lyapunov–Krasovskii functional with exponential weighting, Jensen inequality and "
    "reciprocally convex combination (Park, Ko & Jeong 2011, Thm 1), one delay "
    "τ_k = m_k d(t) ∈ [0, m_k h] per multiplier, any rate of variation"
)
REFERENCE = (
    "P. Park, J. W. Ko, C. Jeong, Automatica 47(1):235–238, 2011; K. Gu, Proc. 39th IEEE CDC, "
    "2000; S. Mondié, V. L. Kharitonov, IEEE TAC 50(2):268–273, 2005"
)


@dataclass(frozen=True)
class DelayLMIResult(LMIResult):
    """:class:`LMIResult` of the delay condition, with what it was asked.

    Attributes
    ----------
    h : float
        Bound on d(t), s: delays ``m_k d(t) ∈ [0, m_k h]``.
    alpha : float
        Decay rate of V, 1/s: ``V(t) ≤ V(0) e^{−αt}`` (the state decays at α/2).
    multipliers : tuple of float
        The distinct m_k, increasing (one delay each).
    condition : str
        The condition solved (:data:`CONDITION`).
    """

    h: float
    alpha: float
    multipliers: tuple
    condition: str



def as_delay_system(a0, terms):
    """Validated ``(A0, multipliers, matrices)``; terms with equal multipliers are summed."""
    a0 = np.atleast_2d(np.asarray(a0, dtype=float))
    n = a0.shape[0]
    if a0.shape != (n, n):
        raise ValueError(f"a0 must be square, got shape {a0.shape}")
    grouped = {}
    for a_k, m_k in terms:
        m_k = float(m_k)
        if not (math.isfinite(m_k) and m_k > 0.0):
            raise ValueError(f"delay multipliers must be positive, got {m_k}")
        a_k = np.atleast_2d(np.asarray(a_k, dtype=float))
        if a_k.shape != (n, n):
            raise ValueError(f"delayed term for m = {m_k:g} has shape {a_k.shape}, expected {(n, n)}")
        grouped[m_k] = grouped.get(m_k, 0.0) + a_k
    mults = tuple(sorted(grouped))
    mats = [grouped[m] for m in mults]
    if not all(np.all(np.isfinite(m)) for m in [a0, *mats]):
        raise ValueError("system matrices must be finite")
    return a0, mults, mats


def nonnegative(name, value):
    """``value`` as a float, or a ValueError naming ``name`` unless it is finite and ≥ 0."""
    value = float(value)
    if not (math.isfinite(value) and value >= 0.0):
        raise ValueError(f"{name} must be finite and ≥ 0, got {value}")
    return value


class DelayProgram:
    """The delay condition for one structure (n states, given multipliers), in DPP form.

    ``h_k² Fᵀ R_k F`` is written ``Σ_{a≤b} R_k[a, b] C_ab`` with parameters
    ``C_ab = h_k² (f_a f_bᵀ + f_b f_aᵀ)`` (``f_a`` row a of F; halved on the diagonal), so the
    data enter only through parameters and cvxpy compiles the problem once.
    """

    def __init__(self, n, multipliers):
        import cvxpy as cp

        self.n, self.multipliers = n, tuple(multipliers)
        nd = len(self.multipliers)
        d = n * (1 + 2 * nd)
        eye = np.eye(d)

        def sel(i):
            return eye[i * n : (i + 1) * n]

        e0 = sel(0)
        self.f = cp.Parameter((n, d), name="F")
        self.alpha = cp.Parameter(nonneg=True, name="alpha")
        self.decay = [cp.Parameter(nonneg=True, name=f"c{k}") for k in range(nd)]
        self.pairs = [(a, b) for a in range(n) for b in range(a, n)]
        self.outer = [[cp.Parameter((d, d), symmetric=True) for _ in self.pairs] for _ in range(nd)]
        p = cp.Variable((n, n), symmetric=True, name="P")
        variables = {"P": p}
        pf = e0.T @ p @ self.f
        phi = pf + pf.T + self.alpha * (e0.T @ p @ e0)
        ineqs = [MatrixInequality("P", p, ">")]
        traces = cp.trace(p)
        for k, m in enumerate(self.multipliers):
            tag = f"m={m:g}"
            q = cp.Variable((n, n), symmetric=True, name=f"Q[{tag}]")
            r = cp.Variable((n, n), symmetric=True, name=f"R[{tag}]")
            x = cp.Variable((n, n), name=f"X[{tag}]")
            variables |= {f"Q[{tag}]": q, f"R[{tag}]": r, f"X[{tag}]": x}
            e_tau, e_h = sel(1 + 2 * k), sel(2 + 2 * k)
            gamma = np.vstack([e0 - e_tau, e_tau - e_h])
            rcc = cp.bmat([[r, x], [x.T, r]])
            phi = (
                phi
                + e0.T @ q @ e0
                - self.decay[k] * (e_h.T @ q @ e_h)
                - self.decay[k] * (gamma.T @ rcc @ gamma)
                + sum(r[a, b] * c for (a, b), c in zip(self.pairs, self.outer[k]))
            )
            ineqs += [
                MatrixInequality(f"Q[{tag}]", q, ">"),
                MatrixInequality(f"R[{tag}]", r, ">"),
                MatrixInequality(f"RCC[{tag}]", rcc, ">"),
            ]
            traces = traces + cp.trace(q) + cp.trace(r)
        ineqs.append(MatrixInequality("dV", phi, "<"))
        self.program = LMIProgram(ineqs, variables, normalization=traces)

    def certify(self, a0, mats, h, alpha, solvers, rtol):
        n, nd = self.n, len(self.multipliers)
        f = np.zeros((n, n * (1 + 2 * nd)))
        f[:, :n] = a0
        for k, a_k in enumerate(mats):
            f[:, n * (1 + 2 * k) : n * (2 + 2 * k)] = a_k
        self.f.value = f
        self.alpha.value = alpha
        for k, m in enumerate(self.multipliers):
            h_k = m * h
            self.decay[k].value = math.exp(-alpha * h_k)
            for (a, b), c in zip(self.pairs, self.outer[k]):
                o = np.outer(f[a], f[b])
                c.value = h_k**2 * (o + o.T) * (0.5 if a == b else 1.0)
        base = self.program.solve(solvers, rtol)
        return DelayLMIResult(
            **{fl.name: getattr(base, fl.name) for fl in fields(base)},
            h=float(h),
            alpha=float(alpha),
            multipliers=self.multipliers,
            condition=CONDITION,
        )


def certify_delay_bound(a0, terms, h, alpha=0.0, solvers=DEFAULT_SOLVERS, rtol=RTOL):
    """Certify ``ẋ = A0 x + Σ_k A_k x(t − m_k d(t))`` for every delay with ``0 ≤ d(t) ≤ h``.

    Parameters
    ----------
    a0 : array_like, shape (n, n)
        1/s.
    terms : sequence of (array_like (n, n), float)
        ``(A_k, m_k)``: ``A_k`` (1/s) multiplies ``x(t − m_k d(t))``, m_k > 0 (hops).
    h : float
        Bound on d(t), s (≥ 0).
    alpha : float
        Decay rate of V to certify, 1/s (≥ 0): ``V(t) ≤ V(0) e^{−αt}``.
    solvers, rtol
        See :meth:`~coopsat.design.lmi.LMIProgram.solve`.

    Returns
    -------
    DelayLMIResult
        Margins named ``"P"``, ``"Q[m=…]"``, ``"R[m=…]"``, ``"RCC[m=…]"`` (the reciprocally
        convex block) and ``"dV"`` (Φ).

    Notes
    -----
    The condition of the module docstring (Park, Ko & Jeong 2011, Thm 1, with Gu's Jensen
    inequality and the exponential weighting of Mondié & Kharitonov 2005).
    """
    h, alpha = nonnegative("h", h), nonnegative("alpha", alpha)
    a0, mults, mats = as_delay_system(a0, terms)
    return DelayProgram(a0.shape[0], mults).certify(a0, mats, h, alpha, solvers, rtol)
