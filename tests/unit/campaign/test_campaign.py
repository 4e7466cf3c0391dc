"""Campaign files without Dask: the dispersions' statistics, seeds, poisoned runs failing alone,
and every bundled campaign.

References are independent of :mod:`coopsat.workflows.campaign`: the undispersed values are read from the
resolved scenario TOML, the draws are tested against scipy.stats distributions (the master
seeds are fixed, so the p-values are fixed numbers, not a source of flakiness), and the values
a run stores are checked against the scenario that its ``--set`` strings build.
"""

import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
import tomli_w
from scipy import stats

from coopsat.workflows.campaign.runner import run_batch_rows
from coopsat.workflows.campaign.spec import (
    bundled_campaign,
    bundled_campaign_names,
    draw_run,
    load_campaign,
    overrides_for,
    run_seed_sequences,
)
from coopsat.scenarios.load import load_scenario, resolved_toml

N_DRAWS = 4000
P_MIN = 1e-3  # every p-value below is a fixed number (fixed seeds); 1e-3 leaves room for ~50 tests

STATS_CAMPAIGN = f"""
scenario = "consensus-sync-a-stable"
runs = {N_DRAWS}
master_seed = 31337
batch_size = 100

[[dispersions]]
field = "spacecraft.*.inertia_kgm2"
distribution = "normal"
sigma = 0.02
mode = "relative"

[[dispersions]]
field = "spacecraft.*.omega_b_rad_s"
distribution = "normal"
mean = 0.01
sigma = 0.05
mode = "absolute"

[[dispersions]]
field = "controller.alpha"
distribution = "uniform"
low = 0.5
high = 1.5
mode = "replace"

[[dispersions]]
field = "actuators.torque_max_nm"
distribution = "uniform"
low = -0.01
high = 0.02
mode = "absolute"

[[dispersions]]
field = "controller.beta"
distribution = "choice"
values = [1.0, 2.0, 3.0]
mode = "replace"
"""

N_SPACECRAFT = 5
INERTIA = [f"spacecraft.{i}.inertia_kgm2" for i in range(N_SPACECRAFT)]
OMEGA = [f"spacecraft.{i}.omega_b_rad_s" for i in range(N_SPACECRAFT)]


def _get(node, path):
    for part in path.split("."):
        node = node[int(part)] if isinstance(node, list) else node[part]
    return node


def _undispersed(ref, overrides, paths):
    """Each path's value in the resolved scenario (read from its TOML, not from the campaign code)."""
    resolved = tomllib.loads(resolved_toml(load_scenario(ref, overrides)))
    return {p: _get(resolved, p) for p in paths}


def _draw_all(path):
    campaign, ref, fields = load_campaign(path)
    bases = _undispersed(ref, campaign.overrides, [p for paths in fields for p in paths])
    draws = [draw_run(campaign, fields, bases, seq) for seq in run_seed_sequences(campaign.master_seed, campaign.runs)]
    return campaign, ref, fields, bases, draws


@pytest.fixture(scope="module")
def drawn(tmp_path_factory):
    path = tmp_path_factory.mktemp("stats") / "stats.toml"
    path.write_text(STATS_CAMPAIGN)
    return path, *_draw_all(path)


def test_every_star_is_expanded_in_file_order(drawn):
    _, _, _, fields, _, draws = drawn
    assert fields == [INERTIA, OMEGA, ["controller.alpha"], ["actuators.torque_max_nm"], ["controller.beta"]]
    applied, _ = draws[0]
    assert list(applied) == [*INERTIA, *OMEGA, "controller.alpha", "actuators.torque_max_nm", "controller.beta"]


def test_normal_relative_is_v_times_one_plus_n_0_sigma(drawn):
    _, _, _, _, bases, draws = drawn
    pooled, p_values = [], []
    for path in INERTIA:
        v = np.asarray(bases[path], dtype=float)
        rel = np.array([a[path] for a, _ in draws]) / v - 1.0  # (runs, 3)
        assert rel.shape == (N_DRAWS, 3)
        for c in range(3):
            p_values.append(stats.kstest(rel[:, c], stats.norm(0.0, 0.02).cdf).pvalue)
        pooled.append(rel)
    pooled = np.concatenate(pooled).ravel()
    assert min(p_values) > P_MIN, p_values
    assert stats.kstest(pooled, stats.norm(0.0, 0.02).cdf).pvalue > P_MIN
    # The tests would catch a variance used as σ, or an absolute draw: both far off.
    assert stats.kstest(pooled, stats.norm(0.0, 0.02**2).cdf).pvalue < 1e-10
    assert pooled.std() == pytest.approx(0.02, rel=0.03)


