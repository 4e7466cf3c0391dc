"""``coopsat campaign report`` on a synthetic campaign folder (rows written as the runner writes
them, no Dask, no simulation): metrics never reached are counted, not dropped; a constant has
σ exactly 0; every axis names its unit; a norm's −3σ line stops at 0; a summary comes first."""

import json
import re

import numpy as np
import pytest
import xarray as xr

from coopsat.cli import EXIT_BAD_INPUT, main
from coopsat.workflows.campaign import report
from coopsat.workflows.campaign.runner import MARKER, _record_call, write_batch

CONSTANT = 0.1
"""Seven copies of 0.1 sum to a mean 1 ulp off, which numpy's σ turns into 1.5e-17."""

SCENARIO_TOML = '[[published]]\nquantity = "sync_time_s"\nvalue = 250.0\nunit = "s"\n'


def _rows():
    """Eight runs: seven ok, one failed. ``sync_time_s`` reached in four, ``never_time_s`` in
    none, ``design_period_s`` the same in all, ``fuel_l1_ns`` rising with ``controller.alpha``."""
    sync = [120.0, None, 130.0, None, 125.0, None, 125.0]
    rows = []
    for k in range(7):
        alpha = 1.0 + 0.1 * k
        rows.append({"run_id": k, "status": "ok", "reason": "", "seed": 100 + k,
                     "params": json.dumps({"controller.alpha": alpha, "spacecraft.0.omega_b_rad_s": [0.01 * k, 0.0, -0.01 * k]}),
                     "design_period_s": CONSTANT, "sync_time_s": sync[k], "never_time_s": None,
                     "fuel_l1_ns": 10.0 + alpha ** 2})
    rows.append({"run_id": 7, "status": "failed", "reason": "invalid scenario: a flat body", "seed": 107,
                 "params": json.dumps({"controller.alpha": 9.0, "spacecraft.0.omega_b_rad_s": [0.0, 0.0, 0.0]})})
    return rows


def _series():
    """``omega`` of the seven ok runs, (run, time, spacecraft, component), rad/s: one run far
    above the others, so that mean − 3σ of the size falls below 0."""
    size = np.full((7, 5), 0.01)
    size[0] = 1.0
    omega = np.zeros((7, 5, 2, 3))
    omega[:, :, 0, 2] = size
    return xr.Dataset({"omega": (("run", "time", "spacecraft", "component"), omega, {"units": "rad/s"})},
                      coords={"run": np.arange(7), "time": np.arange(5) * 10.0})


@pytest.fixture
def folder(tmp_path):
    out = tmp_path / "camp"
    (out / "batches").mkdir(parents=True)
    (out / MARKER).write_text(json.dumps({
        "campaign": {"scenario": "consensus-sync-a-stable", "runs": 8, "master_seed": 7, "description": "synthetic"},
        "scenario_toml": SCENARIO_TOML, "fields": [], "campaign_file": "/somewhere/synthetic-campaign.toml"}))
    write_batch(out, 0, _rows(), _series())
    _record_call(out, 12.25, 1)
    _record_call(out, 7.75, 0)
    return out


@pytest.fixture
def written(folder, monkeypatch):
    """The report written, its page, its statistics.json and its figures (not rasterised)."""
    figures = []
    monkeypatch.setattr(report, "_png", lambda fig: figures.append(fig) or b"")
    page = report.write_report(folder).read_text()
    return page, json.loads((folder / "report" / "statistics.json").read_text()), figures


def _row(page, metric):
    """The cells of a metric's row of the full table (text, tags stripped)."""
    row = re.search(rf"<tr><td>{metric}</td>(.*?)</tr>", page).group(0)
    return [re.sub(r"<[^>]+>", "", c) for c in re.findall(r"<td[^>]*>(.*?)</td>", row)]


def test_a_metric_never_reached_is_counted_not_dropped(written):
    page, data, _ = written
    stats = data["statistics"]
    assert stats["never_time_s"]["n"] == 0 and stats["never_time_s"]["runs"] == 7
    assert stats["never_time_s"]["mean"] is None
    assert stats["sync_time_s"]["n"] == 4 and stats["sync_time_s"]["mean"] == 125.0  # over the runs that reached it
    assert _row(page, "never_time_s")[2:4] == ["0 of 7 runs", "—"]
    assert "<th>reached in</th>" in page and _row(page, "sync_time_s")[2] == "4 of 7 runs"


