"""Linear matrix inequalities: a certified solve, delay-dependent stability, gain design (SPEC §3).

Every LMI in the project goes through :class:`LMIProgram`: a cvxpy problem whose matrix
inequalities carry names. It is solved with CLARABEL (interior point), falling back to SCS
when CLARABEL fails or reports an inaccurate solution, and the answer is never taken on the
solver's word: each named inequality is rebuilt from the returned numeric values,
symmetrised, and its eigenvalues checked (:func:`check_inequality`). A result is
*certified* only if the solver says ``"optimal"`` and every re-check holds strictly, by the
relative tolerance :data:`RTOL`.

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

Gain design (:func:`design_gain`). The gain K enters the leader–follower error system as
H ⊗ BK (the same K for every follower) and multiplies P, R_k in Φ: bilinear. The usual
convexification (congruence with P⁻¹ and Y = K P⁻¹) needs P⁻¹ = I ⊗ X̄ to recover one K
shared by all followers, which fixes the shape of the certificate and is conservative in a
way that is hard to bound. Instead K is searched directly (Nelder–Mead, a handful of
entries), each evaluation being the exact convex problem for that fixed K; every reported
number is a re-checked certificate for the reported K.

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
S. Boyd, L. El Ghaoui, E. Feron, V. Balakrishnan, *Linear Matrix Inequalities in System and
Control Theory*, SIAM, 1994, §7.2 (the LQR inequality of :func:`lqr_lmi`).
"""

import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import minimize

from coopsat.design.memo import by_value

#: Relative tolerance of the re-check. A strict inequality holds if its margin exceeds
#: ``RTOL`` times the block's spectral norm; a non-strict one if it is not violated by more.
#: Forming a block from the returned values and taking its eigenvalues in float64 errs by
#: about d·ε ≈ 10⁻¹⁴ of the norm (d ≤ 100), so 10⁻⁶ leaves eight orders of magnitude for
#: cancellation among the terms; and it lies above CLARABEL's feasibility tolerance (10⁻⁸),
#: so a solution that meets a strict inequality only to within the solver's tolerance — the
#: closure, not the open set — is rejected.
RTOL = 1e-6

#: Solvers tried in order, with their options. SCS is reached only when CLARABEL fails or
#: reports an inaccurate solution; its answers are re-checked like any other.
DEFAULT_SOLVERS = (("CLARABEL", {}), ("SCS", {"eps_abs": 1e-9, "eps_rel": 1e-9, "max_iters": 5000}))

#: Statuses that are a definite answer: another solver would not change the verdict.
_DEFINITE = ("optimal", "infeasible", "unbounded")

SENSES = ("<", ">", "<=", ">=")

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
class MatrixInequality:
    """A named matrix inequality ``expr ≺ 0`` (``"<"``), ``≻ 0`` (``">"``), ``⪯ 0``, ``⪰ 0``.

    Attributes
    ----------
    name : str
    expr : cvxpy.Expression, shape (d, d)
        Square; it is symmetrised before use, so only its symmetric part matters.
    sense : {"<", ">", "<=", ">="}
    """

    name: str
    expr: object
    sense: str


@dataclass(frozen=True)
class InequalityCheck:
    """Eigenvalue re-check of one matrix inequality on numeric values.

    Attributes
    ----------
    margin : float
        Largest eigenvalue of the symmetric part for ``≺``/``⪯`` (negative when it holds),
        smallest for ``≻``/``⪰`` (positive when it holds); NaN without a value.
    relative_margin : float
        Signed distance from violation over the spectral norm of the block: positive when the
        inequality holds, whatever its sense; 0 for a zero block.
    satisfied : bool
        Strict senses: ``relative_margin > rtol``; non-strict: ``relative_margin ≥ −rtol``.
    """

    margin: float
    relative_margin: float
    satisfied: bool


