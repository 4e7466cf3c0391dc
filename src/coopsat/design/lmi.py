"""Linear matrix inequalities: a certified solve (SPEC §3).

Every LMI in the project goes through :class:`LMIProgram`: a cvxpy problem whose matrix
inequalities carry names. It is solved with CLARABEL (interior point), falling back to SCS
when CLARABEL fails or reports an inaccurate solution, and the answer is never taken on the
solver's word: each named inequality is rebuilt from the returned numeric values,
symmetrised, and its eigenvalues checked (:func:`check_inequality`). A result is
*certified* only if the solver says ``"optimal"`` and every re-check holds strictly, by the
relative tolerance :data:`RTOL`.

The LMIs themselves are posed where they are used: the delay-dependent stability condition
(:mod:`coopsat.design.delay_lmi`), the gain search over it (:mod:`coopsat.design.delay_gain`),
the LQR inequality (:mod:`coopsat.design.lqr_lmi`) and the formation's eq. (11)
(:mod:`coopsat.design.formation_synthesis`).
"""

import math
import warnings
from dataclasses import dataclass, fields

import numpy as np

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
