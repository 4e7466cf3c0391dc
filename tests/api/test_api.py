"""The public Python API (docs/api.md): scenarios as immutable values, runs in memory that
equal what the command line writes, and the workflows called with the same objects."""

import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import coopsat

SHORT = 20.0
"""Run length of the API tests, s (consensus-sync-a-stable: 40 records at 0.5 s)."""


@pytest.fixture(scope="module")
def scenario():
    return coopsat.Scenario.load("consensus-sync-a-stable").set("sim.t_final_s", SHORT)


@pytest.fixture(scope="module")
def result(scenario):
    return coopsat.run(scenario)


@pytest.fixture(scope="module")
def cli_folder(tmp_path_factory):
    """What ``coopsat run`` writes for the same scenario, from a separate process."""
    out = tmp_path_factory.mktemp("cli") / "run"
    subprocess.run(
        [sys.executable, "-m", "coopsat.cli", "run", "consensus-sync-a-stable", "--set", f"sim.t_final_s={SHORT}", "--out",
         str(out), "--no-figures", "-q"],
        check=True, capture_output=True, text=True,
    )
    return out


# --- Scenario ----------------------------------------------------------------------------------


def test_set_returns_a_new_scenario_and_leaves_the_old_one(scenario):
    changed = scenario.set("controller.alpha", 2.5)
    assert changed["controller.alpha"] == 2.5 and changed.model.controller.alpha == 2.5
    assert scenario.model.controller.alpha == 1.0
    assert changed != scenario and scenario.set("sim.t_final_s", SHORT) == scenario


def test_values_are_typed_not_parsed(scenario):
    changed = scenario.set("spacecraft.1.omega_b_rad_s", [0.0, 0.0, 0.125])
    assert changed.model.spacecraft[1].omega_b_rad_s == [0.0, 0.0, 0.125]
    # A string is a string: "2.0" is not a number to a scenario field.
    with pytest.raises(coopsat.ScenarioError, match=r"^controller\.alpha: Input should be a valid number"):
        scenario.set("controller.alpha", "2.0")


def test_every_bundled_scenario_loads():
    names = coopsat.Scenario.bundled()
    assert "consensus-sync-a" in names and len(names) >= 20
    for name in names:
        assert coopsat.Scenario.load(name).model.name == name


def test_to_dict_is_a_copy(scenario):
    d = scenario.to_dict()
    d["controller"]["alpha"] = 99.0
    assert scenario["controller.alpha"] == 1.0