@dataclass(frozen=True)
class LMIResult:
    """Outcome of :meth:`LMIProgram.solve`.

    Attributes
    ----------
    certified : bool
        Status ``"optimal"`` and every named inequality re-checked as satisfied.
    status : str
        cvxpy status of the returned attempt (``"optimal"``, ``"optimal_inaccurate"``,
        ``"infeasible"``, …, or ``"solver_error"``).
    solver : str
        Solver of the returned attempt.
    margins : dict of str to float
        Per inequality, :attr:`InequalityCheck.margin` (NaN without values).
    relative_margins : dict of str to float
        Per inequality, :attr:`InequalityCheck.relative_margin`.
    variables : dict of str to ndarray
        Numeric values of the named variables (empty without values).
    objective_value : float
        Objective at the returned point: the common margin t for a feasibility problem
        (NaN without values).
    attempts : tuple of (str, str)
        ``(solver, status)`` of every solver tried, in order.
    rtol : float
        Relative tolerance the re-check used.
    """

    certified: bool
    status: str
    solver: str
    margins: dict
    relative_margins: dict
    variables: dict
    objective_value: float
    attempts: tuple
    rtol: float


def check_inequality(matrix, sense, rtol=RTOL):
    """Re-check ``matrix`` (sense) 0 by the eigenvalues of its symmetric part.

    Parameters
    ----------
    matrix : array_like, shape (d, d)
    sense : {"<", ">", "<=", ">="}
    rtol : float
        See :data:`RTOL`.

    Returns
    -------
    InequalityCheck
    """
    if sense not in SENSES:
        raise ValueError(f"sense must be one of {SENSES}, got {sense!r}")
    m = np.atleast_2d(np.asarray(matrix, dtype=float))
    if m.ndim != 2 or m.shape[0] != m.shape[1]:
        raise ValueError(f"a matrix inequality needs a square matrix, got shape {m.shape}")
    if not np.all(np.isfinite(m)):
        return InequalityCheck(math.nan, math.nan, False)
    eig = np.linalg.eigvalsh(0.5 * (m + m.T))
    scale = float(np.max(np.abs(eig)))
    upper = sense in ("<", "<=")
    margin = float(eig[-1] if upper else eig[0])
    relative = (-margin if upper else margin) / scale if scale > 0.0 else 0.0
    satisfied = relative > rtol if sense in ("<", ">") else relative >= -rtol
    return InequalityCheck(margin, relative, bool(satisfied))


def _symmetric(expr):
    return 0.5 * (expr + expr.T)


