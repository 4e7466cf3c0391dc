"""Compare a run's metrics with the source paper's published numbers, and explain differences.

Each ``[[published]]`` entry of a scenario becomes one row: quantity, unit, published value,
ours, verdict ("agrees" or "differs") and a reason. A difference is a finding, not a failure:
the reason says what the tool knows about it (an unstable sampled-data loop, a quantity that
never settled within the run, a conserved quantity that forbids the published outcome, or the
scenario's own note on what differs from the paper's set-up).
"""

import math


def _agrees(entry, ours):
    if ours is None or (isinstance(ours, float) and math.isnan(ours)):
        return False
    if entry.relation == "greater":
        return ours > entry.value
    if entry.relation == "less":
        return ours < entry.value
    return abs(ours - entry.value) <= max(entry.abs_tol, entry.rel_tol * abs(entry.value))


def _tolerance_text(entry):
    if entry.relation == "greater":
        return f"published: more than {entry.value:g} {entry.unit}"
    if entry.relation == "less":
        return f"published: less than {entry.value:g} {entry.unit}"
    tol = max(entry.abs_tol, entry.rel_tol * abs(entry.value))
    return f"agreement band ±{tol:g} {entry.unit}"


def _rest_explanation(quantity, metrics):
    """Why law (3) need not end at rest: it damps only rate differences."""
    h0, hf = metrics.get("angular_momentum_initial_nms"), metrics.get("angular_momentum_final_nms")
    if h0 is None or hf is None:
        return None
    return (
        "law (3) damps only rate differences: once attitudes and rates agree its torque is zero whatever the "
        "common rate, so a common spin about a shared principal axis is an equilibrium and nothing brings the "
        f"formation to rest (inertial angular momentum {h0:.3g} N·m·s at the start, {hf:.3g} N·m·s at the end)"
    )


def _deadband_explanation(quantity, metrics):
    """A PWM minimum pulse leaves small commands unexecuted: errors stall instead of vanishing."""
    deadband = metrics.get("pwm_deadband_torque_nm")
    if deadband is None or metrics.get(quantity) is not None or metrics.get("spectral_radius", 0.0) >= 1.0:
        return None  # an unstable loop is explanation enough; the dead band is not the cause
    spread = metrics.get("final_attitude_spread_deg")
    tail = f"; the attitude spread ends at {spread:.3g} deg" if spread is not None else ""
    return (
        f"PWM commands below T_max·τ/T = {deadband:.3g} N·m are not executed (minimum pulse), so the loop stops "
        f"correcting small errors{tail}"
    )


def _spin_down_explanation(quantity, metrics):
    """The thrusters' authority bounds how fast a spin can be removed."""
    bound = metrics.get(quantity.replace("_rate_settle_time_s", "_min_spin_down_time_s"))
    if bound is None:
        return None
    return f"at full thrust the spin cannot be removed in less than {bound:.3g} s (I·|Δω|/T_max per axis)"


EXPLAINERS = {
    "final_rate_max_rad_s": _rest_explanation,
    "sync_time_s": _deadband_explanation,
    "track_time_s": _deadband_explanation,
    "_rate_settle_time_s": _spin_down_explanation,
}
"""Explanations of a difference, by metric name or name suffix: (quantity, metrics) -> str or None."""


def _explain(quantity, metrics):
    sentences = []
    for key, explainer in EXPLAINERS.items():
        if quantity == key or (key.startswith("_") and quantity.endswith(key)):
            sentence = explainer(quantity, metrics)
            if sentence:
                sentences.append(sentence)
    return sentences


def compare_published(published, metrics, stability_note=None, t_final_s=None):
    """Rows of the comparison table.

    Parameters
    ----------
    published : sequence of coopsat.scenarios.schema.Published
    metrics : dict
        From :func:`coopsat.analysis.metrics.run_metrics` (plus design-time entries).
    stability_note : str, optional
        One line from the sampled-data check when the loop is unstable.
    t_final_s : float, optional
        Run length, quoted when a quantity never settled.

    Returns
    -------
    list of dict
        Keys ``quantity, unit, published, relation, ours, verdict, reason, source``;
        ``relation`` is "approx", or "greater"/"less" when the paper gives only a bound.
    """
    rows = []
    for entry in published:
        if entry.quantity not in metrics:
            raise KeyError(
                f"published.quantity '{entry.quantity}' is not a metric of this run "
                f"(metrics: {', '.join(sorted(metrics))})"
            )
        ours = metrics[entry.quantity]
        agrees = _agrees(entry, ours)
        reasons = []
        if ours is None:
            reasons.append(f"never settled within the run ({t_final_s:g} s)" if t_final_s else "never settled")
        elif not agrees:
            reasons.append(f"ours {ours:.4g} {entry.unit} is outside the {_tolerance_text(entry)}")
        if stability_note:
            reasons.append(stability_note if not agrees else "agrees, although " + stability_note)
        if not agrees:
            reasons.extend(_explain(entry.quantity, metrics))
            if entry.note:
                reasons.append(entry.note)
        rows.append(
            {
                "quantity": entry.quantity,
                "unit": entry.unit,
                "published": entry.value,
                "relation": entry.relation,
                "ours": ours,
                "verdict": "agrees" if agrees else "differs",
                "reason": "; ".join(reasons),
                "source": entry.source,
            }
        )
    return rows


def comparison_markdown(rows, title):
    """The comparison rows as a Markdown document."""
    lines = [
        f"# {title}: ours against the published numbers",
        "",
        "| quantity | unit | published | ours | verdict | reason | source |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        ours = "never" if r["ours"] is None else f"{r['ours']:.4g}"
        pub = {"approx": "≈ ", "greater": "> ", "less": "< "}[r["relation"]] + f"{r['published']:g}"
        cells = [r["quantity"], r["unit"], pub, ours, f"**{r['verdict']}**", r["reason"], r["source"]]
        lines.append("| " + " | ".join(str(c).replace("|", "\\|") for c in cells) + " |")
    return "\n".join(lines) + "\n"