def test_normal_absolute_is_v_plus_n_mean_sigma(drawn):
    _, _, _, _, bases, draws = drawn
    p_values = []
    for path in OMEGA:
        d = np.array([a[path] for a, _ in draws]) - np.asarray(bases[path], dtype=float)
        p_values += [stats.kstest(d[:, c], stats.norm(0.01, 0.05).cdf).pvalue for c in range(3)]
    assert min(p_values) > P_MIN, p_values


def test_uniform_replace_and_absolute(drawn):
    _, _, _, _, bases, draws = drawn
    alpha = np.array([a["controller.alpha"] for a, _ in draws])
    assert alpha.min() >= 0.5 and alpha.max() <= 1.5
    assert stats.kstest(alpha, stats.uniform(0.5, 1.0).cdf).pvalue > P_MIN
    torque = np.array([a["actuators.torque_max_nm"] for a, _ in draws]) - bases["actuators.torque_max_nm"]
    assert stats.kstest(torque, stats.uniform(-0.01, 0.03).cdf).pvalue > P_MIN
    assert stats.kstest(alpha, stats.uniform(0.0, 1.5).cdf).pvalue < 1e-10  # the test has power


def test_choice_gives_every_value_equally_often(drawn):
    _, _, _, _, _, draws = drawn
    beta = [a["controller.beta"] for a, _ in draws]
    assert set(beta) == {1.0, 2.0, 3.0}
    counts = [beta.count(v) for v in (1.0, 2.0, 3.0)]
    assert stats.chisquare(counts).pvalue > P_MIN, counts


def test_numbers_are_independent_across_components_fields_and_runs(drawn):
    _, _, _, _, bases, draws = drawn
    columns = []
    for a, _ in draws:
        row = []
        for path in INERTIA:
            row += list(np.asarray(a[path]) / np.asarray(bases[path]))
        for path in OMEGA:
            row += list(a[path])
        row += [a["controller.alpha"], a["actuators.torque_max_nm"], a["controller.beta"]]
        columns.append(row)
    x = np.array(columns)
    corr = np.corrcoef(x, rowvar=False)
    off = np.abs(corr[~np.eye(len(corr), dtype=bool)])
    assert off.max() < 5.0 / math.sqrt(N_DRAWS), off.max()  # 0.079; independent: ~1/sqrt(n) = 0.016
    alpha = x[:, -3]
    assert abs(np.corrcoef(alpha[:-1], alpha[1:])[0, 1]) < 5.0 / math.sqrt(N_DRAWS)  # run k vs run k+1
    # Different runs differ: no two runs share a drawn value or a scenario seed.
    assert len(set(alpha)) == N_DRAWS
    assert len({tuple(a["spacecraft.2.omega_b_rad_s"]) for a, _ in draws}) == N_DRAWS
    seeds = [s for _, s in draws]
    assert len(set(seeds)) == N_DRAWS
    assert all(isinstance(s, int) and 0 <= s < 2**31 for s in seeds)


def test_draws_are_reproducible_and_follow_the_documented_seed_recipe(drawn):
    path, campaign, _, fields, bases, draws = drawn
    again = _draw_all(path)[-1]
    assert again == draws  # a fresh load: the same values and seeds, exactly
    other = tomllib.loads(STATS_CAMPAIGN)
    other["master_seed"] += 1
    path2 = path.with_name("other.toml")
    path2.write_text(tomli_w.dumps(other))
    assert _draw_all(path2)[-1][0] != draws[0]
    # docs/campaigns.md: run k draws from SeedSequence(master_seed).spawn(runs)[k], its
    # dispersions in file order, then its scenario seed.
    k = 17
    rng = np.random.default_rng(np.random.SeedSequence(31337).spawn(N_DRAWS)[k])
    expected = {}
    for p in INERTIA:
        expected[p] = (np.asarray(bases[p]) * (1.0 + rng.normal(0.0, 0.02, 3))).tolist()
    for p in OMEGA:
        expected[p] = (np.asarray(bases[p]) + rng.normal(0.01, 0.05, 3)).tolist()
    expected["controller.alpha"] = float(rng.uniform(0.5, 1.5))
    expected["actuators.torque_max_nm"] = float(bases["actuators.torque_max_nm"] + rng.uniform(-0.01, 0.02))
    expected["controller.beta"] = [1.0, 2.0, 3.0][int(rng.integers(3))]
    assert draws[k] == (expected, int(rng.integers(0, 2**31 - 1)))


