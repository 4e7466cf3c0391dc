"""Static gain with the largest certified delay bound, or decay rate at a bound (SPEC §3).

The gain K enters the leader–follower error system as
H ⊗ BK (the same K for every follower) and multiplies P, R_k in Φ: bilinear. The usual
convexification (congruence with P⁻¹ and Y = K P⁻¹) needs P⁻¹ = I ⊗ X̄ to recover one K
shared by all followers, which fixes the shape of the certificate and is conservative in a
way that is hard to bound. Instead K is searched directly (Nelder–Mead, a handful of
entries), each evaluation being the exact convex problem for that fixed K; every reported
number is a re-checked certificate for the reported K.

The condition is the one of :mod:`coopsat.design.delay_lmi`, each candidate's bound found by
the bisections of :mod:`coopsat.design.delay_bounds`.
"""

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import minimize

from coopsat.design.delay_bounds import decay_search, delay_search
from coopsat.design.delay_lmi import CONDITION, REFERENCE, DelayLMIResult, DelayProgram, as_delay_system, nonnegative
from coopsat.design.lmi import DEFAULT_SOLVERS, RTOL


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


class BestGain(NamedTuple):
    """The best certified gain of a running search, as a progress callback sees it.

    Attributes
    ----------
    value : float
        Maximising the delay bound: h*(K), s. At a given h: the decay rate α*(K), 1/s.
    gain : ndarray, shape k0.shape
        The gain K.
    """

    value: float
    gain: np.ndarray


#: ``progress(stage, done, total, best)``: the search's stage (str), gains evaluated so far
#: over all starts and at most (int; the search may stop sooner), and the best certified gain
#: so far (:class:`BestGain`, None until one is certified). Observes only: the result is the
#: same with or without it.
ProgressCallback = Callable[[str, int, int, BestGain | None], None]


class _GainScorer:
    """The search's objective: the score of a gain (lower is better), and the best gain seen.

    Maximising h* (``h`` None) a gain scores −h*(K). At a given h a certified gain scores
    −α*(K) ≤ 0 and one that is not scores ``(h − h*(K))/h > 0``, so that the search climbs
    toward certified gains; the largest h*(K) of those is kept for the error message. Scores
    are cached by the gain rounded to 12 decimals; one :class:`DelayProgram` serves every gain
    whose system has the same structure. ``progress`` (a :data:`ProgressCallback` or None)
    hears of each gain newly scored, under the ``stage`` and ``total`` the search sets.
    """

    def __init__(self, system_of_gain, shape, h, alpha, tol, solvers, rtol, progress=None):
        self.system_of_gain, self.shape, self.h, self.alpha = system_of_gain, shape, h, alpha
        self.tol, self.solvers, self.rtol = tol, solvers, rtol
        self.progress, self.stage, self.total = progress, "gain search", 0
        self.programs, self.cache = {}, {}
        self.best_score, self.best_gain, self.best_bound = math.inf, None, None
        self.largest_h, self.largest_h_gain = 0.0, None

    @property
    def n_evaluations(self):
        """Gains scored (distinct to 12 decimals)."""
        return len(self.cache)

    def __call__(self, x):
        key = tuple(np.round(x, 12))
        if key in self.cache:
            return self.cache[key]
        gain = np.array(x, dtype=float).reshape(self.shape)
        a0, mults, mats = as_delay_system(*self.system_of_gain(gain))
        structure = (a0.shape[0], mults)
        if structure not in self.programs:
            self.programs[structure] = DelayProgram(a0.shape[0], mults)
        score, certified, bound = self._score(self.programs[structure], a0, mats, gain)
        if certified and score < self.best_score:
            self.best_score, self.best_gain, self.best_bound = score, gain, bound
        self.cache[key] = score
        self.report()
        return score

    def report(self):
        """Tell ``progress`` (if any) the stage, the gains scored, and the best so far."""
        if self.progress is not None:
            # A copy: whatever the callback does with it, the search's own gain stays as it was.
            best = None if self.best_bound is None else BestGain(self.best_bound.value, self.best_gain.copy())
            self.progress(self.stage, self.n_evaluations, self.total, best)

    def _score(self, program, a0, mats, gain):
        """``(score, certified, bound)`` of one gain (class docstring)."""
        h, tol, solvers, rtol = self.h, self.tol, self.solvers, self.rtol
        if h is None:
            bound = delay_search(program, a0, mats, self.alpha, None, tol, solvers, rtol)
            return -bound.value, bound.value > 0.0, bound
        bound = decay_search(program, a0, mats, h, None, tol, solvers, rtol)
        if bound.result.certified:
            return -bound.value, True, bound
        reach = delay_search(program, a0, mats, 0.0, h, tol, solvers, rtol, bound.result).value
        if reach >= self.largest_h:
            self.largest_h, self.largest_h_gain = reach, gain
        return (h - reach) / h, False, bound

    def failure(self):
        """Why no gain is returned, in one line (when none tried was certified)."""
        if self.h is None:
            return f"no gain tried within the bounds is certified for any delay bound h > 0 by: {CONDITION}"
        found = (
            f"the largest delay bound certified by any gain tried is {self.largest_h:.6g} s "
            f"(gain {np.round(self.largest_h_gain, 6).tolist()})"
            if self.largest_h_gain is not None and self.largest_h > 0.0
            else "no gain tried is certified for any delay bound h > 0"
        )
        return f"no gain tried within the bounds is certified at h = {self.h:g} s; {found}"


