"""Malformed scenario files and signals, class by class (issue 6): exit 2 (130/143 for
signals), one line on stderr, no traceback, nothing written."""

import signal
import subprocess
import sys
import time

import pytest

from coopsat.cli import EXIT_BAD_INPUT, main

GOOD = """\
name = "good"
[sim]
t_final_s = 1.0
dt_s = 0.01
[[spacecraft]]
inertia_kgm2 = [1.0, 0.9, 1.1]
[[spacecraft]]
inertia_kgm2 = [1.0, 1.2, 0.8]
[network]
kind = "ring"
[controller]
kind = "consensus-sync"
period_s = 0.01
alpha = 1.0
beta = 2.0
short_way = false
"""


def _run(tmp_path, capsys, path):
    out = tmp_path / "runs" / "r"
    status = main(["run", str(path), "--out", str(out), "--no-figures", "-q"])
    err = capsys.readouterr().err
    assert status == EXIT_BAD_INPUT
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("coopsat: error: "), err
    assert not (tmp_path / "runs").exists() or not any((tmp_path / "runs").iterdir())
    return lines[0]


@pytest.mark.parametrize(
    "old, new, expected",
    [
        ("alpha = 1.0", "alpha = true", "controller.alpha: Input should be a valid number, got a boolean (true)"),
        ("dt_s = 0.01", 'dt_s = "0.01"', "sim.dt_s: Input should be a valid number, got a string ('0.01')"),
        ("short_way = false", 'short_way = "yes"', "controller.short_way: Input should be a valid boolean, got a string ('yes')"),
        ('kind = "ring"', "kind = 3", "network.kind: Input should be"),
        ("beta = 2.0", 'beta = [2.0]', "controller.beta: Input should be a valid number, got an array"),
    ],
)
def test_wrong_types_are_refused_not_coerced(tmp_path, capsys, old, new, expected):
    path = tmp_path / "s.toml"
    path.write_text(GOOD.replace(old, new), encoding="utf-8")
    assert expected in _run(tmp_path, capsys, path)


def test_the_good_file_runs(tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text(GOOD, encoding="utf-8")
    assert main(["validate", str(path)]) == 0


@pytest.mark.parametrize(
    "content, expected",
    [
        (GOOD.encode("utf-16"), "is a binary file, not TOML text"),
        (b"\x89PNG\r\n\x1a\n\x00\x00", "is a binary file"),
        (GOOD.replace("good", "g\xe9").encode("latin-1"), "is not UTF-8 text"),
        (b"[sim\n", "not valid TOML"),
    ],
)
def test_unreadable_contents_say_what_is_wrong(tmp_path, capsys, content, expected):
    path = tmp_path / "s.toml"
    path.write_bytes(content)
    assert expected in _run(tmp_path, capsys, path)


def test_a_directory_named_like_a_scenario(tmp_path, capsys):
    (tmp_path / "x.toml").mkdir()
    assert "is a directory, not a scenario file" in _run(tmp_path, capsys, tmp_path / "x.toml")


def test_a_file_too_large(tmp_path, capsys):
    path = tmp_path / "big.toml"
    path.write_text(GOOD + "#" * (11 * 2**20), encoding="utf-8")
    assert "too large for a scenario file" in _run(tmp_path, capsys, path)


def test_unbounded_input_is_not_echoed_whole(tmp_path, capsys):
    key = "k" * 100_000
    path = tmp_path / "s.toml"
    path.write_text(GOOD + f"{key} = 1\n", encoding="utf-8")
    line = _run(tmp_path, capsys, path)
    assert len(line) < 400 and "(100000 characters)" in line and "unknown field" in line


@pytest.mark.slow
@pytest.mark.parametrize("sig, status", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_signal_ends_a_run_with_one_line_and_nothing_written(tmp_path, sig, status):
    out = tmp_path / "runs" / "r"
    proc = subprocess.Popen(
        [sys.executable, "-m", "coopsat.cli", "run", "consensus-track-stable", "--set", "sim.t_final_s=30000",
         "--out", str(out), "-q"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    time.sleep(6.0)  # start-up and compilation, then into the loop
    assert proc.poll() is None, "the run ended before the signal"
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == status, err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert not out.exists() and not (tmp_path / "runs").exists() or not any((tmp_path / "runs").iterdir())


@pytest.mark.parametrize(
    "old, new, expected",
    [
        ("t_final_s = 1.0", "t_final_s = 1e308", "sim.t_final_s: Input should be less than or equal to"),
        ("dt_s = 0.01", "dt_s = 5e-324", "sim.dt_s: Input should be greater than or equal to"),
        ("alpha = 1.0", "alpha = 1e308", "controller.alpha: Input should be less than or equal to"),
        ("inertia_kgm2 = [1.0, 0.9, 1.1]", "inertia_kgm2 = [1e308, 1e308, 1e308]", "spacecraft[0].inertia_kgm2: entries must be finite and at most"),
        ("inertia_kgm2 = [1.0, 0.9, 1.1]", "inertia_kgm2 = [1e-12, 1e-12, 1e-12]", "spacecraft[0].inertia_kgm2: smallest principal moment"),
        ("beta = 2.0", "beta = 2.0\n[actuators]\nkind = \"ideal-torque\"\ntorque_max_nm = 1e308", "actuators.torque_max_nm: Input should be less than or equal to"),
    ],
)
def test_extreme_values_are_refused_with_the_field(tmp_path, capsys, old, new, expected):
    path = tmp_path / "s.toml"
    path.write_text(GOOD.replace(old, new, 1), encoding="utf-8")
    assert expected in _run(tmp_path, capsys, path)


def test_the_largest_valid_values_still_validate(tmp_path, capsys):
    # Gains and inertias at the edges of their ranges: the design checks must not crash.
    text = GOOD.replace("alpha = 1.0", "alpha = 1e6").replace("beta = 2.0", "beta = 1e6").replace(
        "inertia_kgm2 = [1.0, 0.9, 1.1]", "inertia_kgm2 = [1e-9, 1e-9, 1e-9]"
    )
    path = tmp_path / "s.toml"
    path.write_text(text, encoding="utf-8")
    assert main(["validate", str(path)]) == 0
    assert "Traceback" not in capsys.readouterr().err


def test_a_run_estimated_too_long_is_refused_before_it_starts(tmp_path, capsys):
    # 3e9 ticks of 2 spacecraft at 2 M spacecraft-steps/s: 50 min, above the 30 min threshold.
    path = tmp_path / "s.toml"
    path.write_text(GOOD.replace("t_final_s = 1.0", "t_final_s = 3e7").replace("dt_s = 0.01", "dt_s = 0.01\nrecord_interval_s = 1e4"), encoding="utf-8")
    line = _run(tmp_path, capsys, path)
    assert "would take about 0.83 h" in line and "--allow-long" in line
