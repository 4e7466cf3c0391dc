"""``report.html``: one self-contained, offline page per run.

The page holds Plotly's JavaScript (from the ``plotly`` wheel, read as a file: the Python
package is never imported, so writing a report costs no import time), the run's data as JSON
and :file:`report.js`, which draws the 3D view, the network and the time series and ties them
to one time slider. Tables (published comparison, design-time checks, metrics) are plain HTML
written here. Nothing is fetched: the page names no ``http(s)`` resource.
"""

import base64
import html
import importlib.util
import json
import math
from pathlib import Path

import numpy as np

from coopsat.core.errors import PlatformError

MAX_SERIES_POINTS = 2000
"""Most samples drawn per time series: a long record is decimated by a whole stride (hover
reads recorded values, never interpolated ones)."""


class ReportError(PlatformError):
    """The report cannot be made (its JavaScript library is missing)."""


def plotly_js():
    """Plotly's minified JavaScript bundle, as shipped in the ``plotly`` wheel.

    Raises
    ------
    ReportError
        When the ``plotly`` distribution is not installed.
    """
    spec = importlib.util.find_spec("plotly")
    if spec is None or not spec.submodule_search_locations:
        raise ReportError("report.html needs the 'plotly' package (its JavaScript bundle): pip install plotly")
    path = Path(next(iter(spec.submodule_search_locations))) / "package_data" / "plotly.min.js"
    if not path.is_file():
        raise ReportError(f"plotly is installed without its JavaScript bundle ({path} is missing)")
    return path.read_text(encoding="utf-8")


def packed(values):
    """An array as base64 of little-endian float32 (NaN kept), as :file:`report.js` decodes it."""
    return base64.b64encode(np.ascontiguousarray(values, dtype="<f4").tobytes()).decode("ascii")


def _stride(n):
    return max(1, math.ceil(n / MAX_SERIES_POINTS))


def _finite(value):
    """A finite number as a float, anything else (None, inf, NaN) as None (strict JSON)."""
    return float(value) if value is not None and math.isfinite(value) else None


def series_json(series):
    """The time-series charts: per series, its label, unit, scale and one trace per line.

    Parameters
    ----------
    series : sequence of coopsat.analysis.series.Series
        Each with ``values`` of dims (time,), (time, spacecraft) or (time, spacecraft, one more).

    Returns
    -------
    list of dict
    """
    charts = []
    for s in series:
        v = s.values.transpose("time", ...)
        step = _stride(v.sizes["time"])
        t = v["time"].values[::step]
        if v.ndim == 1:
            charts.append({"name": s.name, "label": s.label, "unit": s.unit, "log": bool(s.log_scale), "t": packed(t),
                           "threshold": _finite(s.threshold), "traces": [{"name": s.name, "color": 0, "y": packed(v.values[::step])}]})
            continue
        # The decimated record read out of xarray once: one selection per spacecraft costs
        # 0.2 ms, the page of a formation of 1e4 spacecraft 13 s.
        v = v.transpose("time", "spacecraft", ...)
        values = v.values[::step]  # (time, spacecraft) or (time, spacecraft, extra)
        names = [str(sc) for sc in v["spacecraft"].values]
        if values.ndim == 2:
            traces = [{"name": sc, "color": k, "y": packed(values[:, k])} for k, sc in enumerate(names)]
        else:
            labels = [str(label) for label in v[v.dims[2]].values]
            traces = [{"name": f"{sc} {label}", "color": k, "dash": c, "y": packed(values[:, k, c])}
                      for k, sc in enumerate(names) for c, label in enumerate(labels)]
        charts.append({"name": s.name, "label": s.label, "unit": s.unit, "log": bool(s.log_scale), "t": packed(t),
                       "threshold": _finite(s.threshold), "traces": traces})
    return charts


def scene_json(scene):
    """The 3D view's arrays (:class:`coopsat.reports.scene.Scene`) as the page reads them."""
    return {
        "frame": scene.frame,
        "axis_titles": list(scene.axis_titles),
        "positions": packed(scene.positions),
        "trails": packed(scene.trails),
        "body_axes": None if scene.body_axes is None else packed(scene.body_axes),
        "axis_length": float(scene.axis_length),
        "central_body": None if scene.central_body is None else [scene.central_body[0], float(scene.central_body[1])],
        "targets": None if scene.targets is None else packed(scene.targets),
        "note": scene.note,
    }


