"""``coopsat campaign report DIR``: statistics, failures and sensitivities of a campaign, in one
self-contained HTML page (figures embedded) beside its PNGs.

A summary first (the campaign, its runs and failures, the headline metrics with mean ± σ and
how many runs reached them, the wall time of its calls); then per metric over the ok runs: in
how many it was reached (a finite number; None, a time never reached, is not), and over those
mean, σ, min, P1, P5, P50, P95, P99, max; the failed runs with their reason and parameters; for
each metric the dispersed parameters it is most sensitive to, by Spearman rank correlation over
the runs (each component of a vector parameter on its own); and, for every time series the
campaign kept, the envelope over the runs (mean, ±3σ stopped at 0, min–max) of its size: the
norm over its components, the largest over spacecraft. Every axis names its unit, taken from
the name's suffix (:func:`unit_of`) or, for a time series, from what the run recorded.
"""

import base64
import html
import io
import json
from pathlib import Path

import numpy as np

from coopsat.workflows.campaign.consistency import pooled_nees, pooled_nees_html
from coopsat.workflows.campaign.runner import MARKER, read_calls, read_results, read_series
from coopsat.workflows.campaign.spec import CampaignError
from coopsat.workflows.folders import atomic_folder

FIXED = ("run_id", "status", "reason", "seed", "params")
PERCENTILES = (1.0, 5.0, 50.0, 95.0, 99.0)
HEADLINE_MAX = 6
"""Most metrics in the summary above the full table."""

UNIT_SUFFIXES = {
    "_rad_s_sqrt_s": "rad/s/√s", "_m3_s2": "m³/s²", "_rad_s": "rad/s", "_m_s": "m/s", "_1_s": "1/s",
    "_kgm2": "kg·m²", "_nms": "N·m·s", "_am2": "A·m²", "_ns": "N·s", "_nm": "N·m", "_arcsec": "arcsec",
    "_deg": "deg", "_rad": "rad", "_kg": "kg", "_km": "km", "_s": "s", "_m": "m", "_n": "N",
    "_percent": "%", "_probability": "1", "_bits": "bits", "_firings": "firings",
}
"""A name's unit from its suffix (coopsat's names end in their unit: docs/scenarios.md)."""


def unit_of(name):
    """The unit a metric's or a scenario field's name ends in (``"s"`` for ``sync_time_s``,
    ``"rad/s"`` for ``spacecraft.0.omega_b_rad_s[2]``), or None when it names none.

    A field path counts by its last key, a vector's component (``[i]``) aside. One trailing
    qualifier may follow the unit (``position_error_3sigma_m_dep1``,
    ``switch_convergence_s_reference``). The longest matching suffix wins (``_rad_s``, not
    ``_s``)."""
    key = name.split("[")[0].rsplit(".", 1)[-1]
    for stem in (key, key.rsplit("_", 1)[0]):
        for suffix in sorted(UNIT_SUFFIXES, key=len, reverse=True):
            if stem.endswith(suffix) and len(stem) > len(suffix):
                return UNIT_SUFFIXES[suffix]
    return None


def axis_label(name, unit=None):
    """``name (unit)`` for a figure's axis, the unit from the name when not given."""
    unit = unit or unit_of(name)
    return f"{name} ({unit or 'unit not in its name'})"


def number(x):
    """A statistic for the page: 4 significant digits, ``0`` for zero, ``—`` for none."""
    if x is None:
        return "—"
    return "0" if x == 0 else f"{x:.4g}"


def mean_and_spread(v):
    """Mean and sample standard deviation (ddof 1) of ``v``, (k,) finite, k ≥ 1.

    Equal values give their value and exactly 0 (summing them in floating point would leave
    a spread of rounding noise, 1e-18 of nothing); a single value has σ 0; the mean is kept
    within [min, max], which rounding can also leave."""
    lo, hi = float(v.min()), float(v.max())
    if lo == hi:
        return lo, 0.0
    return min(max(float(v.mean()), lo), hi), float(v.std(ddof=1))


def metric_names(rows):
    """Every metric any row has, in the order the runs report them."""
    return [k for k in dict.fromkeys(k for r in rows for k in r) if k not in FIXED]


def statistics(rows):
    """Per metric over ``rows`` (the ok runs): ``runs`` (how many rows), ``n`` (how many have
    it as a finite number: it was reached), ``nonfinite`` (how many have it infinite or NaN,
    an unbounded margin), then ``mean``, ``std``, ``min``, ``p1`` … ``p99``, ``max`` over those
    ``n`` (None when n = 0). A metric that is None in a run (a time never reached) counts as
    not reached there; one none of the runs reached is kept, with n = 0."""
    out = {}
    for name in metric_names(rows):
        given = np.array([r[name] for r in rows if r.get(name) is not None], dtype=float)
        v = given[np.isfinite(given)]
        s = {"runs": len(rows), "n": int(v.size), "nonfinite": int(given.size - v.size)}
        if v.size:
            mean, std = mean_and_spread(v)
            s.update(mean=mean, std=std, min=float(v.min()),
                     **{f"p{p:g}": float(x) for p, x in zip(PERCENTILES, np.percentile(v, PERCENTILES))}, max=float(v.max()))
        else:
            s.update(dict.fromkeys(["mean", "std", "min", *(f"p{p:g}" for p in PERCENTILES), "max"]))
        out[name] = s
    return out


