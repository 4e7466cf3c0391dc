"""A navigation filter's NEES pooled over a campaign's runs against its χ² band (synthetic rows
as the runner writes them: no Dask, no simulation)."""

import json

import numpy as np
from scipy.stats import chi2

from coopsat.workflows.campaign import report
from coopsat.workflows.campaign.consistency import pooled_nees
from coopsat.workflows.campaign.runner import MARKER, write_batch


def _rows(means, counts):
    return [{"run_id": k, "status": "ok", "reason": "", "seed": k, "params": "{}", "nees_mean": m,
             "nees_effective_samples": c, "nees_consistent": bool(chi2.ppf(0.025, 6 * c) / c <= m <= chi2.ppf(0.975, 6 * c) / c)}
            for k, (m, c) in enumerate(zip(means, counts))]


def test_runs_of_a_consistent_filter_pool_inside_the_band_and_an_overconfident_one_above():
    """Run means drawn as a consistent filter's (χ²(6 N_k)/N_k) pool to the mean of Σ N_k
    values, inside the band; the same runs with errors 1.5 times the claimed σ (NEES × 2.25)
    pool far above it."""
    rng = np.random.default_rng(4)
    counts = rng.uniform(10.0, 40.0, size=30)
    means = rng.chisquare(6 * counts) / counts
    good = pooled_nees(_rows(means, counts))
    total = counts.sum()
    assert good["effective_samples"] == total and good["runs"] == 30
    np.testing.assert_allclose(good["pooled_mean"], np.sum(means * counts) / total, rtol=1e-12)
    assert (good["bound_low"], good["bound_high"]) == (chi2.ppf(0.025, 6 * total) / total, chi2.ppf(0.975, 6 * total) / total)
    assert good["consistent"] and good["runs_consistent"] >= 25
    bad = pooled_nees(_rows(2.25 * means, counts))
    assert not bad["consistent"] and bad["pooled_mean"] > bad["bound_high"] and bad["runs_consistent"] < 5
    assert pooled_nees([{"run_id": 0, "status": "ok", "sync_time_s": 1.0}]) is None


def test_the_campaign_report_says_it(tmp_path):
    out = tmp_path / "camp"
    (out / "batches").mkdir(parents=True)
    (out / MARKER).write_text(json.dumps({
        "campaign": {"scenario": "leo-pair-navigation", "runs": 3, "master_seed": 1, "description": "synthetic"},
        "scenario_toml": "", "fields": [], "campaign_file": "/x/nav.toml"}))
    write_batch(out, 0, _rows([15.0, 14.0, 16.0], [20.0, 20.0, 20.0]), None)
    page = report.write_report(out).read_text()
    assert "Pooled NEES over the campaign 15 for 60 independent values" in page and "NOT consistent" in page
    stats = json.loads((out / "report" / "statistics.json").read_text())
    assert stats["navigation_consistency"]["runs_consistent"] == 0
