"""Fuel against settling time: Pareto fronts and the comparison of two designs at matched
settling time (SPEC §4).

A design's fuel means little alone: a slower controller spends less. Each design is swept over
its weight (:mod:`coopsat.tradeoff`) and judged by its *front*, the runs no other run of the
same design beats on both fuel and settling time; two designs are compared by the fuel of
their fronts at the same settling time, by linear interpolation along each front, only where
both fronts reach.
"""

import numpy as np


def pareto_front(settle_s, fuel):
    """Indices of the non-dominated runs (lower settling time and lower fuel are better), in
    order of increasing settling time.

    Parameters
    ----------
    settle_s, fuel : (k,)
        NaN (a run that never settled) is never on the front.

    Returns
    -------
    ndarray of int
    """
    settle_s, fuel = np.asarray(settle_s, dtype=float), np.asarray(fuel, dtype=float)
    ok = np.flatnonzero(np.isfinite(settle_s) & np.isfinite(fuel))
    order = ok[np.lexsort((fuel[ok], settle_s[ok]))]
    front, best = [], np.inf
    for k in order:
        if fuel[k] < best:
            front.append(k)
            best = fuel[k]
    return np.asarray(front, dtype=int)


def fuel_on_front(settle_s, fuel, at_s):
    """Fuel of a front at the given settling times (linear interpolation along the front; NaN
    outside its range).

    Parameters
    ----------
    settle_s, fuel : (k,)
        All runs of one design (the front is taken here).
    at_s : (m,)
    """
    idx = pareto_front(settle_s, fuel)
    at_s = np.asarray(at_s, dtype=float)
    if idx.size == 0:
        return np.full(at_s.shape, np.nan)
    s, f = np.asarray(settle_s, dtype=float)[idx], np.asarray(fuel, dtype=float)[idx]
    out = np.interp(at_s, s, f)
    return np.where((at_s >= s[0]) & (at_s <= s[-1]), out, np.nan)


def matched_saving(settle_a, fuel_a, settle_b, fuel_b, n_points=9):
    """Fuel saving of design A against design B at the same settling time, percent of B.

    Returns
    -------
    dict
        ``settle_s`` (m,) the settling times compared (spread over the overlap of the two
        fronts), ``fuel_a``, ``fuel_b`` (m,), ``saving_percent`` (m,) = 100 (B − A)/B, and
        ``overlap_s`` (lo, hi) or None when the fronts do not overlap (then the arrays are
        empty).
    """
    fa, fb = pareto_front(settle_a, fuel_a), pareto_front(settle_b, fuel_b)
    empty = {"settle_s": np.array([]), "fuel_a": np.array([]), "fuel_b": np.array([]), "saving_percent": np.array([]), "overlap_s": None}
    if fa.size == 0 or fb.size == 0:
        return empty
    sa, sb = np.asarray(settle_a, dtype=float)[fa], np.asarray(settle_b, dtype=float)[fb]
    lo, hi = max(sa[0], sb[0]), min(sa[-1], sb[-1])
    if not lo <= hi:
        return empty
    at = np.linspace(lo, hi, n_points) if hi > lo else np.array([lo])
    a, b = fuel_on_front(settle_a, fuel_a, at), fuel_on_front(settle_b, fuel_b, at)
    return {"settle_s": at, "fuel_a": a, "fuel_b": b, "saving_percent": 100.0 * (b - a) / b, "overlap_s": (lo, hi)}
