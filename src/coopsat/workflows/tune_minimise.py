"""The minimiser of ``coopsat tune`` (:mod:`coopsat.workflows.tune`): SLSQP with JAX gradients
from several starts.

Every start is screened in one ``jax.vmap`` (values and Jacobians together); SciPy's SLSQP then
refines the best of them one after the other, on the objective scaled so that its first step
is :data:`FIRST_STEP` long. A step that destabilises the loop (NaN or inf) is reported as far
worse than the start, sloping back towards the last point that ran.
"""

import time
from dataclasses import dataclass

import numpy as np

from coopsat.workflows.tune_problem import TuneError

FIRST_STEP = 0.1
"""Length of SLSQP's first step in the scaled variables (10 % of each parameter's size)."""


@dataclass
class Optimum:
    """What :func:`minimise` found.

    Attributes
    ----------
    z : ndarray (starts, n_var)
        Final variables of every start.
    values : ndarray (starts, 1 + m)
        Objective and constraints there.
    best : int
        The start kept (:func:`ranked`).
    history : list of dict
        Per iteration, every start's objective and constraints.
    iterations : int
    compile_s, optimise_s : float
    warnings : list of str
    """

    z: np.ndarray
    values: np.ndarray
    best: int
    history: list
    iterations: int
    compile_s: float
    optimise_s: float
    warnings: list


def minimise(stacked, z0, m, bounds, max_iter=50, report=None, ftol=1e-10, polish=1):
    """Minimise ``stacked(z)[0]`` subject to ``stacked(z)[1:] ≤ 0`` from several starts.

    Every start is screened in one ``jax.vmap`` (values and Jacobians together); SLSQP then
    runs from the ``polish`` best of them (lowest objective among those meeting the
    constraints, then least violation), one after the other, with the Jacobian by reverse
    mode. The objective is divided by its gradient's norm at the first start over
    :data:`FIRST_STEP`. (Stacking every start into one SLSQP problem was tried first: one start
    that meets a bad step stops all of them.)

    Parameters
    ----------
    stacked : callable
        ``z (n_var,) -> (1 + m,)`` JAX function: objective, then constraints.
    z0 : ndarray (starts, n_var)
    m : int
        Number of constraints.
    bounds : list of (lo, hi)
        Per variable (``None``: unbounded).
    report : callable, optional
        ``(iteration, values (1 + m,))`` per iteration of the start being polished.
    polish : int
        How many of the screened starts SLSQP refines.

    Returns
    -------
    Optimum
        ``z``, ``values``: every start's final point and values (those not polished stay at
        their start).
    """
    one, vals0, jac0, compile_s = _screen(stacked, z0)
    if not (np.all(np.isfinite(vals0[0])) and np.all(np.isfinite(jac0[0]))):
        raise TuneError("the surrogate objective or a constraint is not finite at the scenario's own values")
    vals0 = np.where(np.isfinite(vals0), vals0, np.inf)
    # SLSQP's first step is the negative gradient (its Hessian estimate starts as I): scaled so,
    # that step moves the variables by FIRST_STEP at most, not across the whole stable region.
    norm = max(float(np.linalg.norm(jac0[0, 0])) / FIRST_STEP, 1e-300)
    evaluate = _evaluator(one, vals0)
    history, z, values, iterations, warnings = [], z0.copy(), vals0.copy(), 0, []
    t0 = time.perf_counter()
    for s in ranked(vals0)[:polish]:
        res, z[s], values[s] = _polish(evaluate, norm, s, z0[s], m, bounds, max_iter, ftol, history, report)
        iterations += int(res.nit)
        if not res.success:
            warnings.append(f"SLSQP from start {s} stopped: {res.message}")
    return Optimum(
        z=z, values=values, best=ranked(values)[0], history=history, iterations=iterations,
        compile_s=compile_s, optimise_s=time.perf_counter() - t0, warnings=warnings,
    )