class LMIProgram:
    """A cvxpy problem with named matrix inequalities, built once and solved many times.

    Parameters
    ----------
    inequalities : sequence of MatrixInequality
    variables : dict of str to cvxpy.Variable
        The decision variables whose values the result reports.
    objective : cvxpy.Minimize or cvxpy.Maximize, optional
        Without one the program is a feasibility problem posed as: maximise the common margin
        t with every strict inequality shifted by it (``expr ⪯ −t I``, ``expr ⪰ t I``) and
        every non-strict one as given. With one, strict inequalities are imposed in closed
        form and only the re-check decides strictness.
    normalization : cvxpy.Expression, optional
        Scalar, constrained ``≤ 1``; required without an objective. The strict inequalities
        of a stability test are homogeneous in the variables, so without it the margin is
        unbounded; a trace bound on the certificate's matrices keeps the problem well
        conditioned and makes t comparable between solves.
    constraints : sequence of cvxpy.Constraint, optional
        Extra constraints (not re-checked).

    Notes
    -----
    cvxpy Parameters inside the expressions are set by the caller before :meth:`solve`; a
    problem that follows the DPP rules is then compiled once. Not safe to share between
    threads.
    """

    def __init__(self, inequalities, variables, objective=None, normalization=None, constraints=()):
        import cvxpy as cp

        self.inequalities = tuple(inequalities)
        for ineq in self.inequalities:
            if ineq.sense not in SENSES:
                raise ValueError(f"inequality {ineq.name!r}: sense must be one of {SENSES}, got {ineq.sense!r}")
        if len({ineq.name for ineq in self.inequalities}) != len(self.inequalities):
            raise ValueError("inequality names must be unique")
        self.variables = dict(variables)
        cons = list(constraints)
        if objective is None:
            if normalization is None:
                raise ValueError("a feasibility problem needs a normalization (a scalar expression bounded by 1)")
            t = cp.Variable(name="margin")
            shift = {"<": -t, ">": t, "<=": 0.0, ">=": 0.0}
            cons.append(normalization <= 1.0)
            objective = cp.Maximize(t)
        else:
            shift = dict.fromkeys(SENSES, 0.0)
        for ineq in self.inequalities:
            sym = _symmetric(ineq.expr)
            rhs = shift[ineq.sense] * np.eye(sym.shape[0])
            cons.append(sym << rhs if ineq.sense in ("<", "<=") else sym >> rhs)
        self.problem = cp.Problem(objective, cons)

    def solve(self, solvers=DEFAULT_SOLVERS, rtol=RTOL):
        """Solve (with fall-back) and re-check every named inequality.

        Parameters
        ----------
        solvers : sequence of (str, dict)
            Solver names and options, tried in order until one is certified or gives a
            definite answer (optimal, infeasible, unbounded).
        rtol : float
            Re-check tolerance, see :data:`RTOL`.

        Returns
        -------
        LMIResult
            The certified attempt if any; otherwise the last attempt that returned values,
            or the last attempt.
        """
        import cvxpy as cp

        attempts, kept = [], None
        for name, options in solvers:
            with warnings.catch_warnings():
                warnings.filterwarnings("ignore", message="Solution may be inaccurate")
                try:
                    self.problem.solve(solver=name, **options)
                    status = self.problem.status
                except cp.error.SolverError:
                    status = "solver_error"
            attempts.append((name, status))
            result = self._result(name, status, tuple(attempts), rtol)
            if result.certified:
                return result
            if kept is None or result.variables or not kept.variables:
                kept = result
            if status in _DEFINITE:
                break
        return LMIResult(**{f.name: getattr(kept, f.name) for f in fields(kept)} | {"attempts": tuple(attempts)})

    def _result(self, solver, status, attempts, rtol):
        has_values = status in ("optimal", "optimal_inaccurate") and all(
            v.value is not None for v in self.variables.values()
        )
        margins, relative, ok = {}, {}, has_values
        for ineq in self.inequalities:
            if has_values:
                check = check_inequality(ineq.expr.value, ineq.sense, rtol)
            else:
                check = InequalityCheck(math.nan, math.nan, False)
            margins[ineq.name] = check.margin
            relative[ineq.name] = check.relative_margin
            ok = ok and check.satisfied
        values = {k: np.array(v.value, dtype=float) for k, v in self.variables.items()} if has_values else {}
        objective = float(self.problem.value) if has_values else math.nan
        return LMIResult(
            certified=bool(ok and status == "optimal"),
            status=status,
            solver=solver,
            margins=margins,
            relative_margins=relative,
            variables=values,
            objective_value=objective,
            attempts=attempts,
            rtol=rtol,
        )


def solve_lmis(inequalities, variables, objective=None, normalization=None, constraints=(), solvers=DEFAULT_SOLVERS, rtol=RTOL):
    """Build an :class:`LMIProgram` and solve it once; see there for the parameters.

    Returns
    -------
    LMIResult
    """
    return LMIProgram(inequalities, variables, objective, normalization, constraints).solve(solvers, rtol)


# --- delay-dependent stability -----------------------------------------------------------------


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


@dataclass(frozen=True)
class CertifiedBound:
    """Largest certified value found by a bisection (a delay bound or a decay rate).

    Attributes
    ----------
    value : float
        Largest value certified (h in s, or α in 1/s); 0 when none was.
    result : DelayLMIResult
        The certificate at ``value``; when nothing was certified, the failed attempt at the
        smallest value tried.
    upper : float
        Smallest value tried that was not certified (``inf`` when the search cap was).
    n_solves : int
        LMI problems solved.
    """

    value: float
    result: DelayLMIResult
    upper: float
    n_solves: int


