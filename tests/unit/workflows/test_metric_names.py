"""The metric names of a scenario (the published-quantity check of `coopsat validate` and
`coopsat run`) kept in the persistent cache: equal to those worked out, and worked out again
for another scenario or a plug-in the key cannot name (issue 26)."""

import pytest

from coopsat.core import runtime
from coopsat.scenarios.document import Scenario
from coopsat.workflows import pipeline


@pytest.fixture
def private_disk(tmp_path, monkeypatch):
    monkeypatch.setattr(runtime, "persistent_cache_dir", lambda kind: tmp_path / f"coopsat-{kind}")
    return tmp_path / "coopsat-design"


def _built(name, **sets):
    doc = Scenario.load(name)
    for key, value in sets.items():
        doc = doc.set(key.replace("__", "."), value)
    return pipeline.prepare(doc.model, check_published=False)


def test_kept_names_equal_worked_out_names_and_are_not_worked_out_again(private_disk, monkeypatch):
    built = _built("consensus-sync-a-stable")
    fresh = pipeline._metric_names(built)
    assert pipeline.metric_names(built) == fresh
    assert "sync_time_s" in fresh and len(list(private_disk.glob("metric_names-*.pickle"))) == 1
    monkeypatch.setattr(pipeline, "_metric_names", lambda built: pytest.fail("kept: not worked out again"))
    assert pipeline.metric_names(_built("consensus-sync-a-stable")) == fresh


def test_another_scenario_is_another_key(private_disk):
    a = pipeline.metric_names(_built("consensus-sync-a-stable"))
    b = pipeline.metric_names(_built("consensus-sync-a-stable", sim__t_final_s=7.0))  # same names, other key
    c = pipeline.metric_names(_built("rigid-body-free"))
    assert a == b != c and "sync_time_s" not in c
    assert len(list(private_disk.glob("metric_names-*.pickle"))) == 3


def test_a_plugin_outside_any_distribution_is_worked_out_each_time(private_disk, monkeypatch):
    monkeypatch.setattr(pipeline, "_plugin_distributions", lambda: None)
    built = _built("consensus-sync-a-stable")
    assert pipeline.metric_names(built) == pipeline._metric_names(built)
    assert not private_disk.exists()
