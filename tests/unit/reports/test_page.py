"""The report page's own parts: packing, decimation, escaping, and no network address."""

import base64
import json
import re
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import xarray as xr

from coopsat.analysis.series import Series
from coopsat.reports import page


def _unpacked(text):
    return np.frombuffer(base64.b64decode(text), dtype="<f4")


def test_packed_arrays_read_back_as_float32_with_nan():
    values = np.array([[1.5, np.nan], [-2.0, 1e-30]])
    np.testing.assert_array_equal(_unpacked(page.packed(values)), values.astype(np.float32).ravel())


def test_series_are_decimated_by_a_whole_stride_and_split_per_spacecraft_and_component():
    n_t = 2 * page.MAX_SERIES_POINTS + 1
    t = np.arange(n_t) * 0.5
    values = np.arange(n_t * 2 * 3, dtype=float).reshape(n_t, 2, 3)
    rates = xr.DataArray(values, dims=("time", "spacecraft", "component"),
                         coords={"time": t, "spacecraft": ["a", "b"], "component": ["x", "y", "z"]})
    spread = xr.DataArray(np.linspace(1, 2, n_t), dims=("time",), coords={"time": t})
    charts = page.series_json([Series("rate_rad_s", "body rate", "rad/s", rates),
                               Series("spread_deg", "spread", "deg", spread, log_scale=True, threshold=float("inf"))])
    first, second = charts
    assert [tr["name"] for tr in first["traces"]] == ["a x", "a y", "a z", "b x", "b y", "b z"]
    t_drawn = _unpacked(first["t"])
    assert len(t_drawn) <= page.MAX_SERIES_POINTS and np.all(np.diff(t_drawn) == t_drawn[1] - t_drawn[0])
    step = round((t_drawn[1] - t_drawn[0]) / 0.5)
    np.testing.assert_array_equal(_unpacked(first["traces"][4]["y"]), values[::step, 1, 1].astype(np.float32))
    assert second["log"] and second["threshold"] is None and len(second["traces"]) == 1


def test_a_series_per_spacecraft_in_any_dimension_order_is_one_trace_each():
    values = np.arange(2 * 7, dtype=float).reshape(2, 7)  # (spacecraft, time)
    angle = xr.DataArray(values, dims=("spacecraft", "time"), coords={"time": np.arange(7.0), "spacecraft": ["a", "b"]})
    (chart,) = page.series_json([Series("angle_deg", "angle", "deg", angle)])
    assert [(tr["name"], tr["color"]) for tr in chart["traces"]] == [("a", 0), ("b", 1)]
    for k, tr in enumerate(chart["traces"]):
        np.testing.assert_array_equal(_unpacked(tr["y"]), values[k].astype(np.float32))


class _Markup(HTMLParser):
    """Every attribute value of the page's elements, and the text of its scripts."""

    def __init__(self):
        super().__init__()
        self.attributes, self.scripts, self._in_script = [], [], False

    def handle_starttag(self, tag, attrs):
        self.attributes += [v or "" for _, v in attrs]
        self._in_script = tag == "script"

    def handle_endtag(self, tag):
        self._in_script = False

    def handle_data(self, data):
        if self._in_script:
            self.scripts.append(data)


def test_the_page_names_no_network_address_and_its_data_survives_a_closing_tag(monkeypatch):
    monkeypatch.setattr(page, "plotly_js", lambda: "/* plotly */")
    data = {"names": ["a"], "note": "</script><script>alert(1)</script>"}
    html = page.page_html("t </script>", ["x"], data, ["<table></table>"])
    markup = _Markup()
    markup.feed(html)
    assert not any(re.search(r"https?:", v) for v in markup.attributes)
    ours = html.replace("/* plotly */", "")
    assert "http" not in ours and "src=" not in ours
    payload = next(s for s in markup.scripts if s.lstrip().startswith("{"))
    assert json.loads(payload) == data  # the closing tag stayed inside the JSON
    assert "http" not in (Path(page.__file__).with_name("report.js")).read_text()