def test_the_set_strings_give_the_run_exactly_the_drawn_values(drawn):
    _, campaign, ref, _, _, draws = drawn

    def physical(applied):  # satellite 1 sits on the triangle inequality: half its draws break it
        m = np.sort(applied["spacecraft.0.inertia_kgm2"])
        return m[0] + m[1] > m[2]

    for applied, seed in [d for d in draws if physical(d[0])][:3]:
        scenario = load_scenario(ref, [*campaign.overrides, *overrides_for(applied, seed)])
        assert scenario.seed == seed
        assert scenario.controller.alpha == applied["controller.alpha"]
        assert scenario.controller.beta == applied["controller.beta"]
        assert scenario.actuators.torque_max_nm == applied["actuators.torque_max_nm"]
        for i, sc in enumerate(scenario.spacecraft):
            assert list(sc.inertia_kgm2) == applied[f"spacecraft.{i}.inertia_kgm2"]
            assert list(sc.omega_b_rad_s) == applied[f"spacecraft.{i}.omega_b_rad_s"]


# --- Poisoned runs: an invalid body and a blow-up, in one batch with healthy runs --------------

UNSATURATED = (Path(__file__).resolve().parents[2] / "data" / "consensus-unsaturated.toml").read_text()

GOOD_INERTIA, BAD_INERTIA = [1.0, 0.1, 0.9], [1.0, 0.1, 2.0]  # 0.1 + 1.0 < 2.0: no rigid body
HUGE_BETA = 1e6  # the schema's largest gain: β·dt/I ~ 1e4 per control period, unsaturated


def _poison_campaign(beta_values, inertia_values):
    # Master seed 20 puts one invalid body and one blow-up among runs 0–3 (checked below from
    # the stored parameters, not assumed).
    return f"""
scenario = "unsaturated.toml"
runs = 8
master_seed = 20
batch_size = 4

[[dispersions]]
field = "controller.beta"
distribution = "choice"
values = {json.dumps(beta_values)}
mode = "replace"

[[dispersions]]
field = "spacecraft.0.inertia_kgm2"
distribution = "choice"
values = {json.dumps(inertia_values)}
mode = "replace"

[[dispersions]]
field = "spacecraft.*.omega_b_rad_s"
distribution = "normal"
sigma = 0.05
"""


@pytest.fixture(scope="module")
def poisoned(tmp_path_factory):
    d = tmp_path_factory.mktemp("poison")
    (d / "unsaturated.toml").write_text(UNSATURATED)
    # The clean campaign has as many values per choice (the same draws), all of them good.
    (d / "poisoned.toml").write_text(_poison_campaign([2.0, 2.0, 2.0, HUGE_BETA], [GOOD_INERTIA] * 3 + [BAD_INERTIA]))
    (d / "clean.toml").write_text(_poison_campaign([2.0] * 4, [GOOD_INERTIA] * 4))
    ids = [0, 1, 2, 3]
    return d, ids, run_batch_rows(d / "poisoned.toml", ids), run_batch_rows(d / "clean.toml", ids)


def _kind(params):
    if params["spacecraft.0.inertia_kgm2"] == BAD_INERTIA:
        return "invalid"
    return "blow-up" if params["controller.beta"] == HUGE_BETA else "ok"


