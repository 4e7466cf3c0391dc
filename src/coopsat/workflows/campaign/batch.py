"""A campaign batch's runs made: each run's values drawn, its scenario validated, the batch built
(once where every dispersed field is applied as data, :mod:`coopsat.scenarios.applied`, else run
by run), and the kept timeseries gathered; :func:`coopsat.workflows.campaign.runner.run_batch`
simulates and analyses them."""

import json
from pathlib import Path

from coopsat.workflows.campaign.spec import Campaign, base_values, draw_run, overrides_for, run_seed_sequences


def run_overrides(job, run_id, seqs=None, bases=None):
    """The applied values, seed and ``--set`` strings (on the job's scenario) of one run.

    ``seqs`` (:func:`run_seed_sequences`) and ``bases`` (:func:`base_values`) may be given by a
    caller that draws many runs, so that each is computed once (parsing the scenario for
    ``bases`` took 3 ms a run)."""
    campaign = Campaign.model_validate(job["campaign"])
    seq = (seqs or run_seed_sequences(campaign.master_seed, campaign.runs))[run_id]
    applied, seed = draw_run(campaign, job["fields"], base_values(job) if bases is None else bases, seq)
    return applied, seed, overrides_for(applied, seed)


def batch_models(job, campaign, run_ids):
    """The validated scenarios of a batch's runs: ``(rows, models, where)`` — a row per run id
    (failed where its scenario is invalid), the valid runs' scenarios and their run ids."""
    import tempfile

    from coopsat.scenarios.applied import applicable
    from coopsat.scenarios.load import ScenarioError, load_scenario

    seqs = run_seed_sequences(campaign.master_seed, campaign.runs)
    bases = base_values(job)
    rows, models, where = {}, [], []
    with tempfile.TemporaryDirectory() as tmp:
        scenario = Path(tmp) / "scenario.toml"
        scenario.write_text(job["scenario_toml"])
        # The dispersed values set on one validated scenario where every dispersed field is
        # applied as data (each checked as its field), else each run's scenario loaded whole
        # with its overrides.
        base = load_scenario(scenario) if applicable(_batch_paths(job)) is None else None
        for k in run_ids:
            applied, seed, overrides = run_overrides(job, k, seqs, bases)
            row = {"run_id": k, "status": "ok", "reason": "", "seed": seed, "params": json.dumps(applied)}
            try:
                models.append(_with_values(base, {**applied, "seed": seed}) if base is not None
                              else load_scenario(scenario, overrides))
                where.append(k)
            except ScenarioError as err:
                row.update(status="failed", reason=f"invalid scenario: {err}")
            rows[k] = row
    return rows, models, where


def _batch_paths(job):
    """The model paths a campaign's runs differ in: its dispersed fields and the seed."""
    return [*(p for paths in job["fields"] for p in paths), "seed"]


def batch_builds(job, models, where, rows):
    """The runs built: ``(builds, stacked, note, where)`` as
    :func:`coopsat.workflows.sweep.build_runs`, ``where`` the run ids built. A run that the build
    refuses (an impossible body, a graph that cannot agree) fails alone: its row is marked and
    the others are built one by one."""
    from coopsat.scenarios.load import ScenarioError
    from coopsat.workflows.pipeline import prepare
    from coopsat.workflows.sweep import build_runs

    try:
        return (*build_runs(models, _batch_paths(job)), where)
    except ScenarioError:
        builds, kept = [], []
        for k, m in zip(where, models):
            try:
                builds.append(prepare(m, check_published=False))
                kept.append(k)
            except ScenarioError as err:
                rows[k].update(status="failed", reason=f"invalid scenario: {err}")
        return builds, None, "each run built on its own", kept


def batch_series(series, run_ids):
    """The campaign's kept timeseries of a batch (``{run_id: Dataset}``) as one Dataset with a
    ``run`` dimension, or None when none was kept."""
    if not series:
        return None
    import xarray as xr

    ids = [k for k in run_ids if k in series]
    # The run's attributes (its seed, its scenario) go; each variable's own (units, long
    # name), the same in every run, stay: the report labels its axes with them.
    kept = xr.concat([series[k].drop_attrs(deep=False) for k in ids], dim="run").assign_coords(run=ids)
    # Text labels (spacecraft names, component letters) go to attributes: Zarr v3 has no
    # specified fixed-width string type.
    labels = [c for c in kept.coords if kept[c].dtype.kind == "U"]
    return kept.drop_vars(labels).assign_attrs({f"{c}_labels": [str(v) for v in kept[c].values] for c in labels})


def _with_values(model, values):
    """``model`` with each ``{path: value}`` set as its field
    (:func:`coopsat.scenarios.applied.with_value`)."""
    from coopsat.scenarios.applied import with_value

    for path, value in values.items():
        model = with_value(model, path, value)
    return model
