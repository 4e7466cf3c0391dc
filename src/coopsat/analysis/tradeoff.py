"""Fuel against settling time: Pareto fronts and the comparison of two designs at matched
settling time (SPEC §4).

A design's fuel means little alone: a slower controller spends less. Each design is swept over
its weight (:mod:`coopsat.workflows.deep_space_tradeoff`) and judged by its *front*, the runs no other run of the
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


def rest_to_rest_fuel_ns(distance_m, t_s, mass_kg, force_max_n):
    """Least ``∫|u| dt`` that moves a double integrator ``distance_m`` from rest to rest in
    ``t_s`` with ``|u| ≤ force_max_n``: bang-coast-bang, ``2·m·v`` with the slowest coast
    speed ``v`` that arrives in time.

    Parameters
    ----------
    distance_m, t_s : array_like (broadcast)
        Distance to cover (≥ 0), m, and the time allowed, s.
    mass_kg, force_max_n : float

    Returns
    -------
    ndarray
        N·s; ``inf`` where ``t_s`` is shorter than bang-bang's ``2·sqrt(m·D/F)``.

    Notes
    -----
    Burning ``t_b = m v / F`` at each end and coasting in between covers
    ``D = v (T − m v / F)``, so ``v = (F / 2m)(T − sqrt(T² − 4 m D / F))``; the fuel is
    ``2 m v``: ``2 m D / T`` for a long time, ``2 sqrt(m D F)`` at the bang-bang limit.
    """
    d = np.maximum(np.asarray(distance_m, dtype=float), 0.0)
    t = np.asarray(t_s, dtype=float)
    disc = t**2 - 4.0 * mass_kg * d / force_max_n
    with np.errstate(invalid="ignore"):
        # The root written without cancellation: T − sqrt(T² − a) = a / (T + sqrt(T² − a)).
        v = (force_max_n / (2.0 * mass_kg)) * (4.0 * mass_kg * d / force_max_n) / (t + np.sqrt(np.maximum(disc, 0.0)))
    return np.where(disc >= 0.0, 2.0 * mass_kg * v, np.inf)


def formation_fuel_bound_ns(displacement_m, t_s, mass_kg, force_max_n, tolerance_m=0.0):
    """A lower bound on the L1 fuel ``Σ_i Σ_axes ∫|u| dt`` of a formation reconfiguration.

    Every spacecraft must move by its displacement plus a common translation ``c`` of the
    whole formation (free: the formation error ignores translation), axis by axis, from rest
    to rest, ending within ``tolerance_m`` (each axis' residual is at most the tolerance when
    the distance is); :func:`rest_to_rest_fuel_ns` per axis, minimised over ``c`` (convex).

    Parameters
    ----------
    displacement_m : (n, d)
        Target minus initial position of each spacecraft, relative to its centroid, m.
    t_s : float
        The settling time asked for, s.

    Returns
    -------
    float
        N·s (``inf`` where ``t_s`` is too short at ``force_max_n``).

    Notes
    -----
    Disturbances (solar pressure differentials of ~1e-5 N) and the dead zone are ignored;
    every real design spends at least this.
    """
    from scipy.optimize import minimize_scalar

    d = np.asarray(displacement_m, dtype=float)
    total = 0.0
    for a in range(d.shape[1]):
        col = d[:, a]

        def fuel(c, col=col):
            return float(rest_to_rest_fuel_ns(np.abs(col + c) - tolerance_m, t_s, mass_kg, force_max_n).sum())

        lo, hi = float(-col.max()), float(-col.min())
        best = minimize_scalar(fuel, bounds=(lo, hi), method="bounded", options={"xatol": 1e-9}) if hi > lo else None
        total += min(fuel(0.0), fuel(lo), fuel(hi), best.fun if best is not None else np.inf)
    return total