def _search_box(k0, bounds, starts):
    """``(k0, box, start points)`` as arrays, checked: a (low, high) pair with low < high per
    entry of the gain, every start inside."""
    k0 = np.atleast_2d(np.asarray(k0, dtype=float))
    box = np.asarray(bounds, dtype=float)
    if box.shape != (k0.size, 2) or np.any(box[:, 0] >= box[:, 1]):
        raise ValueError(f"bounds must be {k0.size} (low, high) pairs with low < high, got shape {box.shape}")
    start_points = [k0] + [np.asarray(s, dtype=float).reshape(k0.shape) for s in starts]
    for s in start_points:
        if np.any(s.ravel() < box[:, 0]) or np.any(s.ravel() > box[:, 1]):
            raise ValueError(f"starting gain {s.tolist()} lies outside the bounds")
    return k0, box, start_points


def _nelder_mead(scorer, start_points, box, max_evaluations, tol):
    """Bounded Nelder–Mead from each start in turn, the first simplex a tenth of the box wide,
    until ``max_evaluations`` gains have been scored over all starts; each start is a stage
    of the scorer's progress reports."""
    width = box[:, 1] - box[:, 0]
    scorer.total = max_evaluations
    for n, s in enumerate(start_points, start=1):
        remaining = max_evaluations - scorer.n_evaluations
        if remaining <= 0:
            break
        if len(start_points) > 1:
            scorer.stage = f"gain search from start {n}/{len(start_points)}"
        scorer.report()
        x0 = s.ravel()
        simplex = [x0]
        for i in range(x0.size):
            step = np.zeros_like(x0)
            step[i] = 0.1 * width[i] * (1.0 if x0[i] + 0.1 * width[i] <= box[i, 1] else -1.0)
            simplex.append(x0 + step)
        minimize(
            scorer,
            x0,
            method="Nelder-Mead",
            bounds=box,
            options={"maxfev": remaining, "initial_simplex": np.array(simplex), "xatol": 1e-3 * width.max(), "fatol": tol},
        )


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
    progress=None,
):
    """Static gain maximising the certified delay bound, or the decay rate at a given bound.

    Parameters
    ----------
    system_of_gain : callable
        ``system_of_gain(K) -> (a0, terms)``, the closed-loop (error) system for gain K in the
        form of :func:`~coopsat.design.delay_lmi.certify_delay_bound`.
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
        See :meth:`~coopsat.design.lmi.LMIProgram.solve`.
    progress : ProgressCallback, optional
        ``progress(stage, done, total, best)`` as each start begins and after each gain newly
        scored (``done`` never decreasing, ``total`` = ``max_evaluations``); it only observes.

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
    box wide) over K; each evaluation solves the convex condition of
    :mod:`coopsat.design.delay_lmi` for that fixed K by bisection. At a given h a gain that is not certified scores
    ``(h − h*(K))/h > 0`` so that the search climbs toward certified gains; a certified one
    scores ``−α*(K) ≤ 0``. The optimum is local; the certificate of the gain returned is
    exact, whatever the search's quality.
    """
    k0, box, start_points = _search_box(k0, bounds, starts)
    if h is not None and not (math.isfinite(h) and h > 0.0):
        raise ValueError(f"h must be None or finite and > 0, got {h}")
    scorer = _GainScorer(system_of_gain, k0.shape, h, nonnegative("alpha", alpha), tol, solvers, rtol, progress)
    _nelder_mead(scorer, start_points, box, max_evaluations, tol)
    if scorer.best_gain is None:
        raise ValueError(scorer.failure())
    res = scorer.best_bound.result
    return DelayGainDesign(
        gain=scorer.best_gain,
        h=res.h,
        alpha=res.alpha,
        result=res,
        objective="delay bound" if h is None else "decay rate",
        condition=CONDITION,
        reference=REFERENCE,
        solver=res.solver,
        status=res.status,
        n_evaluations=scorer.n_evaluations,
    )


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
    progress: ProgressCallback | None = None,
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
    progress : callable, optional
        ``progress(stage, done, total, best)`` as the search goes (:data:`ProgressCallback`);
        it only observes.

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
        system_of_gain, h, k0, bounds, alpha=alpha, starts=starts, max_evaluations=max_evaluations, tol=tol,
        progress=progress,
    )