def reached(s):
    """``reached in k of N runs`` of one metric's :func:`statistics`."""
    note = f" ({s['nonfinite']} not finite)" if s["nonfinite"] else ""
    return f"reached in {s['n']} of {s['runs']} runs{note}"


def headline_metrics(stats, scenario_toml):
    """The few metrics the summary shows: those the scenario's ``[[published]]`` numbers name
    (the paper's own figures), else those the dispersions moved (σ > 0, or not reached in
    every run); at most :data:`HEADLINE_MAX`, in table order when not published."""
    import tomllib

    published = [p.get("quantity") for p in tomllib.loads(scenario_toml).get("published", [])]
    names = [q for q in dict.fromkeys(published) if q in stats]
    if not names:
        names = [k for k, s in stats.items() if s["n"] < s["runs"] or (s["std"] or 0.0) > 0]
    return names[:HEADLINE_MAX]


def parameter_columns(rows):
    """Each dispersed scalar (a vector's components apart, ``path[i]``) over the rows: dict of
    name -> (len(rows),) array."""
    cols = {}
    for k, r in enumerate(rows):
        for path, value in json.loads(r["params"]).items():
            items = [(f"{path}[{i}]", v) for i, v in enumerate(value)] if isinstance(value, list) else [(path, value)]
            for name, v in items:
                if isinstance(v, (int, float)) and not isinstance(v, bool):
                    cols.setdefault(name, np.full(len(rows), np.nan))[k] = float(v)
    return cols


def sensitivities(rows, top=3):
    """Per metric, the ``top`` parameters with the largest |Spearman ρ| over the ok runs:
    list of ``(parameter, rho)``."""
    from scipy.stats import spearmanr

    ok = [r for r in rows if r["status"] == "ok"]
    params = parameter_columns(ok)
    out = {}
    for name in metric_names(ok):
        y = np.array([np.nan if r.get(name) is None else r[name] for r in ok], dtype=float)
        found = []
        for p, x in params.items():
            m = np.isfinite(x) & np.isfinite(y)
            if m.sum() >= 3 and np.ptp(x[m]) > 0 and np.ptp(y[m]) > 0:
                rho = float(spearmanr(x[m], y[m]).statistic)
                if np.isfinite(rho):
                    found.append((p, rho))
        out[name] = sorted(found, key=lambda t: -abs(t[1]))[:top]
    return out


def series_sizes(series):
    """Per kept variable, its size over time for every run, ``(runs, T)``: the Euclidean norm
    over its component dimensions (|x| for a scalar), then the largest over spacecraft. A size
    is never negative (the envelope's band stops at 0)."""
    out = {}
    for name, da in series.data_vars.items():
        per_craft = "spacecraft" in da.dims
        components = [d for d in da.dims if d not in ("run", "time", "spacecraft")]
        v = np.asarray(da.transpose("run", "time", *(["spacecraft"] if per_craft else []), *components).values, dtype=float)
        v = np.linalg.norm(v.reshape(*v.shape[:2 + per_craft], -1), axis=-1)
        out[name] = np.nanmax(v, axis=-1) if per_craft else v
    return out


def series_label(da):
    """The y label of a kept variable's size (:func:`series_sizes`), with the unit the run
    recorded (campaign folders from before units were kept say so)."""
    where = ", largest over spacecraft" if "spacecraft" in da.dims else ""
    return f"|{da.name}|{where} ({da.attrs.get('units') or 'unit not stored'})"


def _png(fig):
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    return buf.getvalue()


def summary_html(spec, name, rows, stats, headline, calls):
    """The summary above the full table: the campaign, its runs and failures, the headline
    metrics (mean ± σ, how many runs reached them) and the wall time of the calls that ran it."""
    campaign = spec["campaign"]
    ok = sum(r["status"] == "ok" for r in rows)
    wall = (f"{sum(c['wall_s'] for c in calls):.1f} s over {len(calls)} call{'s' * (len(calls) != 1)} of "
            "<code>campaign run</code>" if calls else "not recorded (a folder from before it was)")
    about = f": {html.escape(campaign['description'])}" if campaign.get("description") else ""
    items = [f"<li>Campaign <b>{html.escape(name)}</b>{about}; "
             f"scenario <code>{html.escape(campaign['scenario'])}</code>; master seed {campaign['master_seed']}.</li>",
             f"<li>Runs: {len(rows)} of {campaign['runs']} finished, {ok} ok, {len(rows) - ok} failed.</li>",
             f"<li>Wall time: {wall}.</li>"]
    for m in headline:
        st, unit = stats[m], unit_of(m)
        value = f"{number(st['mean'])} ± {number(st['std'])}{' ' + unit if unit else ''}, " if st["n"] else ""
        items.append(f"<li><code>{html.escape(m)}</code>: {value}{reached(st)}.</li>")
    return "<h2>Summary</h2><ul>" + "".join(items) + "</ul>"