def test_poisoned_runs_fail_alone_with_their_reason_and_parameters(poisoned):
    d, ids, rows, clean = poisoned
    assert [r["run_id"] for r in rows] == ids
    kinds = [_kind(json.loads(r["params"])) for r in rows]
    assert {"invalid", "blow-up", "ok"} <= set(kinds), kinds  # the batch mixes all three
    campaign, ref, fields = load_campaign(d / "poisoned.toml")
    bases = _undispersed(ref, campaign.overrides, [p for paths in fields for p in paths])
    seqs = run_seed_sequences(campaign.master_seed, campaign.runs)
    for row, kind in zip(rows, kinds):
        applied, seed = draw_run(campaign, fields, bases, seqs[row["run_id"]])
        assert json.loads(row["params"]) == applied and row["seed"] == seed  # stored, failed or not
        if kind == "invalid":
            assert row["status"] == "failed"
            assert row["reason"].startswith("invalid scenario: spacecraft[0].inertia_kgm2")
            assert "triangle inequality" in row["reason"]
        elif kind == "blow-up":
            assert row["status"] == "failed"
            assert "non-finite" in row["reason"]
        else:
            assert row["status"] == "ok" and row["reason"] == ""
    # The clean campaign (same draws, good values only) runs all four.
    assert [r["status"] for r in clean] == ["ok"] * 4
    assert [r["seed"] for r in clean] == [r["seed"] for r in rows]


def test_healthy_runs_beside_poisoned_ones_match_the_clean_campaign(poisoned):
    _, _, rows, clean = poisoned
    healthy = [(r, c) for r, c in zip(rows, clean) if r["status"] == "ok"]
    assert healthy
    metrics = [k for k, v in clean[0].items() if k not in ("run_id", "seed") and isinstance(v, float)]
    assert "final_rate_spread_rad_s" in metrics and "sat1_impulse_nms" in metrics
    for row, ref in healthy:
        assert row["params"] == ref["params"]
        for name in metrics:
            assert row[name] is not None and math.isfinite(row[name]), name
            # Not bit for bit: the poisoned batch simulates its healthy runs in a batch of a
            # different size, which changes the last bits (see the replay test of
            # tests/cli/test_cli_campaign.py); 1e-12 is far below any physical difference.
            assert row[name] == pytest.approx(ref[name], rel=1e-12, abs=1e-15), name


# --- Every bundled campaign -------------------------------------------------------------------

SHORT_HORIZON_S = {  # a whole number of each scenario's record interval (and control period)
    "consensus-sync-a-stable": 1.0,        # record 0.5 s
    "cartwheel-keeping-ground": 100.0,     # record 10 s
    "delay-designed": 1.0,                 # record 0.1 s
    "deepspace-square-to-line-lqr": 500.0,  # record 50 s
    "observation-cooperative": 2.0,        # record 1 s
}

# Bundled campaigns whose dispersions make invalid scenarios (src bugs, see the report): a
# uniform draw of a delay that must be a whole number of control periods fails every run; a
# relative dispersion of satellite 1's inertia (1.0, 0.1, 0.9), which sits exactly on the
# triangle inequality (0.1 + 0.9 = 1.0), fails about half of them.
def test_there_are_bundled_campaigns():
    assert set(bundled_campaign_names()) >= {"consensus-sync-dispersed", "cartwheel-navigation-dispersed",
                                             "delay-designed-dispersed", "deepspace-lqr-dispersed",
                                             "observation-cooperative-dispersed"}


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n.startswith(("observation", "cartwheel-navigation"))
                                  else n for n in bundled_campaign_names()])  # 14–31 s each: CI's second pass
def test_bundled_campaign_runs_two_runs(name, tmp_path):
    campaign, ref, fields = load_campaign(name)
    assert campaign.runs >= 2 and fields and all(fields)
    horizon = SHORT_HORIZON_S[campaign.scenario]
    record = tomllib.loads(resolved_toml(load_scenario(ref, campaign.overrides)))["sim"]["record_interval_s"]
    assert horizon / record == round(horizon / record)
    path = _two_runs(name, tmp_path, horizon)
    rows = run_batch_rows(path, [0, 1])
    assert [r["run_id"] for r in rows] == [0, 1]
    for r in rows:
        params = json.loads(r["params"])
        assert set(params) == {p for paths in fields for p in paths}
        if r["status"] == "ok":
            assert r["reason"] == ""
            assert any(isinstance(v, float) and math.isfinite(v) for k, v in r.items() if k not in ("run_id", "seed"))
    assert all(r["status"] == "ok" for r in rows), [r["reason"] for r in rows]


