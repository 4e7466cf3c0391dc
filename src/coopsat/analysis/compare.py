"""Compare a run's metrics with the source paper's published numbers, and explain differences.

Each ``[[published]]`` entry of a scenario becomes one row: quantity, unit, published value,
ours, verdict ("agrees" or "differs") and a reason. A difference is a finding, not a failure:
the reason says what the tool knows about it (a failed design-time check such as an unstable
sampled-data loop, a quantity that never settled within the run, the paper module's
explanations, or the scenario's own note on what differs from the paper's set-up).
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


def _explain(quantity, metrics, explainers):
    sentences = []
    for key, explainer in explainers.items():
        if quantity == key or (key.startswith("_") and quantity.endswith(key)):
            sentence = explainer(quantity, metrics)
            if sentence:
                sentences.append(sentence)
    return sentences


def compare_published(published, metrics, design_note=None, t_final_s=None, explainers=None):
    """Rows of the comparison table.

    Parameters
    ----------
    published : sequence of coopsat.scenarios.schema.Published
    metrics : dict
        From :func:`coopsat.analysis.metrics.run_metrics` (plus design-time entries).
    design_note : str, optional
        The failed design-time checks in one line (e.g. an unstable sampled-data loop).
    t_final_s : float, optional
        Run length, quoted when a quantity never settled.
    explainers : dict, optional
        Explanations of a difference by metric name or name suffix (``"_x_s"`` matches every
        name ending so): ``(quantity, metrics) -> str or None``; from the run's paper modules
        (:func:`coopsat.analysis.papers.explainers`).

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
        if design_note:
            reasons.append(design_note if not agrees else "agrees, although " + design_note)
        if not agrees:
            reasons.extend(_explain(entry.quantity, metrics, explainers or {}))
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
