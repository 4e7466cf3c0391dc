"""The largest delay bound, or decay rate, that the delay LMI certifies, by bisection (SPEC §3).

Each value tried is one solve of :func:`coopsat.design.delay_lmi.certify_delay_bound` (the
condition and its references are there); the value returned is always one that was certified,
with its certificate. ``certified_delay`` is the public name (``coopsat.design``).
"""

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from coopsat.design.delay_lmi import DelayLMIResult, DelayProgram, as_delay_system, nonnegative
from coopsat.design.lmi import DEFAULT_SOLVERS, RTOL
from coopsat.design.memo import by_value


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


def _time_scale(a0, mats):
    """``‖A0‖ + Σ‖A_k‖`` (1/s): sets the first guesses of the searches."""
    s = float(np.linalg.norm(a0, 2) + sum(np.linalg.norm(m, 2) for m in mats))
    return s if s > 0.0 else 1.0


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


def delay_search(program, a0, mats, alpha, h_hi, tol, solvers, rtol, failed_at_hi=None):
    """Largest h that ``program`` (a :class:`DelayProgram`) certifies at decay rate ``alpha``:
    doubling from 1/(‖A0‖ + Σ‖A_k‖), or bisection below ``h_hi`` (``failed_at_hi``: its known
    failed result, if any)."""
    def at(h):
        return program.certify(a0, mats, h, alpha, solvers, rtol)

    scale = _time_scale(a0, mats)
    if h_hi is None:
        return _largest_certified(at, 0.0, None, 1.0 / scale, _CAP_FACTOR / scale, tol)
    return _largest_certified(at, 0.0, None, h_hi, h_hi, tol, failed_at_hi)


def decay_search(program, a0, mats, h, alpha_hi, tol, solvers, rtol):
    """Largest α that ``program`` (a :class:`DelayProgram`) certifies at delay bound ``h``;
    0 with the failed result when h is not certified at α = 0."""
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
    """Largest h that :func:`~coopsat.design.delay_lmi.certify_delay_bound` certifies (bisection).

    Parameters
    ----------
    a0, terms
        As :func:`~coopsat.design.delay_lmi.certify_delay_bound`.
    alpha : float
        Decay rate certified alongside, 1/s.
    h_hi : float, optional
        Upper end of the search, s. Without it the search starts at 1/(‖A0‖ + Σ‖A_k‖) and
        doubles while certified, up to 1000 times that (then ``upper`` is ``inf``).
    tol : float
        Bisection stops when the bracket is narrower than this, s.
    solvers, rtol
        See :meth:`~coopsat.design.lmi.LMIProgram.solve`.

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
    a0, mults, mats = as_delay_system(a0, terms)
    if h_hi is not None and not (math.isfinite(h_hi) and h_hi > 0.0):
        raise ValueError(f"h_hi must be finite and > 0, got {h_hi}")
    program = DelayProgram(a0.shape[0], mults)
    return delay_search(program, a0, mats, nonnegative("alpha", alpha), h_hi, tol, solvers, rtol)


@by_value
def max_decay_rate(a0, terms, h, alpha_hi=None, tol=1e-4, solvers=DEFAULT_SOLVERS, rtol=RTOL):
    """Largest α (decay rate of V, 1/s) certified at delay bound h (bisection).

    Parameters
    ----------
    a0, terms, h
        As :func:`~coopsat.design.delay_lmi.certify_delay_bound`.
    alpha_hi : float, optional
        Upper end of the search, 1/s. Without it the search starts at ‖A0‖ + Σ‖A_k‖ and
        doubles while certified, up to 1000 times that.
    tol : float
        Bracket width at which bisection stops, 1/s.
    solvers, rtol
        See :meth:`~coopsat.design.lmi.LMIProgram.solve`.

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
    a0, mults, mats = as_delay_system(a0, terms)
    program = DelayProgram(a0.shape[0], mults)
    return decay_search(program, a0, mats, nonnegative("h", h), alpha_hi, tol, solvers, rtol)


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
    :func:`max_certified_delay` (the condition of :mod:`coopsat.design.delay_lmi`; Park, Ko
    & Jeong 2011), under its public name. Sufficient only: h* never exceeds the exact constant-delay
    margin (:func:`coopsat.design.delay_margin`).
    """
    return max_certified_delay(a0, terms, alpha=alpha, h_hi=h_hi, tol=tol)