def test_sigma_of_a_constant_is_exactly_zero(written):
    assert np.full(7, CONSTANT).std(ddof=1) != 0  # what the report must not print
    page, data, _ = written
    s = data["statistics"]["design_period_s"]
    assert (s["mean"], s["std"]) == (CONSTANT, 0.0)
    cells = _row(page, "design_period_s")
    assert cells[1] == "s" and cells[3:5] == ["0.1", "0"]
    assert "e-1" not in page.split("<h2>Failed")[0]  # no rounding noise anywhere in the tables


def test_summary_comes_first_with_runs_failures_headline_and_wall_time(written):
    page, data, _ = written
    summary = page[page.index("<h2>Summary"):page.index("<h2>Statistics")]
    text = re.sub(r"<[^>]+>", "", summary)
    assert "Campaign synthetic-campaign: synthetic" in text
    assert "Runs: 8 of 8 finished, 7 ok, 1 failed." in text
    assert "Wall time: 20.0 s over 2 calls of campaign run." in text
    assert "sync_time_s: 125 ± 4.082 s, reached in 4 of 7 runs." in text  # the published quantity
    assert data["summary"] == {"runs": 8, "failed": 1, "wall_s": 20.0, "headline": ["sync_time_s"]}


def test_every_axis_names_its_unit_and_a_norms_band_stops_at_zero(written):
    _, _, figures = written
    labels = {(ax.get_xlabel(), ax.get_ylabel()) for fig in figures for ax in fig.axes}
    assert ("fuel_l1_ns (N·s)", "runs") in labels  # histogram
    assert ("sync_time_s (s)", "runs") in labels
    assert ("controller.alpha (unit not in its name)", "fuel_l1_ns (N·s)") in labels  # scatter, largest |ρ|
    assert ("time (s)", "|omega|, largest over spacecraft (rad/s)") in labels  # envelope
    (envelope,) = [fig.axes[0] for fig in figures if fig.axes[0].get_xlabel() == "time (s)"]
    mean, upper, lower = [line.get_ydata() for line in envelope.get_lines()]
    assert np.all(mean - (upper - mean) < 0)  # mean − 3σ would be negative …
    np.testing.assert_array_equal(lower, 0.0)  # … the band stops at 0


@pytest.mark.parametrize(("name", "unit"), [
    ("sync_time_s", "s"), ("fuel_l1_ns", "N·s"), ("final_rate_max_rad_s", "rad/s"), ("velocity_error_3sigma_m_s", "m/s"),
    ("angular_momentum_final_nms", "N·m·s"), ("pwm_deadband_torque_nm", "N·m"), ("relative_attitude_error_max_deg", "deg"),
    ("saving_percent", "%"), ("spacecraft.0.omega_b_rad_s[2]", "rad/s"), ("spacecraft.1.inertia_kgm2[0]", "kg·m²"),
    ("position_error_3sigma_m_dep1", "m"), ("switch_convergence_s_reference", "s"), ("sensors.0.sigma_arcsec", "arcsec"),
    ("controller.alpha", None), ("disturbances.1.cd", None), ("s", None),
])
def test_unit_from_the_name_suffix(name, unit):
    assert report.unit_of(name) == unit


def test_numbers_and_spread():
    assert [report.number(x) for x in (None, 0.0, -0.0, 4300.123, 1.7e-18)] == ["—", "0", "0", "4300", "1.7e-18"]
    for x in (0.1, 0.3, 1e-3, 4300.123):
        assert report.mean_and_spread(np.full(10, x)) == (x, 0.0)
    mean, std = report.mean_and_spread(np.array([1.0, 2.0, 3.0]))
    assert (mean, std) == (2.0, 1.0)


def test_headline_without_published_numbers_is_what_the_dispersions_moved(folder):
    stats = report.statistics([r for r in _rows() if r["status"] == "ok"])
    assert report.headline_metrics(stats, "") == ["sync_time_s", "never_time_s", "fuel_l1_ns"]


def test_report_of_a_folder_that_is_not_a_campaign(tmp_path, capsys):
    assert main(["campaign", "report", str(tmp_path)]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not a campaign folder" in err[0]