def _as_delay_system(a0, terms):
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


def _nonnegative(name, value):
    value = float(value)
    if not (math.isfinite(value) and value >= 0.0):
        raise ValueError(f"{name} must be finite and ≥ 0, got {value}")
    return value


def _time_scale(a0, mats):
    """``‖A0‖ + Σ‖A_k‖`` (1/s): sets the first guesses of the searches."""
    s = float(np.linalg.norm(a0, 2) + sum(np.linalg.norm(m, 2) for m in mats))
    return s if s > 0.0 else 1.0


class _DelayProgram:
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
        See :meth:`LMIProgram.solve`.

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
    h, alpha = _nonnegative("h", h), _nonnegative("alpha", alpha)
    a0, mults, mats = _as_delay_system(a0, terms)
    return _DelayProgram(a0.shape[0], mults).certify(a0, mats, h, alpha, solvers, rtol)


def _largest_certified(certify_at, lo, lo_result, hi, cap, tol, failed=None):
    """Bisection for the largest certified value.

    ``lo`` is certified (``lo_result``) or, with ``lo_result`` None, unknown; ``hi`` is the
    first guess: while certified it doubles up to ``cap``, then [lo, hi] is halved until
    ``hi − lo ≤ tol``. ``failed``, if given, is a failed result already known at ``hi``.
    """
    n = 0
    while failed is None:
        res = certify_at(hi)
        n += 1
        if not res.certified:
            failed = res
            break
        lo, lo_result = hi, res
        if hi >= cap:
            return CertifiedBound(lo, lo_result, math.inf, n)
        hi = min(2.0 * hi, cap)
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        res = certify_at(mid)
        n += 1
        if res.certified:
            lo, lo_result = mid, res
        else:
            hi, failed = mid, res
    if lo_result is None:
        return CertifiedBound(0.0, failed, hi, n)
    return CertifiedBound(lo, lo_result, hi, n)


#: The searches stop doubling at this many times the system's time scale 1/(‖A0‖ + Σ‖A_k‖).
_CAP_FACTOR = 1e3


def _delay_search(program, a0, mats, alpha, h_hi, tol, solvers, rtol, failed_at_hi=None):
    def at(h):
        return program.certify(a0, mats, h, alpha, solvers, rtol)

    scale = _time_scale(a0, mats)
    if h_hi is None:
        return _largest_certified(at, 0.0, None, 1.0 / scale, _CAP_FACTOR / scale, tol)
    return _largest_certified(at, 0.0, None, h_hi, h_hi, tol, failed_at_hi)


def _decay_search(program, a0, mats, h, alpha_hi, tol, solvers, rtol):
    def at(alpha):
        return program.certify(a0, mats, h, alpha, solvers, rtol)

    zero = at(0.0)
    if not zero.certified:
        return CertifiedBound(0.0, zero, 0.0, 1)
    scale = _time_scale(a0, mats)
    cap = _CAP_FACTOR * scale if alpha_hi is None else alpha_hi
    found = _largest_certified(at, 0.0, zero, scale if alpha_hi is None else alpha_hi, cap, tol)
    return CertifiedBound(found.value, found.result, found.upper, found.n_solves + 1)


