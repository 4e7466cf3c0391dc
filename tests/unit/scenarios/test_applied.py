"""Runs built once, their differences applied as arrays (coopsat.scenarios.applied), against each
run's own build: every leaf of the system and every design check equal bit for bit, or the
batch goes back to per-run builds and says why."""

import jax
import numpy as np
import pytest

import coopsat
from coopsat.scenarios import applied
from coopsat.scenarios.load import ScenarioError
from coopsat.workflows.pipeline import prepare
from coopsat.workflows.sweep import build_runs, simulate_runs


def build_one(model):
    return prepare(model, check_published=False)


def variants(name):
    """A short run of a bundled scenario and five variants, each differing from it in applied fields."""
    base = coopsat.Scenario.load(name).set("sim.t_final_s", 2 * coopsat.Scenario.load(name).model.record_interval_s)
    last = len(base.model.spacecraft) - 1
    docs = [
        base,
        base.with_seed(base.model.seed + 12345678901),
        base.set("spacecraft.0.omega_b_rad_s", [0.01, -0.02, 0.003]),
        base.set(f"spacecraft.{last}.q_bi", [0.9, 0.1, -0.2, 0.3]),  # not unit: the build normalises it
        base.update({f"spacecraft.{last}.h_wheels_b_nms": [0.1, 0.0, -0.1], "spacecraft.0.angle_rad": [0.01, 0.0, 0.02]}),
        base.update({"seed": 7, "spacecraft.0.omega_b_rad_s": [0.0, 0.0, 0.05]}),
    ]
    paths = ["seed", "spacecraft.0.omega_b_rad_s", f"spacecraft.{last}.q_bi", f"spacecraft.{last}.h_wheels_b_nms",
             "spacecraft.0.angle_rad"]
    return [d.model for d in docs], paths


def assert_same_build(ours, theirs):
    a, ta = jax.tree_util.tree_flatten_with_path(ours.system)
    b, tb = jax.tree_util.tree_flatten_with_path(theirs.system)
    assert ta == tb
    for (path, x), (_, y) in zip(a, b):
        x, y = np.asarray(x), np.asarray(y)
        assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes(), jax.tree_util.keystr(path)
    assert {k: (c.ok, c.note, c.metrics) for k, c in ours.named_checks.items()} == \
        {k: (c.ok, c.note, c.metrics) for k, c in theirs.named_checks.items()}
    assert ours.scenario == theirs.scenario


@pytest.mark.parametrize("name", ["consensus-sync-a-stable", "delay-classic-nodelay", "cartwheel-keeping-ground",
                                  "leo-pair-navigation", "rigid-body-gravity-gradient"])
def test_applied_runs_equal_their_own_builds_or_say_why_not(name):
    models, paths = variants(name)
    assert applied.applicable(paths) is None
    base = build_one(models[0])
    try:
        runs = applied.applied_runs(base, models, paths, build_one)
    except applied.NotApplicable as err:
        # A plug-in reads one of these fields at build time: the check must have seen a real difference.
        assert "differs from the run's own build" in str(err)
        assert name not in ("consensus-sync-a-stable", "delay-classic-nodelay", "rigid-body-gravity-gradient")
        return
    for model, ours in zip(models, runs.builds):
        assert_same_build(ours, build_one(model))
    # The batch the engine gets is the per-run systems stacked.
    for k, ours in enumerate(runs.builds):
        for x, y in zip(jax.tree_util.tree_leaves(runs.system), jax.tree_util.tree_leaves(ours.system)):
            assert np.asarray(x)[k].tobytes() == np.asarray(y).tobytes()


def test_the_simulated_runs_are_bit_for_bit_those_of_per_run_builds():
    models, paths = variants("consensus-sync-a-stable")
    builds, stacked, note = build_runs(models, paths)
    assert stacked is not None and note.startswith("6 runs built once")
    once, _, _ = simulate_runs(builds, every_core=False, stacked=stacked)
    each, _, _ = simulate_runs([build_one(m) for m in models], every_core=False)
    for a, b in zip(once, each):
        assert a.identical(b)
        for name in a.data_vars:
            assert a[name].values.tobytes() == b[name].values.tobytes()


def test_a_field_that_enters_the_build_is_built_per_run_and_named():
    base = coopsat.Scenario.load("consensus-sync-a-stable").set("sim.t_final_s", 1.0)
    models = [base.model, base.set("spacecraft.1.inertia_kgm2", [1.1, 0.2, 0.95]).model]
    builds, stacked, note = build_runs(models, ["spacecraft.1.inertia_kgm2"])
    assert stacked is None
    assert note.startswith("spacecraft.1.inertia_kgm2 enters the build")
    assert_same_build(builds[1], build_one(models[1]))


