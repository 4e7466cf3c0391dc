"""A campaign whose dispersions are all applied as data (the seed, initial rates and attitudes)
builds each batch once: its rows are bit for bit those of the same batch built run by run, a
dispersed value out of its field's bounds fails that run alone, and the batch says how it was built."""

import json

import numpy as np

from coopsat.scenarios import applied
from coopsat.workflows.campaign.runner import make_job, run_batch

CAMPAIGN = """
scenario = "consensus-sync-a-stable"
runs = 6
master_seed = 4
batch_size = 6
overrides = ["sim.t_final_s=20"]

[[dispersions]]
field = "spacecraft.*.omega_b_rad_s"
distribution = "normal"
sigma = {sigma}

[[dispersions]]
field = "spacecraft.2.q_bi"
distribution = "normal"
sigma = 0.005
{extra}"""

OUT_OF_BOUNDS = """
[[dispersions]]
field = "spacecraft.1.angle_rad"
distribution = "choice"
values = [[0.0, 0.0, 0.01], [5000.0, 0.0, 0.0]]
mode = "replace"
"""


def rows_of(tmp_path, sigma, extra=""):
    f = tmp_path / f"c{sigma}{len(extra)}.toml"
    f.write_text(CAMPAIGN.format(sigma=sigma, extra=extra))
    rows, _, provenance = run_batch(make_job(f), list(range(6)), native=False)
    return rows, provenance


def same(a, b):
    if isinstance(a, float) and isinstance(b, float):
        return np.float64(a).tobytes() == np.float64(b).tobytes()
    return a == b


def test_rows_are_bit_for_bit_those_of_per_run_builds(tmp_path, monkeypatch):
    once, provenance = rows_of(tmp_path, 0.05)
    assert provenance["build"] == ("6 runs built once, spacecraft.0.omega_b_rad_s, spacecraft.1.omega_b_rad_s, "
                                   "spacecraft.2.omega_b_rad_s and 4 more applied as arrays")
    monkeypatch.setattr(applied, "APPLIED_FIELDS", ())  # nothing applied: every run built and loaded on its own
    each, provenance = rows_of(tmp_path, 0.05)
    assert provenance["build"].startswith("spacecraft.0.omega_b_rad_s enters the build")
    assert [r["status"] for r in once] == ["ok"] * 6
    for a, b in zip(once, each):
        assert a.keys() == b.keys()
        assert all(same(a[k], b[k]) for k in a), [k for k in a if not same(a[k], b[k])]
    # Every run differs: the rates were dispersed.
    assert len({json.dumps(r["params"]) for r in once}) == 6


def test_a_value_outside_its_field_fails_that_run_alone(tmp_path, monkeypatch):
    # One spacecraft's small-angle state drawn from two values, one past its bound (1e3 rad).
    once, _ = rows_of(tmp_path, 0.05, OUT_OF_BOUNDS)
    failed = [r for r in once if r["status"] == "failed"]
    assert failed and len(failed) < 6
    assert all(r["reason"].startswith("invalid scenario: spacecraft[1].angle_rad: ") for r in failed), failed[0]["reason"]
    monkeypatch.setattr(applied, "APPLIED_FIELDS", ())
    each, _ = rows_of(tmp_path, 0.05, OUT_OF_BOUNDS)
    assert [r["status"] for r in once] == [r["status"] for r in each]
    for a, b in zip(once, each):
        if a["status"] == "ok":
            assert all(same(a[k], b[k]) for k in a)