@by_value
def max_certified_delay(a0, terms, alpha=0.0, h_hi=None, tol=1e-4, solvers=DEFAULT_SOLVERS, rtol=RTOL):
    """Largest h that :func:`certify_delay_bound` certifies (bisection).

    Parameters
    ----------
    a0, terms
        As :func:`certify_delay_bound`.
    alpha : float
        Decay rate certified alongside, 1/s.
    h_hi : float, optional
        Upper end of the search, s. Without it the search starts at 1/(‖A0‖ + Σ‖A_k‖) and
        doubles while certified, up to 1000 times that (then ``upper`` is ``inf``).
    tol : float
        Bisection stops when the bracket is narrower than this, s.
    solvers, rtol
        See :meth:`LMIProgram.solve`.

    Returns
    -------
    CertifiedBound
        ``value`` = h* (0 if no h was certified).

    Notes
    -----
    Bisection assumes the LMI is feasible on an interval [0, h*]. Stability itself is
    monotone (a certificate at h covers every d(t) ≤ h' < h), but monotonicity of this LMI in
    h is not proven here; the unit tests check it on a grid below h*. Whatever happens, the
    value returned has been certified.
    """
    a0, mults, mats = _as_delay_system(a0, terms)
    if h_hi is not None and not (math.isfinite(h_hi) and h_hi > 0.0):
        raise ValueError(f"h_hi must be finite and > 0, got {h_hi}")
    program = _DelayProgram(a0.shape[0], mults)
    return _delay_search(program, a0, mats, _nonnegative("alpha", alpha), h_hi, tol, solvers, rtol)


@by_value
def max_decay_rate(a0, terms, h, alpha_hi=None, tol=1e-4, solvers=DEFAULT_SOLVERS, rtol=RTOL):
    """Largest α (decay rate of V, 1/s) certified at delay bound h (bisection).

    Parameters
    ----------
    a0, terms, h
        As :func:`certify_delay_bound`.
    alpha_hi : float, optional
        Upper end of the search, 1/s. Without it the search starts at ‖A0‖ + Σ‖A_k‖ and
        doubles while certified, up to 1000 times that.
    tol : float
        Bracket width at which bisection stops, 1/s.
    solvers, rtol
        See :meth:`LMIProgram.solve`.

    Returns
    -------
    CertifiedBound
        ``value`` = α*; 0 with an uncertified ``result`` when h itself is not certified.

    Notes
    -----
    The condition is monotone in α: a certificate at α holds unchanged at any α' < α (the
    term α P shrinks and every ``c_k`` grows, multiplying positive definite blocks with a
    minus sign), so the bisection is exact up to ``tol``. The state decays at α/2.
    """
    a0, mults, mats = _as_delay_system(a0, terms)
    program = _DelayProgram(a0.shape[0], mults)
    return _decay_search(program, a0, mats, _nonnegative("h", h), alpha_hi, tol, solvers, rtol)


# --- gain design -------------------------------------------------------------------------------


@dataclass(frozen=True)
class DelayGainDesign:
    """Result of :func:`design_gain`.

    Attributes
    ----------
    gain : ndarray, shape k0.shape
        The gain K found.
    h : float
        Delay bound certified with it, s.
    alpha : float
        Decay rate of V certified with it at ``h``, 1/s.
    result : DelayLMIResult
        The certificate (certified) at ``(h, alpha)``.
    objective : {"delay bound", "decay rate"}
        What was maximised.
    condition, reference : str
        The condition used and where it comes from.
    solver, status : str
        Of the certificate.
    n_evaluations : int
        Gains evaluated (each a bisection over convex problems).
    """

    gain: np.ndarray
    h: float
    alpha: float
    result: DelayLMIResult
    objective: str
    condition: str
    reference: str
    solver: str
    status: str
    n_evaluations: int