def network_json(view, frames):
    """The network panel (:class:`coopsat.reports.network_view.NetworkView`) at the slider's
    record indices ``frames``."""
    return {
        "xy": view.xy.tolist(),
        "epoch_start_s": view.epoch_start_s,
        "epochs": [[[k.transmitter, k.receiver, k.state, k.hops, k.delay_s] for k in links] for links in view.epochs],
        "tau_s": None if view.tau_s is None else packed(view.tau_s[frames]),
        "dropout_probability": view.dropout_probability,
        "flags": {name: packed(v[frames]) for name, v in view.node_flags.items()},
    }


def _number(value):
    if value is None:
        return "—"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return f"{value:.6g}"
    return html.escape(str(value))


def _table(header, rows, row_class=None):
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = []
    for k, row in enumerate(rows):
        cls = f' class="{row_class[k]}"' if row_class else ""
        body.append(f"<tr{cls}>" + "".join(f"<td>{cell}</td>" for cell in row) + "</tr>")
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>"


def comparison_section(rows):
    """The published numbers against ours, with the verdict and its reason."""
    if not rows:
        return ""
    cells = [[html.escape(r["quantity"]), _number(r.get("published")), _number(r.get("ours")), html.escape(r.get("unit", "")),
              f"<b>{html.escape(r['verdict'])}</b>", html.escape(r.get("reason", "")), html.escape(r.get("source", ""))]
             for r in rows]
    classes = ["ok" if r["verdict"] == "agrees" else "differs" for r in rows]
    return "<h2>Published numbers</h2>" + _table(
        ["quantity", "published", "ours", "unit", "verdict", "reason", "source"], cells, classes)


def checks_section(checks):
    """The design-time checks: each one's verdict and note."""
    if not checks:
        return ""
    cells = [[html.escape(name), "ok" if c.ok else "<b>failed</b>", html.escape(c.note)] for name, c in checks.items()]
    return "<h2>Design-time checks</h2>" + _table(["check", "result", "note"], cells,
                                                  ["ok" if c.ok else "differs" for c in checks.values()])


def metrics_section(metrics):
    """Every scalar metric (unit at the end of its name)."""
    cells = [[html.escape(k), _number(v)] for k, v in metrics.items() if v is None or isinstance(v, (int, float))]
    return "<h2>Metrics</h2>" + _table(["metric", "value"], cells)


STYLE = """
body { font-family: system-ui, sans-serif; margin: 0 1.2em 2em; color: #222; }
header p { margin: 0.2em 0; color: #555; }
#bar { position: sticky; top: 0; background: #fff; padding: 0.5em 0; border-bottom: 1px solid #ddd; z-index: 10;
       display: flex; gap: 1em; align-items: center; }
#frame { flex: 1; }
#views { display: grid; grid-template-columns: 3fr 2fr; gap: 1em; }
#scene { height: 560px; } #network { height: 560px; }
.note { color: #a15c00; font-size: 0.9em; }
table { border-collapse: collapse; margin: 0.5em 0 1.5em; font-size: 0.9em; }
td, th { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: left; vertical-align: top; }
tr.differs td { background: #fff3f0; } tr.ok td { background: #f2fbf2; }
.series { margin-bottom: 0.5em; }
"""


def page_html(title, subtitle_lines, data, sections, note=""):
    """The whole page: style, header, slider, views, tables, embedded data and scripts.

    ``data`` is the JSON :file:`report.js` reads; ``sections`` the tables' HTML.
    """
    payload = json.dumps(data, allow_nan=False, separators=(",", ":")).replace("</", "<\\/")
    script = (Path(__file__).with_name("report.js")).read_text(encoding="utf-8")
    subtitle = "".join(f"<p>{html.escape(line)}</p>" for line in subtitle_lines)
    note_html = f'<p class="note">{html.escape(note)}</p>' if note else ""
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>{STYLE}</style>
<script>{plotly_js()}</script></head>
<body>
<header><h1>{html.escape(title)}</h1>{subtitle}</header>
<div id="bar"><button id="play" type="button">play</button>
<input id="frame" type="range" min="0" max="0" value="0" step="1" aria-label="time"><span id="frame-time"></span></div>
<div id="views"><div><div id="scene"></div>{note_html}</div><div><div id="network"></div>
<p class="note">Arrows point from transmitter to receiver: green up, red lost (a link of another graph of
the run), grey relayed over several hops; labels give the delay.</p></div></div>
{''.join(sections)}
<h2>Time series</h2><div id="series"></div>
<script type="application/json" id="coopsat-data">{payload}</script>
<script>{script}</script>
</body></html>
"""
