"""Metrics computed over a whole batch at once are the metrics ``coopsat run`` computes run by
run: settle times against a plain scan of the samples, every metric of a batch of dispersed
runs against each run analysed alone (a paper module with ``batch_metrics``, one without it),
and a module that defines only one of ``metrics``/``batch_metrics`` serving both."""

import types

import numpy as np
import pytest

import coopsat
from coopsat.analysis import papers
from coopsat.analysis.metrics import run_rows, settle_time_s, settle_times_s
from coopsat.workflows.analyse import analyse, analyse_batch
from coopsat.workflows.sweep import batch_record, build_runs, run_datasets, simulate_batches


def _scan(t_s, ok, hold_s):
    """The definition, sample by sample: the time after the last failing sample, if the
    condition holds at the end and has held for ``hold_s``."""
    if not ok[-1]:
        return np.nan
    k = len(ok) - 1
    while k > 0 and ok[k - 1]:
        k -= 1
    return t_s[k] if t_s[-1] - t_s[k] >= hold_s else np.nan


def test_settle_times_are_the_sample_after_the_last_failure_in_every_column():
    rng = np.random.default_rng(3)
    t = np.arange(40) * 0.5
    ok = rng.random((6, 40, 5)) < 0.9
    ok[:, -12:, :2] = True  # some columns settle, some at the very start
    ok[0, :, 0] = True
    hold = np.array([0.0, 1.0, 3.0, 5.0, 7.0, 0.0])
    got = settle_times_s(t, ok, hold[:, None], axis=1)
    want = np.array([[_scan(t, ok[r, :, k], hold[r]) for k in range(5)] for r in range(6)])
    np.testing.assert_array_equal(got, want)
    assert np.isnan(want).any() and (~np.isnan(want)).sum() >= 6
    assert settle_time_s(t, ok[0, :, 0]) == 0.0
    assert settle_time_s(t, ok[1], 1.0) == [None if np.isnan(v) else v for v in want[1]]


def test_run_rows_give_ints_floats_and_none():
    rows = run_rows({"a_s": np.array([1.5, np.nan]), "firings": np.array([3, 4])}, 2)
    assert rows == [{"a_s": 1.5, "firings": 3}, {"a_s": None, "firings": 4}]
    assert type(rows[0]["firings"]) is int and type(rows[0]["a_s"]) is float
    assert run_rows({}, 3) == [{}, {}, {}]


def _batch(scenario, sets):
    models = [scenario.update(s).model for s in sets]
    paths = sorted({p for s in sets for p in s})
    builds, stacked, _ = build_runs(models, paths)
    (group, out), = simulate_batches(builds, stacked=stacked, every_core=False)[0]
    return builds, out


def _assert_same(batch_rows, single_rows):
    for got, want in zip(batch_rows, single_rows, strict=True):
        assert list(got) == list(want)  # the same names, in the same order
        for name, value in want.items():
            if value is None or isinstance(value, int):
                assert got[name] == value, name
            else:
                # A batch sums in another order than a run alone, and that order depends on the
                # CPU's vector width: agreement to far above rounding, not bits.
                np.testing.assert_allclose(got[name], value, rtol=1e-9, atol=1e-12, err_msg=name)


@pytest.mark.parametrize("name, sets", [
    ("consensus-track-stable", [  # law (4): tracking, per-spacecraft settle and spin-down times
        {"sim.t_final_s": 60.0},
        {"sim.t_final_s": 60.0, "spacecraft.1.omega_b_rad_s": [0.2, 1.0, 0.0], "analysis.sync_attitude_deg": 5.0},
        {"sim.t_final_s": 60.0, "seed": 7, "analysis.settle_hold_s": 20.0, "analysis.sync_rate_rad_s": 0.05},
    ]),
    ("consensus-sync-a-stable", [{"sim.t_final_s": 40.0, "spacecraft.0.omega_b_rad_s": [w, 0.0, 0.5]}
                                 for w in (0.5, 0.1, 0.0)]),
    ("deepspace-square-to-line-lqr", [{"sim.t_final_s": 3000.0, "seed": s} for s in (0, 1)]),
    ("delay-designed", [{"sim.t_final_s": 20.0, "seed": s} for s in (0, 1)]),  # a module without batch_metrics
])
def test_a_batch_analysed_at_once_is_each_run_analysed_alone(name, sets):
    builds, out = _batch(coopsat.Scenario.load(name), sets)
    record = batch_record(builds, out)
    assert record is not None and record.sizes["run"] == len(sets)
    single = [analyse(b, ds, compare=False)[0] for b, ds in zip(builds, run_datasets(builds, out))]
    _assert_same(analyse_batch(builds, record), single)
    if name.startswith("consensus-track"):
        assert any(v is not None for v in single[0].values()) and single[0] != single[1]


def _fake(monkeypatch, module):
    monkeypatch.setattr(papers, "paper_modules", lambda built: [module])
    monkeypatch.setattr(papers, "source_of", lambda m, built: f"analysis module '{m.__name__}'")


def test_a_module_with_only_batch_metrics_serves_a_single_run(monkeypatch):
    builds, out = _batch(coopsat.Scenario.load("consensus-sync-a-stable"),
                         [{"sim.t_final_s": 2.0, "seed": s} for s in (0, 1)])
    record = batch_record(builds, out)
    seen = []

    def batch_metrics(ds, blds):
        seen.append(ds.sizes["run"])
        return {"last_rate_x_rad_s": ds["omega"].values[:, -1, 0, 0], "never_s": np.full(ds.sizes["run"], np.nan)}

    _fake(monkeypatch, types.ModuleType("batch_only"))
    papers.paper_modules(None)[0].batch_metrics = batch_metrics
    rows = papers.paper_batch_metrics(record, builds)
    single = papers.paper_metrics(run_datasets(builds, out)[1], builds[1])
    assert seen == [2, 1]
    assert single == rows[1] and single["never_s"] is None
    assert single["last_rate_x_rad_s"] == float(record["omega"].values[1, -1, 0, 0])


def test_a_module_with_only_metrics_is_run_run_by_run_in_a_batch(monkeypatch):
    builds, out = _batch(coopsat.Scenario.load("consensus-sync-a-stable"),
                         [{"sim.t_final_s": 2.0, "seed": s} for s in (0, 1, 2)])
    module = types.ModuleType("per_run")
    module.metrics = lambda ds, built: {"seed_echo": float(built.scenario.seed), "runs_seen": float(ds["omega"].ndim)}
    _fake(monkeypatch, module)
    rows = papers.paper_batch_metrics(batch_record(builds, out), builds)
    assert rows == [{"seed_echo": float(s), "runs_seen": 3.0} for s in (0, 1, 2)]  # (time, spacecraft, component)


def test_a_failing_batch_module_costs_only_its_numbers(monkeypatch):
    builds, out = _batch(coopsat.Scenario.load("consensus-sync-a-stable"),
                         [{"sim.t_final_s": 2.0, "seed": s} for s in (0, 1)])
    module = types.ModuleType("broken")
    module.batch_metrics = lambda ds, blds: 1 / 0
    _fake(monkeypatch, module)
    failures = []
    rows = analyse_batch(builds, batch_record(builds, out), failures)
    assert [f.stage for f in failures] == ["metrics"] and "ZeroDivisionError" in failures[0].error
    assert all("final_rate_max_rad_s" in r for r in rows)
    with pytest.raises(ZeroDivisionError):
        analyse_batch(builds, batch_record(builds, out))