def test_a_wrong_applier_is_caught_by_the_batch_check(monkeypatch):
    """An applier that writes the wrong leaf (as a plug-in reading the initial rate at build time
    would leave one stale) sends the batch back to per-run builds, naming the leaf."""
    wrong = applied.AppliedField(r"spacecraft\.(\d+)\.omega_b_rad_s", applied._initial("h_wheels_b"))
    monkeypatch.setattr(applied, "APPLIED_FIELDS", (wrong, *applied.APPLIED_FIELDS[2:]))
    base = coopsat.Scenario.load("consensus-sync-a-stable").set("sim.t_final_s", 1.0)
    models = [base.model, base.set("spacecraft.0.omega_b_rad_s", [0.0, 0.0, 0.02]).model]
    builds, stacked, note = build_runs(models, ["spacecraft.0.omega_b_rad_s"])
    assert stacked is None
    assert "the system's leaf .x0" in note and "each run is built on its own" in note
    assert_same_build(builds[1], build_one(models[1]))


def test_with_value_checks_the_field_and_names_it():
    model = coopsat.Scenario.load("consensus-sync-a-stable").model
    new = applied.with_value(model, "spacecraft.2.omega_b_rad_s", [0.1, 0.0, -0.1])
    assert new.spacecraft[2].omega_b_rad_s == coopsat.Scenario.load("consensus-sync-a-stable").set(
        "spacecraft.2.omega_b_rad_s", [0.1, 0.0, -0.1]).model.spacecraft[2].omega_b_rad_s
    assert model.spacecraft[2].omega_b_rad_s != new.spacecraft[2].omega_b_rad_s  # the original is untouched
    with pytest.raises(ScenarioError, match=r"^spacecraft\[2\]\.omega_b_rad_s: "):
        applied.with_value(model, "spacecraft.2.omega_b_rad_s", [1e9, 0.0, 0.0])
    with pytest.raises(ScenarioError, match=r"^seed: "):
        applied.with_value(model, "seed", -1)


def test_changed_paths():
    a = {"seed": 1, "spacecraft": [{"omega_b_rad_s": [0, 0, 0]}, {"q_bi": [1, 0, 0, 0]}], "sim": {"t_final_s": 1.0}}
    b = {"seed": 2, "spacecraft": [{"omega_b_rad_s": [0, 0, 1]}, {"q_bi": [1, 0, 0, 0]}], "sim": {"t_final_s": 1.0, "x": 1}}
    assert applied.changed_paths(a, b) == ["seed", "spacecraft.0.omega_b_rad_s", "sim.x"]
    assert applied.changed_paths(a, a) == []
    assert applied.changed_paths({"spacecraft": [{}]}, {"spacecraft": [{}, {}]}) == ["spacecraft"]


def test_each_applied_field_is_checked_by_a_run_that_differs_in_it(monkeypatch):
    """Runs that differ from the first in different fields: the wrong applier of a field that
    only the fourth run changes is still caught."""
    wrong = applied.AppliedField(r"spacecraft\.(\d+)\.angle_rad", applied._initial("omega_b"))
    monkeypatch.setattr(applied, "APPLIED_FIELDS", (*applied.APPLIED_FIELDS[:-1], wrong))
    base = coopsat.Scenario.load("consensus-sync-a-stable").set("sim.t_final_s", 1.0)
    models = [base.model, base.with_seed(3).model, base.with_seed(4).model,
              base.set("spacecraft.0.angle_rad", [0.0, 0.0, 0.02]).model]
    assert applied._checked_runs({"seed": np.array([0, 3, 4, 0]), "x": np.array([0, 0, 0, 1])}) == [1, 3]
    builds, stacked, note = build_runs(models, ["seed", "spacecraft.0.angle_rad"])
    assert stacked is None and "the system's leaf .x0" in note


def test_a_scenario_changed_in_applied_fields_has_the_model_a_whole_validation_gives():
    """``Scenario.set``/``with_seed`` on the seed or an initial state set the field on the
    parent's model (no whole validation): the model must equal the one validated from scratch,
    and a refused value must give the whole validation's own message."""
    import coopsat
    from coopsat.scenarios.load import ScenarioError, _merge_defaults, set_path
    from coopsat.scenarios.schema import Scenario as Model

    base = coopsat.Scenario.load("consensus-sync-a-stable")
    changed = [
        base.with_seed(12),
        base.set("spacecraft.1.omega_b_rad_s", [0.1, -0.2, 0.3]),
        base.update({"seed": 4, "spacecraft.0.q_bi": [1, 0, 0, 0], "spacecraft.3.angle_rad": [0.0, 0.01, 0.0]}),
        base.set("sim.t_final_s", 20.0).with_seed(3),  # a whole validation, then a field
    ]
    for s in changed:
        assert s.model == Model.model_validate(_merge_defaults(s.to_dict()))
    assert changed[0].model.seed == 12 and changed[1].model.spacecraft[1].omega_b_rad_s == [0.1, -0.2, 0.3]
    for path, value in [("seed", -1), ("spacecraft.1.omega_b_rad_s", [0.1, 0.2]), ("spacecraft.0.q_bi", [0, 0, 0, 0])]:
        with pytest.raises(ScenarioError) as fast:
            base.set(path, value)
        raw = base.to_dict()
        set_path(raw, path, value)
        with pytest.raises(ScenarioError) as whole:
            coopsat.Scenario(raw)  # validated whole
        assert str(fast.value) == str(whole.value)