def design_gain(
    system_of_gain,
    h,
    k0,
    bounds,
    alpha=0.0,
    starts=(),
    max_evaluations=100,
    tol=1e-3,
    solvers=DEFAULT_SOLVERS,
    rtol=RTOL,
):
    """Static gain maximising the certified delay bound, or the decay rate at a given bound.

    Parameters
    ----------
    system_of_gain : callable
        ``system_of_gain(K) -> (a0, terms)``, the closed-loop (error) system for gain K in the
        form of :func:`certify_delay_bound`.
    h : float or None
        None: maximise the certified delay bound h* at decay rate ``alpha``. A number (s):
        maximise the decay rate α certified at this delay bound.
    k0 : array_like, shape (p, n)
        Starting gain; its shape is the gain's.
    bounds : array_like, shape (p·n, 2)
        ``(low, high)`` per gain entry (row-major order); the search stays inside.
    alpha : float
        Decay rate required while maximising h*, 1/s (ignored when h is given).
    starts : sequence of array_like, shape (p, n)
        Further starting gains.
    max_evaluations : int
        Gains evaluated at most, over all starts.
    tol : float
        Bisection tolerance of each evaluation (s, or 1/s).
    solvers, rtol
        See :meth:`LMIProgram.solve`.

    Returns
    -------
    DelayGainDesign

    Raises
    ------
    ValueError
        When no gain tried is certified at the requested h (the message gives the largest
        delay bound certified by any gain tried), or, maximising h*, for any h > 0.

    Notes
    -----
    Derivative-free search (bounded Nelder–Mead from each start, first simplex a tenth of the
    box wide) over K; each evaluation solves the convex condition of the module docstring for
    that fixed K by bisection. At a given h a gain that is not certified scores
    ``(h − h*(K))/h > 0`` so that the search climbs toward certified gains; a certified one
    scores ``−α*(K) ≤ 0``. The optimum is local; the certificate of the gain returned is
    exact, whatever the search's quality.
    """
    k0 = np.atleast_2d(np.asarray(k0, dtype=float))
    box = np.asarray(bounds, dtype=float)
    if box.shape != (k0.size, 2) or np.any(box[:, 0] >= box[:, 1]):
        raise ValueError(f"bounds must be {k0.size} (low, high) pairs with low < high, got shape {box.shape}")
    start_points = [k0] + [np.asarray(s, dtype=float).reshape(k0.shape) for s in starts]
    for s in start_points:
        if np.any(s.ravel() < box[:, 0]) or np.any(s.ravel() > box[:, 1]):
            raise ValueError(f"starting gain {s.tolist()} lies outside the bounds")
    if h is not None and not (math.isfinite(h) and h > 0.0):
        raise ValueError(f"h must be None or finite and > 0, got {h}")
    alpha = _nonnegative("alpha", alpha)
    programs, cache = {}, {}
    best = {"score": math.inf, "gain": None, "bound": None}
    largest_h = {"h": 0.0, "gain": None}

    def evaluate(x):
        key = tuple(np.round(x, 12))
        if key in cache:
            return cache[key]
        gain = np.array(x, dtype=float).reshape(k0.shape)
        a0, mults, mats = _as_delay_system(*system_of_gain(gain))
        program = programs.setdefault((a0.shape[0], mults), _DelayProgram(a0.shape[0], mults))
        if h is None:
            bound = _delay_search(program, a0, mats, alpha, None, tol, solvers, rtol)
            score, certified = -bound.value, bound.value > 0.0
        else:
            bound = _decay_search(program, a0, mats, h, None, tol, solvers, rtol)
            certified = bound.result.certified
            if certified:
                score = -bound.value
            else:
                reach = _delay_search(program, a0, mats, 0.0, h, tol, solvers, rtol, bound.result).value
                if reach >= largest_h["h"]:
                    largest_h.update(h=reach, gain=gain)
                score = (h - reach) / h
        if certified and score < best["score"]:
            best.update(score=score, gain=gain, bound=bound)
        cache[key] = score
        return score

    width = box[:, 1] - box[:, 0]
    for s in start_points:
        remaining = max_evaluations - len(cache)
        if remaining <= 0:
            break
        x0 = s.ravel()
        simplex = [x0]
        for i in range(x0.size):
            step = np.zeros_like(x0)
            step[i] = 0.1 * width[i] * (1.0 if x0[i] + 0.1 * width[i] <= box[i, 1] else -1.0)
            simplex.append(x0 + step)
        minimize(
            evaluate,
            x0,
            method="Nelder-Mead",
            bounds=box,
            options={"maxfev": remaining, "initial_simplex": np.array(simplex), "xatol": 1e-3 * width.max(), "fatol": tol},
        )
    if best["gain"] is None:
        if h is None:
            raise ValueError(f"no gain tried within the bounds is certified for any delay bound h > 0 by: {CONDITION}")
        found = (
            f"the largest delay bound certified by any gain tried is {largest_h['h']:.6g} s "
            f"(gain {np.round(largest_h['gain'], 6).tolist()})"
            if largest_h["gain"] is not None and largest_h["h"] > 0.0
            else "no gain tried is certified for any delay bound h > 0"
        )
        raise ValueError(f"no gain tried within the bounds is certified at h = {h:g} s; {found}")
    res = best["bound"].result
    return DelayGainDesign(
        gain=best["gain"],
        h=res.h,
        alpha=res.alpha,
        result=res,
        objective="delay bound" if h is None else "decay rate",
        condition=CONDITION,
        reference=REFERENCE,
        solver=res.solver,
        status=res.status,
        n_evaluations=len(cache),
    )


