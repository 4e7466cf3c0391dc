"""``coopsat campaign report DIR``: statistics, failures and sensitivities of a campaign, in one
self-contained HTML page (figures embedded) beside its PNGs.

Statistics per metric over the runs that finished with it (count, mean, σ, min, P1, P5, P50,
P95, P99, max); the failed runs with their reason and parameters; and for each metric the
dispersed parameters it is most sensitive to, by Spearman rank correlation over the runs
(each component of a vector parameter on its own); and, for every time series the campaign
kept, the envelope over the runs (mean, ±3σ, min–max) of its size: the norm over its
components, the largest over spacecraft.
"""

import base64
import html
import io
import json
from pathlib import Path

import numpy as np

from coopsat.workflows.campaign.runner import MARKER, read_results, read_series
from coopsat.workflows.campaign.spec import CampaignError
from coopsat.workflows.folders import atomic_folder

FIXED = ("run_id", "status", "reason", "seed", "params")
PERCENTILES = (1.0, 5.0, 50.0, 95.0, 99.0)


def statistics(rows):
    """Per metric: ``n``, ``mean``, ``std``, ``min``, ``p1`` … ``p99``, ``max`` over the runs
    that have it (finite). Metrics no run has are left out."""
    names = [k for k in dict.fromkeys(k for r in rows for k in r) if k not in FIXED]
    out = {}
    for name in names:
        v = np.array([r.get(name) for r in rows if r.get(name) is not None], dtype=float)
        v = v[np.isfinite(v)]
        if v.size == 0:
            continue
        out[name] = {"n": int(v.size), "mean": float(v.mean()), "std": float(v.std(ddof=1)) if v.size > 1 else 0.0,
                     "min": float(v.min()), **{f"p{p:g}": float(x) for p, x in zip(PERCENTILES, np.percentile(v, PERCENTILES))},
                     "max": float(v.max())}
    return out


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
    for name in statistics(ok):
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
    """Per kept variable, its size over time for every run, ``(runs, T)``: the norm over its
    last (component) dimension, then the largest over the remaining ones (spacecraft)."""
    out = {}
    for name, da in series.data_vars.items():
        v = np.asarray(da.transpose("run", "time", ...).values, dtype=float)
        if v.ndim > 2:
            v = np.linalg.norm(v, axis=-1)
        while v.ndim > 2:
            v = np.nanmax(v, axis=-1)
        out[name] = v
    return out


def _png(fig):
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    return buf.getvalue()


def write_report(out_dir):
    """Write ``report/`` (index.html with everything, and the PNGs) into a campaign folder.

    Returns
    -------
    Path
        The HTML page.
    """
    from coopsat.plots.campaign import histogram_figure, scatter_figure

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
    campaign = spec["campaign"]
    parts = [f"<h1>Campaign: {html.escape(campaign.get('description') or campaign['scenario'])}</h1>",
             f"<p>Scenario <code>{html.escape(campaign['scenario'])}</code>; {len(rows)} of {campaign['runs']} runs finished "
             f"({len(ok)} ok, {len(failed)} failed); master seed {campaign['master_seed']}.</p>",
             "<h2>Statistics</h2><table><tr><th>metric</th>" + "".join(f"<th>{h}</th>" for h in
             ("n", "mean", "σ", "min", *(f"P{p:g}" for p in PERCENTILES), "max", "most sensitive to (Spearman ρ)")) + "</tr>"]
    figures = {}
    for name, s in stats.items():
        top = ", ".join(f"{html.escape(p)} ({rho:+.2f})" for p, rho in sens.get(name, []))
        parts.append(f"<tr><td>{html.escape(name)}</td>" + "".join(
            f"<td>{s[k]:.6g}</td>" if k != "n" else f"<td>{s[k]}</td>"
            for k in ("n", "mean", "std", "min", *(f"p{p:g}" for p in PERCENTILES), "max")) + f"<td>{top}</td></tr>")
        v = np.array([r[name] for r in ok if r.get(name) is not None], dtype=float)
        v = v[np.isfinite(v)]
        if s["n"] > 1 and np.ptp(v) > 0:
            figures[f"hist_{name}"] = _png(histogram_figure(v, name))
            if sens.get(name):
                p, rho = sens[name][0]
                y = np.array([np.nan if r.get(name) is None else r[name] for r in ok], dtype=float)
                figures[f"scatter_{name}"] = _png(scatter_figure(params[p], y, p, name, rho))
    parts.append("</table>")
    series = read_series(out_dir)
    if series is not None:
        from coopsat.plots.campaign import envelope_figure

        t = np.asarray(series["time"].values, dtype=float)
        for name, v in series_sizes(series).items():
            figures[f"envelope_{name}"] = _png(envelope_figure(t, v, f"|{name}| (largest over spacecraft)"))
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
    with atomic_folder(out_dir / "report", CampaignError) as tmp:
        (tmp / "index.html").write_text(page)
        (tmp / "statistics.json").write_text(json.dumps({"statistics": stats, "sensitivities": sens}, indent=2) + "\n")
        for stem, data in figures.items():
            (tmp / f"{stem}.png").write_bytes(data)
    return out_dir / "report" / "index.html"
