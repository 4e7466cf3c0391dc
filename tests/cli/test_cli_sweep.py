"""``coopsat sweep``: zipped values, seeds, batching by structure, the same metrics as
``coopsat run``, its files, and bad input (exit 2, one line, nothing written).

One short sweep (0.5 s of consensus-sync-a-stable) serves the happy-path tests: two points
zipped over the controller's ``alpha`` and the ``sensors`` list (none, then a noisy gyro: two
compiled structures, so two batches), two seeds each.
"""

import csv
import json
import math

import pytest

from coopsat.cli import EXIT_BAD_INPUT, main
from coopsat.workflows.sweep import split_values

SCENARIO = "consensus-sync-a-stable"
SHORT = "sim.t_final_s=0.5"
GYRO = '[{kind="gyro", sigma_rad_s=1e-2}]'
VARY = ["--vary", "controller.alpha=0.5,2", "--vary", f"sensors=[],{GYRO}"]


def run_main(capsys, argv):
    status = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    out = tmp_path_factory.mktemp("sweep") / "s"
    argv = ["sweep", SCENARIO, *VARY, "--seeds", "2", "--set", SHORT, "--out", out, "-q",
            "--plot", "controller.alpha:final_rate_spread_rad_s", "--plot", "sat1_impulse_nms:final_rate_spread_rad_s"]
    status = main([str(a) for a in argv])
    with open(out / "sweep.csv", newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    return status, out, rows, json.loads((out / "sweep.json").read_text())


def test_values_split_outside_brackets_and_quotes():
    assert split_values("0.5, 1,2") == ["0.5", "1", "2"]
    assert split_values('[0,0,1],[0,1,0],"a,b",{k=[1,2]}') == ["[0,0,1]", "[0,1,0]", '"a,b"', "{k=[1,2]}"]


def test_zipped_points_with_seeds_in_one_batch_per_structure(swept):
    status, _, rows, summary = swept
    assert status == 0
    assert [(r["controller.alpha"], r["sensors"], r["seed"]) for r in rows] == [
        ("0.5", "[]", "0"), ("0.5", "[]", "1"), ("2", json.dumps([{"kind": "gyro", "sigma_rad_s": 0.01}]), "0"),
        ("2", json.dumps([{"kind": "gyro", "sigma_rad_s": 0.01}]), "1"),
    ]
    assert summary["batches"] == 2 and summary["seeds_per_point"] == 2
    assert [p["values"]["controller.alpha"] for p in summary["points"]] == [0.5, 2]
    assert summary["compile_s"] > 0 and summary["run_s"] > 0


def test_seeds_differ_only_with_noise(swept):
    _, _, rows, _ = swept
    spread = [float(r["final_rate_spread_rad_s"]) for r in rows]
    assert spread[0] == spread[1]  # no sensor: the seed draws nothing
    assert spread[2] != spread[3]  # the gyro's noise comes from the seed


def test_points_hold_the_mean_and_max_over_seeds(swept):
    _, _, rows, summary = swept
    assert "final_rate_spread_rad_s" in summary["metrics"] and "sync_time_s" in summary["metrics"]
    for k, point in enumerate(summary["points"]):
        values = [float(r["final_rate_spread_rad_s"]) for r in rows[2 * k:2 * k + 2]]
        assert point["seeds"] == [0, 1]
        assert point["mean"]["final_rate_spread_rad_s"] == pytest.approx(sum(values) / 2, rel=1e-12)
        assert point["max"]["final_rate_spread_rad_s"] == pytest.approx(max(values), rel=1e-12)
        assert point["mean"]["sync_time_s"] is None  # never reached in 0.5 s: null, and empty in the csv
    assert {r["sync_time_s"] for r in rows} == {""}


def test_plots_are_written(swept):
    _, out, _, _ = swept
    for name in ("sweep_controller.alpha_final_rate_spread_rad_s.png", "sweep_sat1_impulse_nms_final_rate_spread_rad_s.png"):
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_swept_run_equals_coopsat_run(swept, tmp_path):
    from coopsat.workflows.pipeline import run_scenario

    _, _, rows, _ = swept
    result = run_scenario(SCENARIO, out_dir=tmp_path / "r", overrides=[SHORT, "controller.alpha=2", f"sensors={GYRO}"], figures=False)
    row = rows[2]  # alpha = 2, gyro, seed 0 (the scenario's own)
    compared = [k for k, v in result.metrics.items() if k in row and isinstance(v, (int, float))]
    assert len(compared) > 20
    for key in compared:
        assert float(row[key]) == pytest.approx(result.metrics[key], rel=1e-9, abs=1e-300), key
        assert math.isfinite(float(row[key]))


def test_table_is_printed_with_times(capsys, tmp_path):
    status, out, _ = run_main(capsys, ["sweep", SCENARIO, "--vary", "controller.beta=1,2", "--set", SHORT, "-q",
                                       "--metrics", "sat1_impulse_nms,spectral_radius"])
    lines = out.splitlines()
    assert status == 0 and "2 points x 1 seed = 2 runs in 1 batch (compile" in lines[0]
    assert lines[1].split() == ["controller.beta", "sat1_impulse_nms", "spectral_radius"]
    assert [line.split()[0] for line in lines[2:4]] == ["1", "2"]


BAD = [
    (["--vary", "controller.alphaa=1,2"], "controller.alphaa"),
    (["--vary", "controller.alpha"], "expected FIELD=V1,V2"),
    (["--vary", "controller.alpha="], "no values"),
    (["--vary", "controller.alpha=1,,2"], "empty value"),
    (["--vary", "controller.alpha=1,2", "--vary", "controller.beta=1,2,3"], "differ in length"),
    (["--vary", "controller.alpha=1,2", "--metrics", "final_rate_spread,sync_time_s"], "unknown metric 'final_rate_spread'"),
    (["--vary", "controller.alpha=1,2", "--plot", "controller.alpha:no_such_metric"], "unknown metric 'no_such_metric'"),
    (["--vary", "controller.alpha=1,2", "--plot", "controller.alpha"], "expected X:Y"),
    (["--vary", "controller.alpha=1,2", "--seeds", "0"], "seeds 0: must be at least 1"),
]


@pytest.mark.parametrize(("args", "says"), BAD, ids=[b[1] for b in BAD])
def test_bad_input_exits_2_with_one_line_and_writes_nothing(capsys, tmp_path, args, says):
    out = tmp_path / "s"
    status, stdout, err = run_main(capsys, ["sweep", SCENARIO, *args, "--set", SHORT, "--out", out, "-q"])
    lines = err.strip().splitlines()
    assert status == EXIT_BAD_INPUT and stdout == "" and "Traceback" not in err
    assert len(lines) == 1 and lines[0].startswith("coopsat: error:") and says in lines[0], err
    assert list(tmp_path.iterdir()) == []


def test_plot_needs_an_out_folder(capsys):
    status, _, err = run_main(capsys, ["sweep", SCENARIO, "--vary", "controller.alpha=1,2", "--plot", "controller.alpha:sat1_impulse_nms"])
    assert status == EXIT_BAD_INPUT and "need a folder to receive the figures (out_dir, the command's --out)" in err


def test_an_existing_folder_that_is_not_a_sweep_is_refused(capsys, tmp_path):
    (tmp_path / "keep.txt").write_text("mine")
    status, _, err = run_main(capsys, ["sweep", SCENARIO, "--vary", "controller.alpha=1,2", "--set", SHORT, "--out", tmp_path, "-q"])
    assert status == EXIT_BAD_INPUT and "not a sweep folder" in err and [p.name for p in tmp_path.iterdir()] == ["keep.txt"]