# --- LQR ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class LQRLMIDesign:
    """Result of :func:`lqr_lmi`.

    Attributes
    ----------
    p : ndarray, shape (n, n)
        The maximal P: the stabilising solution of the algebraic Riccati equation.
    gain : ndarray, shape (m, n)
        ``K = R⁻¹ Bᵀ P`` (``u = −K x``).
    result : LMIResult
        The solve; its single margin ``"LQR"`` is the smallest eigenvalue of the block.
    """

    p: np.ndarray
    gain: np.ndarray
    result: LMIResult


#: Tighter than CLARABEL's defaults: the optimum lies where the LQR block is singular and
#: the answer is compared with the Riccati solution.
LQR_SOLVERS = (
    ("CLARABEL", {"tol_gap_abs": 1e-12, "tol_gap_rel": 1e-12, "tol_feas": 1e-12}),
    ("SCS", {"eps_abs": 1e-10, "eps_rel": 1e-10, "max_iters": 100000}),
)


def lqr_lmi(a, b, q, r, solvers=LQR_SOLVERS, rtol=RTOL):
    """Infinite-horizon LQR by an LMI: maximise trace P subject to the dissipation inequality.

    Parameters
    ----------
    a : array_like, shape (n, n)
    b : array_like, shape (n, m)
    q : array_like, shape (n, n)
        State weight, symmetric ⪰ 0.
    r : array_like, shape (m, m)
        Input weight, symmetric ≻ 0.
    solvers, rtol
        See :meth:`LMIProgram.solve`.

    Returns
    -------
    LQRLMIDesign

    Notes
    -----
    ``[[AᵀP + PA + Q, PB], [BᵀP, R]] ⪰ 0`` (P symmetric) says, by the Schur complement,
    ``AᵀP + PA + Q − P B R⁻¹ BᵀP ⪰ 0``; for (A, B) stabilisable every such P lies below the
    stabilising Riccati solution, which satisfies it with equality, so maximising trace P
    returns it (Boyd et al. 1994, §7.2; Willems 1971). The block is singular at the optimum:
    the re-check is non-strict (``"⪰"``, to within ``rtol``).
    """
    import cvxpy as cp

    a, b, q, r = (np.atleast_2d(np.asarray(v, dtype=float)) for v in (a, b, q, r))
    n, m = b.shape
    if a.shape != (n, n) or q.shape != (n, n) or r.shape != (m, m):
        raise ValueError(f"shapes do not match: a {a.shape}, b {b.shape}, q {q.shape}, r {r.shape}")
    if not np.allclose(r, r.T) or np.linalg.eigvalsh(0.5 * (r + r.T))[0] <= 0.0:
        raise ValueError("r must be symmetric positive definite")
    p = cp.Variable((n, n), symmetric=True, name="P")
    block = cp.bmat([[a.T @ p + p @ a + q, p @ b], [b.T @ p, r]])
    result = solve_lmis(
        [MatrixInequality("LQR", block, ">=")],
        {"P": p},
        objective=cp.Maximize(cp.trace(p)),
        solvers=solvers,
        rtol=rtol,
    )
    p_val = result.variables.get("P", np.full((n, n), np.nan))
    p_val = 0.5 * (p_val + p_val.T)
    return LQRLMIDesign(p=p_val, gain=np.linalg.solve(r, b.T @ p_val), result=result)


