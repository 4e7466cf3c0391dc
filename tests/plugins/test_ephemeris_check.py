"""The third-body disturbance checks its analytic Sun and Moon against JPL DE421 before the run,
and says so in one line when it cannot."""

import pytest

import coopsat.astro.ephemeris as ephemeris
from coopsat.workflows.pipeline import prepare
from coopsat.scenarios.load import load_scenario

SCENARIO = """
name = "third-body-check"
[sim]
t_final_s = 86400.0
dt_s = 10.0
record_interval_s = 3600.0
[orbit]
{scale} = "{epoch}"
[[spacecraft]]
inertia_kgm2 = [1.0, 1.0, 1.0]
[spacecraft.elements]
a_m = 6878137.0
e = 0.001
i_deg = 51.6
raan_deg = 0.0
argp_deg = 0.0
mean_anomaly_deg = 0.0
[[disturbances]]
kind = "third-body"
"""


def _check(tmp_path, epoch="2024-03-20T00:00:00", scale="epoch_utc"):
    path = tmp_path / "tb.toml"
    path.write_text(SCENARIO.format(epoch=epoch, scale=scale), encoding="utf-8")
    return prepare(load_scenario(path)).checks["ephemeris"]


def test_the_run_states_how_far_the_series_are_from_de421(tmp_path):
    check = _check(tmp_path)
    assert check.ok and "DE421" in check.note
    # Within the series' accuracy (tests/unit/astro/test_ephemeris.py), and not zero: really compared.
    assert 0.0 < check.metrics["ephemeris_sun_deg"] < 0.2
    assert 1e3 < check.metrics["ephemeris_moon_m"] < 6e5


def test_far_from_j2000_the_check_warns(tmp_path):
    # The Sun's fixed perigee drifts 0.32° a century: by 2053 it is beyond 0.17°; in 1900, 0.32°.
    check = _check(tmp_path, epoch="1900-06-01T00:00:00", scale="epoch_tt")  # no UTC before 1960
    assert not check.ok and "beyond the series' accuracy" in check.note


def test_without_the_extra_the_check_says_so(tmp_path, monkeypatch):
    monkeypatch.setattr(ephemeris, "ephemeris_difference", lambda *a, **k: None)
    check = _check(tmp_path)
    assert check.ok and "coopsat[ephemeris]" in check.note