def _two_runs(name, tmp_path, horizon_s):
    """The bundled campaign ``name`` cut to two runs of ``horizon_s``, as a file."""
    raw = tomllib.loads(bundled_campaign(name).read_text())
    raw["runs"] = 2
    raw["overrides"] = [*raw.get("overrides", []), f"sim.t_final_s={horizon_s}"]
    path = tmp_path / f"{name}.toml"
    path.write_text(tomli_w.dumps(raw))
    return path


LONGER_HORIZON_S = {"consensus-sync-a-stable": 60.0, "delay-designed": 20.0, "deepspace-square-to-line-lqr": 3000.0}
"""Long enough for settle times and final errors to mean something, short enough for the quick suite."""


@pytest.mark.parametrize("name", [n for n in bundled_campaign_names() if n.startswith(("consensus", "delay", "deepspace"))])
def test_a_campaign_batch_gives_each_run_the_metrics_of_the_run_alone(name, tmp_path):
    """A batch is simulated and analysed at once (metrics over the batch); each row must hold
    what ``coopsat run`` computes for that run's scenario on its own (a batch sums in another
    order: the last bits may differ)."""
    from coopsat.workflows.analyse import analyse
    from coopsat.workflows.campaign.batch import run_overrides
    from coopsat.workflows.campaign.runner import make_job
    from coopsat.workflows.pipeline import prepare, simulate_built

    campaign = load_campaign(name)[0]
    path = _two_runs(name, tmp_path, LONGER_HORIZON_S[campaign.scenario])
    job = make_job(path)
    scenario = tmp_path / "scenario.toml"
    scenario.write_text(job["scenario_toml"])
    rows = run_batch_rows(path, [0, 1])
    assert all(r["status"] == "ok" for r in rows), [r["reason"] for r in rows]
    for k, row in enumerate(rows):
        built = prepare(load_scenario(scenario, run_overrides(job, k)[2]), check_published=False)
        alone, _ = analyse(built, simulate_built(built)[0], compare=False)
        assert set(row) - {"run_id", "status", "reason", "seed", "params"} == set(alone)
        for metric, value in alone.items():
            if value is None:
                assert row[metric] is None, metric
            else:
                np.testing.assert_allclose(row[metric], value, rtol=1e-9, atol=1e-12, err_msg=metric)
        assert sum(v is not None for v in alone.values()) >= 3


@pytest.mark.slow  # long: runs in CI's second pytest pass (README)
def test_no_bundled_campaign_draws_an_invalid_scenario(tmp_path):
    """Every drawn run of every bundled campaign (a sample of 25 each) is a scenario the
    builder accepts: none ships runs that fail by construction (a delay that is not a whole
    number of control periods, a body that breaks the triangle inequality)."""
    from coopsat.workflows.campaign.batch import run_overrides
    from coopsat.workflows.campaign.runner import make_job
    from coopsat.workflows.pipeline import prepare

    for name in bundled_campaign_names():
        job = make_job(name)
        campaign, _, _ = load_campaign(name)
        seqs = run_seed_sequences(campaign.master_seed, campaign.runs)
        scenario = tmp_path / f"{name}.toml"
        scenario.write_text(job["scenario_toml"])
        for k in range(0, campaign.runs, max(1, campaign.runs // 25)):
            prepare(load_scenario(scenario, run_overrides(job, k, seqs)[2]))  # ScenarioError if invalid


def test_satellite_1_of_the_consensus_paper_is_a_flat_body():
    """Why consensus-sync-dispersed leaves satellite 1's inertia alone: (1.0, 0.1, 0.9) lies on
    the triangle inequality, so half of any dispersion of it is no rigid body."""
    moments = sorted(tomllib.loads(resolved_toml(load_scenario("consensus-sync-a-stable")))["spacecraft"][0]["inertia_kgm2"])
    assert moments[0] + moments[1] == pytest.approx(moments[2], abs=1e-12)
    fields = load_campaign("consensus-sync-dispersed")[2]
    assert not any(p.startswith("spacecraft.0.inertia") for paths in fields for p in paths)