# --- public names (coopsat.design) ---------------------------------------------------------------


def certified_delay(
    a0: ArrayLike,
    terms: Sequence[tuple[ArrayLike, float]],
    *,
    alpha: float = 0.0,
    h_hi: float | None = None,
    tol: float = 1e-4,
) -> CertifiedBound:
    """Largest delay bound h certified by the delay-dependent LMI (``coopsat.design``).

    Parameters
    ----------
    a0 : array_like, shape (n, n)
        Undelayed state matrix, 1/s.
    terms : sequence of (array_like (n, n), float)
        ``(A_k, m_k)``: ``A_k`` (1/s) multiplies ``x(t − m_k d(t))``, m_k > 0 (hops).
    alpha : float
        Decay rate of the Lyapunov–Krasovskii functional certified alongside, 1/s (≥ 0):
        ``V(t) ≤ V(0) e^{−αt}``.
    h_hi : float, optional
        Upper end of the search, s (default: doubling from 1/(‖A0‖ + Σ‖A_k‖)).
    tol : float
        Bisection bracket at which the search stops, s.

    Returns
    -------
    CertifiedBound
        ``value`` = h* (s; 0 when nothing is certified): every delay with
        ``0 ≤ d(t) ≤ h*``, at any rate of variation, keeps the system exponentially stable.
        ``result`` is the re-checked certificate at h* (``certified``, ``status``, ``solver``,
        per-inequality ``margins``), ``upper`` the smallest h tried that failed.

    Notes
    -----
    :func:`max_certified_delay` (the condition of the module docstring; Park, Ko & Jeong
    2011), under its public name. Sufficient only: h* never exceeds the exact constant-delay
    margin (:func:`coopsat.design.delay_margin`).
    """
    return max_certified_delay(a0, terms, alpha=alpha, h_hi=h_hi, tol=tol)


def design_delay_gain(
    system_of_gain: Callable[[np.ndarray], tuple[ArrayLike, Sequence[tuple[ArrayLike, float]]]],
    k0: ArrayLike,
    bounds: ArrayLike,
    *,
    h: float | None = None,
    alpha: float = 0.0,
    starts: Sequence[ArrayLike] = (),
    max_evaluations: int = 100,
    tol: float = 1e-3,
) -> DelayGainDesign:
    """Static gain with the largest certified delay bound, or decay rate at a bound (``coopsat.design``).

    Parameters
    ----------
    system_of_gain : callable
        ``system_of_gain(K) -> (a0, terms)``: the closed-loop system for gain K (shape of
        ``k0``), in the form of :func:`certified_delay`.
    k0 : array_like, shape (p, n)
        Starting gain; its shape is the gain's.
    bounds : array_like, shape (p·n, 2)
        ``(low, high)`` per gain entry, row-major.
    h : float, optional
        None: maximise the certified delay bound h* (s) at decay rate ``alpha``. A bound (s):
        maximise the decay rate α (1/s) certified at it.
    alpha : float
        Decay rate required while maximising h*, 1/s.
    starts : sequence of array_like, shape (p, n)
        Further starting gains.
    max_evaluations : int
        Gains evaluated at most.
    tol : float
        Bisection tolerance of each evaluation, s or 1/s.

    Returns
    -------
    DelayGainDesign
        ``gain``, the certified ``h`` (s) and ``alpha`` (1/s), and the proof: ``result`` (the
        re-checked certificate), ``solver``, ``status``, ``condition``, ``reference``.

    Raises
    ------
    ValueError
        Bad bounds or starts, or no gain tried is certified (one line).

    Notes
    -----
    :func:`design_gain` (derivative-free search over K, one convex problem per candidate),
    with ``h`` keyword-only.
    """
    return design_gain(
        system_of_gain, h, k0, bounds, alpha=alpha, starts=starts, max_evaluations=max_evaluations, tol=tol
    )