def statistics_html(stats, sens):
    """The full table: one row per metric."""
    keys = ("mean", "std", "min", *(f"p{p:g}" for p in PERCENTILES), "max")
    head = ("metric", "unit", "reached in", "mean", "σ", "min", *(f"P{p:g}" for p in PERCENTILES), "max",
            "most sensitive to (Spearman ρ)")
    out = ["<h2>Statistics</h2><table><tr>" + "".join(f"<th>{h}</th>" for h in head) + "</tr>"]
    for name, s in stats.items():
        top = ", ".join(f"{html.escape(p)} ({rho:+.2f})" for p, rho in sens.get(name, []))
        out.append(f"<tr><td>{html.escape(name)}</td><td>{html.escape(unit_of(name) or '')}</td>"
                   f"<td>{reached(s).removeprefix('reached in ')}</td>"
                   + "".join(f"<td>{number(s[k])}</td>" for k in keys) + f"<td>{top}</td></tr>")
    return "".join(out) + "</table>"


def write_report(out_dir):
    """Write ``report/`` (index.html with everything, and the PNGs) into a campaign folder.

    Returns
    -------
    Path
        The HTML page.
    """
    from coopsat.plots.campaign import envelope_figure, histogram_figure, scatter_figure

    out_dir = Path(out_dir)
    if not (out_dir / MARKER).is_file():
        raise CampaignError(f"{out_dir}: not a campaign folder (no {MARKER})")
    spec = json.loads((out_dir / MARKER).read_text())
    rows = read_results(out_dir).to_pylist()
    if not rows:
        raise CampaignError(f"{out_dir}: no finished batch yet (run `coopsat campaign run` first)")
    ok = [r for r in rows if r["status"] == "ok"]
    failed = [r for r in rows if r["status"] != "ok"]
    stats = statistics(ok)
    sens = sensitivities(rows)
    params = parameter_columns(ok)
    headline = headline_metrics(stats, spec["scenario_toml"])
    calls = read_calls(out_dir)
    name = Path(spec.get("campaign_file", "")).stem or spec["campaign"]["scenario"]
    nees = pooled_nees(ok)
    parts = [f"<h1>Campaign {html.escape(name)}</h1>", summary_html(spec, name, rows, stats, headline, calls),
             pooled_nees_html(nees), statistics_html(stats, sens)]
    figures = {}
    for metric, s in stats.items():
        y = np.array([np.nan if r.get(metric) is None else r[metric] for r in ok], dtype=float)
        v = y[np.isfinite(y)]
        if s["n"] > 1 and np.ptp(v) > 0:
            figures[f"hist_{metric}"] = _png(histogram_figure(v, axis_label(metric)))
            if sens.get(metric):
                p, rho = sens[metric][0]
                figures[f"scatter_{metric}"] = _png(scatter_figure(params[p], y, axis_label(p), axis_label(metric), rho))
    series = read_series(out_dir)
    if series is not None:
        t = np.asarray(series["time"].values, dtype=float)
        for var, v in series_sizes(series).items():
            # A size (a norm) is never negative: its −3σ band stops at 0.
            figures[f"envelope_{var}"] = _png(envelope_figure(t, v, series_label(series[var]), floor=0.0))
    parts.append(f"<h2>Failed runs ({len(failed)})</h2>")
    if failed:
        parts.append("<table><tr><th>run</th><th>reason</th><th>parameters</th></tr>" + "".join(
            f"<tr><td>{r['run_id']}</td><td>{html.escape(r['reason'])}</td><td><code>{html.escape(r['params'])}</code></td></tr>"
            for r in failed[:500]) + "</table>")
        if len(failed) > 500:
            parts.append(f"<p>… and {len(failed) - 500} more (all in batches/*.parquet).</p>")
    parts.append("<h2>Figures</h2>")
    for stem, data in figures.items():
        parts.append(f'<figure><img alt="{html.escape(stem)}" src="data:image/png;base64,{base64.b64encode(data).decode()}">'
                     f"<figcaption>{html.escape(stem)}</figcaption></figure>")
    page = ("<!doctype html><html><head><meta charset='utf-8'><title>coopsat campaign report</title><style>"
            "body{font-family:sans-serif;max-width:1100px;margin:auto}table{border-collapse:collapse;font-size:13px}"
            "td,th{border:1px solid #ccc;padding:2px 6px;text-align:right}td:first-child{text-align:left}</style></head><body>"
            + "\n".join(parts) + "</body></html>\n")
    summary = {"runs": len(rows), "failed": len(failed), "wall_s": sum(c["wall_s"] for c in calls) if calls else None,
               "headline": headline}
    with atomic_folder(out_dir / "report", CampaignError) as tmp:
        (tmp / "index.html").write_text(page)
        (tmp / "statistics.json").write_text(
            json.dumps({"summary": summary, "statistics": stats, "sensitivities": sens, "navigation_consistency": nees},
                       indent=2) + "\n")
        for stem, data in figures.items():
            (tmp / f"{stem}.png").write_bytes(data)
    return out_dir / "report" / "index.html"
