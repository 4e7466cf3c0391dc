"""A navigation filter's consistency across a campaign: the runs' NEES pooled against its χ²
band.

Each run reports ``nees_mean`` over ``nees_effective_samples`` independent values
(:mod:`coopsat.analysis.papers.navigation`); runs are independent of each other, so the pooled
mean ``Σ N_k ε̄_k / Σ N_k`` is the mean of ``Σ N_k`` independent χ²(6) values when the filter is
consistent, and its two-sided 95 % band is ``χ²_{6N}(0.025, 0.975) / N``, ``N = Σ N_k``. Also
how many runs are consistent on their own (about 95 % of them when the filter is).
"""

import numpy as np


def pooled_nees(rows):
    """The campaign's NEES verdict, or None when no run has a navigation filter.

    Parameters
    ----------
    rows : list of dict
        The finished runs' metrics (``nees_mean``, ``nees_effective_samples``,
        ``nees_consistent``).

    Returns
    -------
    dict or None
        ``runs``, ``pooled_mean``, ``effective_samples``, ``bound_low``, ``bound_high``,
        ``consistent`` (the pooled mean inside its band) and ``runs_consistent`` (how many runs
        are inside their own band).
    """
    from coopsat.analysis.papers.navigation import chi2_band

    have = [r for r in rows if r.get("nees_mean") is not None and r.get("nees_effective_samples")]
    if not have:
        return None
    mean = np.array([r["nees_mean"] for r in have], dtype=float)
    count = np.array([r["nees_effective_samples"] for r in have], dtype=float)
    total = float(count.sum())
    pooled = float(np.sum(mean * count) / total)
    low, high = (float(b) for b in chi2_band(6, total))
    return {"runs": len(have), "pooled_mean": pooled, "effective_samples": total, "bound_low": low, "bound_high": high,
            "consistent": bool(low <= pooled <= high), "runs_consistent": int(sum(bool(r.get("nees_consistent")) for r in have))}


def pooled_nees_html(verdict):
    """The report's paragraph for :func:`pooled_nees` ("" without a filter)."""
    if verdict is None:
        return ""
    word = "consistent" if verdict["consistent"] else "NOT consistent"
    return (
        "<h2>Navigation filter consistency</h2><p>Pooled NEES over the campaign "
        f"{verdict['pooled_mean']:.3g} for {verdict['effective_samples']:.0f} independent values "
        f"(95 % χ² band {verdict['bound_low']:.3g}–{verdict['bound_high']:.3g}): {word}; "
        f"{verdict['runs_consistent']} of {verdict['runs']} runs inside their own band (about 95 % when consistent).</p>"
    )