def _screen(stacked, z0):
    """Compile ``z -> (values, Jacobian)`` and evaluate it at every start.

    Returns
    -------
    one : callable
        The compiled function of one start.
    vals0, jac0 : ndarray (starts, 1 + m), (starts, 1 + m, n_var)
    compile_s : float
        Compilation and screening time.
    """
    import jax
    import jax.numpy as jnp

    starts = z0.shape[0]
    both = lambda z: (stacked(z), jax.jacrev(stacked)(z))  # noqa: E731
    t0 = time.perf_counter()
    one = jax.jit(both)
    if starts == 1:  # no screening to do: one compiled program, not two
        vals0, jac0 = (np.asarray(a)[None] for a in one(jnp.asarray(z0[0])))
    else:
        vals0, jac0 = (np.asarray(a) for a in jax.jit(jax.vmap(both))(jnp.asarray(z0)))
        one(jnp.asarray(z0[0]))
    return one, vals0, jac0, time.perf_counter() - t0


def _evaluator(one, vals0):
    """``x -> (values, Jacobian)`` of the compiled ``one``, remembering the last point, with a
    non-finite point replaced by a penalty that slopes back to the last finite one."""
    import jax.numpy as jnp

    cache, good = {}, {}

    def evaluate(x):
        key = x.tobytes()
        if key not in cache:
            cache.clear()
            v, j = (np.array(a) for a in one(jnp.asarray(x)))
            if np.all(np.isfinite(v)) and np.all(np.isfinite(j)):
                good["x"] = x.copy()
            else:
                # A step that destabilises the loop gives NaN or inf: report it as far worse
                # than the start, objective and constraints alike, sloping back towards the
                # last point that ran, so that SLSQP has a way out.
                back = x - good.get("x", x)
                v = 1e3 * (np.abs(vals0[0]) + 1.0) + np.sum(back**2)
                j = np.broadcast_to(2.0 * back, j.shape).copy()
            cache[key] = (v, j)
        return cache[key]

    return evaluate


def _polish(evaluate, norm, s, start, m, bounds, max_iter, ftol, history, report):
    """SLSQP from start ``s`` at ``start``; every iteration is appended to ``history`` (and
    reported).

    Returns
    -------
    res : scipy.optimize.OptimizeResult
    z, values : ndarray
        The best point SLSQP went through and its values (:func:`ranked`).
    """
    from scipy.optimize import minimize

    seen = []

    def record(x):
        v = evaluate(x)[0]
        seen.append((x.copy(), v))
        history.append({"start": int(s), "iteration": len(history), "objective": float(v[0]), "constraints": v[1:].tolist()})
        if report is not None:
            report(len(history) - 1, v)

    record(start)
    res = minimize(
        lambda x: float(evaluate(x)[0][0] / norm), start, jac=lambda x: evaluate(x)[1][0] / norm,
        method="SLSQP", bounds=bounds,
        constraints=[{"type": "ineq", "fun": lambda x: -evaluate(x)[0][1:], "jac": lambda x: -evaluate(x)[1][1:]}] if m else [],
        options={"maxiter": max_iter, "ftol": ftol}, callback=record,
    )
    seen.append((res.x, evaluate(res.x)[0]))
    # SLSQP returns its last iterate, which past an iteration limit may be worse than one
    # it has been through (even infeasible after a feasible start): keep the best seen.
    z, values = seen[ranked(np.array([v for _, v in seen]))[0]]
    return res, z, values


def ranked(values):
    """Starts from best to worst: those meeting every constraint by objective, then the rest
    by total violation. ``values``: (starts, 1 + m)."""
    violation = np.maximum(values[:, 1:], 0.0).sum(axis=1) if values.shape[1] > 1 else np.zeros(len(values))
    feasible = violation <= 1e-6
    order = np.lexsort((values[:, 0], np.where(feasible, 0.0, violation), ~feasible))
    return [int(k) for k in order]