def test_bad_values_raise_the_cli_line(scenario):
    with pytest.raises(coopsat.ScenarioError) as err:
        scenario.set("controller.alpha", -1.0)
    assert str(err.value) == "controller.alpha: Input should be greater than 0"
    with pytest.raises(coopsat.ScenarioError, match=r"^controler: unknown field"):
        scenario.set("controler.alpha", 1.0)
    with pytest.raises(coopsat.ScenarioError, match="not an index of a list of 5"):
        scenario.set("spacecraft.7.mass_kg", 1.0)
    with pytest.raises(coopsat.ScenarioError, match="no bundled scenario named 'no-such'"):
        coopsat.Scenario.load("no-such")
    for api_call in (coopsat.run, coopsat.Scenario.load, coopsat.validate):
        with pytest.raises(coopsat.ScenarioError, match=r"^scenario: expected a Scenario, a bundled scenario's name or a path "
                                                         r"to a \.toml file, got NoneType$"):
            api_call(None)
    # the CLI prints the same line
    proc = subprocess.run([sys.executable, "-m", "coopsat.cli", "validate", "consensus-sync-a-stable", "--set",
                           "controller.alpha=-1.0"], capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stderr.strip() == "coopsat: error: controller.alpha: Input should be greater than 0"


def test_update_sets_a_new_kind_with_its_fields(scenario):
    changed = scenario.update({"controller.kind": "none", "controller.period_s": 0.01})
    assert changed.model.controller.kind == "none"
    with pytest.raises(coopsat.ScenarioError):
        scenario.set("controller.kind", "no-such-law")


def test_toml_round_trip_and_extends(scenario, tmp_path):
    again = coopsat.Scenario.from_toml(scenario.to_toml())
    assert again == scenario
    resolved = scenario.resolved()
    assert resolved.model == scenario.model
    assert "substeps" in resolved["sim"] and "substeps" not in scenario["sim"]
    child = coopsat.Scenario.from_dict({"extends": "consensus-sync-a-stable", "name": "child", "controller": {"alpha": 2.0}})
    assert child.name == "child" and child["controller.beta"] == scenario["controller.beta"] and child["controller.alpha"] == 2.0
    (tmp_path / "base.toml").write_text(scenario.to_toml())
    local = coopsat.Scenario.from_toml('extends = "base.toml"\nseed = 4\n', base_dir=tmp_path)
    assert local.model.seed == 4 and local["sim.t_final_s"] == SHORT


# --- run ---------------------------------------------------------------------------------------


IN_TIME_ATTRS = {"created_utc", "compile_time_s", "run_time_s"}


def test_run_equals_what_the_cli_writes(result, cli_folder):
    written = xr.load_dataset(cli_folder / "result.nc", engine="h5netcdf")
    assert set(written.data_vars) == set(result.dataset.data_vars)
    for name in written.data_vars:
        np.testing.assert_array_equal(result.dataset[name].values, written[name].values, err_msg=name)
    assert {k: v for k, v in written.attrs.items() if k not in IN_TIME_ATTRS} == {
        k: v for k, v in result.dataset.attrs.items() if k not in IN_TIME_ATTRS
    }
    from coopsat.workflows.folders import json_ready

    assert json.loads((cli_folder / "metrics.json").read_text()) == json_ready(result.metrics)
    assert json.loads((cli_folder / "comparison.json").read_text()) == json_ready(result.comparison)
    for name, check in result.checks.items():
        assert written.attrs[f"check_{name}"] == check.note


def test_result_carries_its_checks_and_certificates(result):
    check = result.checks["sampled-data"]
    assert check.ok and "spectral radius" in check.note
    assert check.detail.spectral_radius < 1.0  # the certificate itself, not its text
    assert result.metrics["spectral_radius"] == check.detail.spectral_radius
    assert result.warnings == [c.note for c in result.checks.values() if not c.ok]
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.metrics = {}


def test_run_writes_nothing_unless_asked(result, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    coopsat.run(coopsat.Scenario.load("rigid-body-free").set("sim.t_final_s", 1.0))
    assert list(tmp_path.iterdir()) == []
    folder = result.save(tmp_path / "saved", figures=False)
    assert {p.name for p in Path(folder).iterdir()} == {"run.json", "result.nc", "metrics.json", "comparison.json", "comparison.md",
                                                        "report.html"}


def test_a_saved_run_reads_back_as_the_same_result(result, tmp_path):
    folder = result.save(tmp_path / "saved", figures=False, report=False)
    back = coopsat.load_run(folder)
    # metrics.json keeps 15 significant digits (workflows.folders.json_ready)
    assert back.metrics.keys() == result.metrics.keys() and back.comparison == result.comparison
    for name, value in result.metrics.items():
        assert back.metrics[name] == (None if value is None else pytest.approx(value, rel=1e-14)), name
    assert back.dataset.equals(result.dataset) and set(back.checks) == set(result.checks)
    assert back.scenario.to_dict() == result.scenario.resolved().to_dict()
    page = coopsat.report(folder)
    assert page == folder / "report.html" and "coopsat-data" in page.read_text()
    with pytest.raises(TypeError, match="out=FILE"):
        coopsat.report(result)
    with pytest.raises(coopsat.workflows.pipeline.RunFolderError, match="not a run folder"):
        coopsat.load_run(tmp_path)


def test_figures_are_matplotlib_figures(result):
    from matplotlib.figure import Figure

    figures = result.figures()
    assert {"attitude", "rates", "sync_error"} <= set(figures)
    assert all(isinstance(f, Figure) for f in figures.values())


def test_seed_replaces_the_scenarios_seed():
    s = coopsat.Scenario.load("delay-classic").set("sim.t_final_s", 2.0)
    a, b = coopsat.run(s, seed=3), coopsat.run(s.with_seed(3))
    assert a.dataset.attrs["seed"] == 3
    np.testing.assert_array_equal(a.dataset["network_tau_periods"].values, b.dataset["network_tau_periods"].values)
    c = coopsat.run(s, seed=4)
    assert not np.array_equal(a.dataset["network_tau_periods"].values, c.dataset["network_tau_periods"].values)


def test_validate_runs_the_design_checks_without_simulating(scenario):
    v = coopsat.validate(scenario.set("controller.period_s", 0.5).set("sim.dt_s", 0.01))
    assert not v.checks["sampled-data"].ok and v.checks["sampled-data"].detail.spectral_radius > 1.0
    assert v.warnings and v.estimated_run_s > 0


# --- workflows ---------------------------------------------------------------------------------


def test_run_batch_matches_single_runs(scenario, result):
    batch = coopsat.run_batch([scenario, scenario.set("controller.alpha", 2.0)])
    assert batch.n_batches == 1 and len(batch.results) == 2
    first = batch.results[0]
    for name in result.dataset.data_vars:  # a batch sums in another order: the last bits may differ
        np.testing.assert_allclose(first.dataset[name].values, result.dataset[name].values, rtol=1e-12, atol=1e-12)
    assert batch.results[1].scenario["controller.alpha"] == 2.0
    assert not np.allclose(batch.results[1].dataset["omega"].values, first.dataset["omega"].values)


def test_sweep_takes_typed_values(scenario):
    swept = coopsat.sweep(scenario, {"controller.alpha": [0.5, 2.0]}, metrics=["final_attitude_spread_deg"])
    assert [p["values"]["controller.alpha"] for p in swept.points] == [0.5, 2.0]
    assert swept.n_batches == 1


def test_pair_on_scenarios(scenario):
    paired = coopsat.pair(scenario, scenario.set("controller.alpha", 2.0), seeds=1)
    assert paired.names == ("consensus-sync-a-stable", "consensus-sync-a-stable")
    rows = {r["metric"]: r for r in paired.table()}
    assert rows["final_attitude_spread_deg"]["diff_mean"] != 0.0


def test_configure_and_public_names():
    import jax

    coopsat.validate(coopsat.Scenario.load("rigid-body-free").set("sim.t_final_s", 1.0))
    # The test process is set up as the command's (tests/conftest.py): float64 and the unrolled
    # lowering are applied; asking for them again changes nothing, asking otherwise is too late.
    coopsat.configure(unrolled_threefry=True)
    assert jax.config.jax_enable_x64
    with pytest.raises(coopsat.InputError, match="too late"):
        coopsat.configure(float64=False, unrolled_threefry=True)
    for name in coopsat.__all__:
        assert getattr(coopsat, name) is not None
    with pytest.raises(AttributeError):
        coopsat.no_such_name  # noqa: B018
