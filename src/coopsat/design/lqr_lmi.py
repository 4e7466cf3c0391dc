"""Infinite-horizon LQR as a semidefinite program: a check on the LMI machinery.

Maximising trace P under the dissipation inequality returns the stabilising Riccati solution
(:func:`lqr_lmi`), so the certified solve of :mod:`coopsat.design.lmi` can be compared with
:func:`coopsat.design.riccati.lqr`, the package's Riccati solver. Its tight solver tolerances,
:data:`LQR_SOLVERS`, head the ladder of the formation's LMIs.

References
----------
S. Boyd, L. El Ghaoui, E. Feron, V. Balakrishnan, *Linear Matrix Inequalities in System and
Control Theory*, SIAM, 1994, §7.2 (the LQR inequality of :func:`lqr_lmi`).
"""

from dataclasses import dataclass

import numpy as np

from coopsat.design.lmi import RTOL, LMIResult, MatrixInequality, solve_lmis


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
