"""The command line on bad input: exit 2, one ``coopsat: error:`` line, no traceback, no run folder.

Most cases call :func:`coopsat.cli.main` in-process; two run ``python -m coopsat.cli`` in a
subprocess, to prove the real exit status and the real stderr. The happy paths check that
list/show/validate/run do what they say.
"""

import json
import subprocess
import sys
import tomllib

import pytest

from coopsat.cli import EXIT_BAD_INPUT, main
from coopsat.scenarios.load import bundled_names

VALID = """\
name = "{name}"
[sim]
t_final_s = 1.0
dt_s = 0.01
[[spacecraft]]
inertia_kgm2 = [1.0, 0.9, 1.1]
q_bi = {q}
omega_b_rad_s = [0.1, 0.0, 0.0]
[[spacecraft]]
inertia_kgm2 = [1.0, 1.2, 0.8]
[network]
kind = "ring"
[controller]
kind = "consensus-sync"
period_s = 0.01
{gains}
"""

# Huge gains on tiny inertias with an ideal (unsaturated) actuator: the sampled loop's
# spectral radius is ~1e7, and the state overflows within a few periods.
BLOWUP = """\
name = "blowup"
[sim]
t_final_s = 50.0
dt_s = 0.1
[[spacecraft]]
inertia_kgm2 = [0.01, 0.01, 0.01]
q_bi = [0.75, 0.57, 0.30, -0.03]
omega_b_rad_s = [0.5, 0.0, 0.5]
[[spacecraft]]
inertia_kgm2 = [0.01, 0.012, 0.011]
omega_b_rad_s = [0.0, 0.5, 0.0]
[network]
kind = "ring"
[controller]
kind = "consensus-sync"
period_s = 0.1
alpha = 1e6
beta = 1e6
[actuators]
kind = "ideal-torque"
"""


@pytest.fixture
def work(tmp_path, monkeypatch):
    """Separate folders for inputs, the run folder's parent, and the working directory."""
    (tmp_path / "in").mkdir()
    (tmp_path / "runs").mkdir()
    (tmp_path / "cwd").mkdir()
    monkeypatch.chdir(tmp_path / "cwd")  # a default runs/ folder would land here
    return tmp_path


def write(work, stem, text):
    path = work / "in" / f"{stem}.toml"
    path.write_text(text, encoding="utf-8")
    return path


def misspelt(work):
    return write(work, "misspelt", VALID.format(name="misspelt", q="[1.0, 0.0, 0.0, 0.0]", gains="alpah = 1.0\nbeta = 2.0"))


def zero_quaternion(work):
    return write(work, "zeroq", VALID.format(name="zeroq", q="[0.0, 0.0, 0.0, 0.0]", gains="alpha = 1.0\nbeta = 2.0"))


def error_line(stderr):
    """The single ``coopsat: error:`` line of ``stderr`` (and no traceback anywhere)."""
    assert "Traceback" not in stderr, stderr
    lines = [line for line in stderr.splitlines() if line.startswith("coopsat: error:")]
    assert len(lines) == 1, stderr
    assert len(lines[0]) > len("coopsat: error: ") + 5
    return lines[0]


def assert_nothing_written(work, out):
    assert not out.exists()
    leftovers = sorted(p.name for p in out.parent.iterdir())
    assert leftovers == [], f"left behind in {out.parent}: {leftovers}"  # temp folders start with '.'
    assert sorted(p.name for p in (work / "cwd").iterdir()) == []


def run_main(capsys, argv):
    status = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


# ------------------------------------------------------------------------ bad input, in-process


def test_run_with_a_misspelt_key(work, capsys):
    out = work / "runs" / "r"
    status, _, err = run_main(capsys, ["run", misspelt(work), "--out", out, "--no-figures", "-q"])
    assert status == EXIT_BAD_INPUT == 2
    line = error_line(err)
    assert "controller.alpah" in line and "unknown field" in line
    assert_nothing_written(work, out)


def test_run_of_a_missing_file(work, capsys):
    out = work / "runs" / "r"
    missing = work / "in" / "nowhere.toml"
    status, _, err = run_main(capsys, ["run", missing, "--out", out, "--no-figures", "-q"])
    assert status == 2
    line = error_line(err)
    assert "nowhere.toml" in line and "no such scenario file" in line
    assert_nothing_written(work, out)


def test_validate_with_a_zero_quaternion(work, capsys):
    status, stdout, err = run_main(capsys, ["validate", zero_quaternion(work)])
    assert status == 2
    line = error_line(err)
    assert "spacecraft[0].q_bi" in line
    assert stdout == ""


def test_run_of_an_unknown_bundled_name(work, capsys):
    out = work / "runs" / "r"
    status, _, err = run_main(capsys, ["run", "consensus-snyc-a", "--out", out, "--no-figures", "-q"])
    assert status == 2
    line = error_line(err)
    assert "'consensus-snyc-a'" in line
    assert_nothing_written(work, out)


def test_run_with_a_bad_override(work, capsys):
    out = work / "runs" / "r"
    argv = ["run", "rigid-body-free", "--out", out, "--no-figures", "-q", "--set", "sim.dt_s=-1"]
    status, _, err = run_main(capsys, argv)
    assert status == 2
    assert "sim.dt_s" in error_line(err)
    assert_nothing_written(work, out)


def test_run_of_a_graph_without_spanning_tree(work, capsys):
    text = VALID.format(name="split", q="[1.0, 0.0, 0.0, 0.0]", gains="alpha = 1.0\nbeta = 2.0").replace(
        'kind = "ring"', 'kind = "edges"\ndirected = true\nedges = [["sat1", "sat2", 1.0], ["sat2", "sat1", 1.0]]'
    )
    text += "[[spacecraft]]\ninertia_kgm2 = [1.0, 1.0, 1.0]\n"  # sat3 hears no one, no one hears it
    out = work / "runs" / "r"
    status, _, err = run_main(capsys, ["run", write(work, "split", text), "--out", out, "--no-figures", "-q"])
    assert status == 2
    assert "spanning tree" in error_line(err)
    assert_nothing_written(work, out)


def test_run_that_turns_non_finite(work, capsys):
    out = work / "runs" / "r"
    status, _, err = run_main(capsys, ["run", write(work, "blowup", BLOWUP), "--out", out, "--no-figures", "-q"])
    assert status == 2
    line = error_line(err)
    assert "non-finite" in line
    assert_nothing_written(work, out)


def test_failed_run_keeps_an_existing_run_folder(work, capsys):
    out = work / "runs" / "r"
    out.mkdir()
    (out / "result.nc").write_text("previous run")
    status, _, err = run_main(capsys, ["run", misspelt(work), "--out", out, "--no-figures", "-q"])
    assert status == 2
    error_line(err)
    assert (out / "result.nc").read_text() == "previous run"
    assert sorted(p.name for p in out.parent.iterdir()) == ["r"]


# ---------------------------------------------------------------------- bad input, subprocess


def run_cli(*argv, cwd):
    return subprocess.run(
        [sys.executable, "-m", "coopsat.cli", *map(str, argv)],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=300,
    )


def test_subprocess_misspelt_key_exits_2_with_one_line(work):
    out = work / "runs" / "r"
    proc = run_cli("run", misspelt(work), "--out", out, "--no-figures", "-q", cwd=work / "cwd")
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("coopsat: error: ")
    assert "controller.alpah" in lines[0]
    assert proc.stdout == ""
    assert_nothing_written(work, out)


def test_subprocess_non_finite_run_exits_2_without_traceback(work):
    out = work / "runs" / "r"
    proc = run_cli("run", write(work, "blowup", BLOWUP), "--out", out, "--no-figures", "-q", cwd=work / "cwd")
    assert proc.returncode == 2, proc.stderr
    line = error_line(proc.stderr)
    assert "non-finite" in line
    # Besides the error, only design-time warnings (one line each) may appear.
    for other in proc.stderr.strip().splitlines():
        assert other == line or other.startswith("warning: "), proc.stderr
    assert_nothing_written(work, out)


# ------------------------------------------------------------------------------- happy paths


def test_list_prints_one_line_per_bundled_scenario(capsys):
    status, stdout, _ = run_main(capsys, ["list"])
    assert status == 0
    lines = stdout.strip().splitlines()
    names = bundled_names()
    assert len(names) >= 8
    assert len(lines) == len(names)
    assert [line.split()[0] for line in lines] == names


def test_list_into_a_closed_pipe_ends_quietly():
    """`coopsat list | head -0`: the reader has closed the pipe before the first line; no
    traceback, SIGPIPE's status."""
    proc = subprocess.Popen([sys.executable, "-m", "coopsat.cli", "list"], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()
    assert proc.wait(timeout=60) == 141
    assert proc.stderr.read() == b""


def test_show_prints_parseable_toml(capsys):
    status, stdout, _ = run_main(capsys, ["show", "consensus-sync-a"])
    assert status == 0
    raw = tomllib.loads(stdout)
    assert len(raw["spacecraft"]) == 5
    assert raw["controller"]["kind"] == "consensus-sync"


def test_show_resolved_prints_parseable_toml(capsys):
    status, stdout, _ = run_main(capsys, ["show", "consensus-sync-a-stable", "--resolved"])
    assert status == 0
    raw = tomllib.loads(stdout)
    assert "extends" not in raw
    assert len(raw["spacecraft"]) == 5
    assert raw["controller"]["period_s"] == 0.01


def test_show_of_an_unknown_name(capsys):
    status, _, err = run_main(capsys, ["show", "no-such-scenario"])
    assert status == 2
    error_line(err)


def test_validate_reports_the_unstable_published_period(capsys):
    status, stdout, err = run_main(capsys, ["validate", "consensus-sync-a"])
    assert status == 0
    assert stdout.startswith("ok: consensus-sync-a: 5 spacecraft")
    warning_lines = [line for line in err.splitlines() if line.startswith("warning: ")]
    assert any("UNSTABLE" in line for line in warning_lines), err
    assert "coopsat: error" not in err


def test_validate_of_a_stable_scenario_is_quiet(capsys):
    status, stdout, err = run_main(capsys, ["validate", "consensus-sync-a-stable"])
    assert status == 0
    assert stdout.startswith("ok:")
    assert "UNSTABLE" not in err


def test_run_writes_the_run_folder(work, capsys):
    out = work / "runs" / "r"
    argv = ["run", "rigid-body-free", "--out", out, "--no-figures", "-q", "--set", "sim.t_final_s=1.0"]
    status, stdout, err = run_main(capsys, argv)
    assert status == 0, err
    assert "coopsat: error" not in err
    assert stdout.startswith("wrote ")
    assert (out / "result.nc").is_file()
    metrics = json.loads((out / "metrics.json").read_text())
    assert isinstance(metrics, dict) and metrics
    assert not (out / "comparison.json").exists()  # rigid-body-free has no [published]
    assert not (out / "comparison.md").exists()
    assert not list(out.glob("*.png"))  # --no-figures
    assert sorted(p.name for p in out.parent.iterdir()) == ["r"]  # no temp folder left


def test_argparse_usage_error_exits_2(capsys):
    with pytest.raises(SystemExit) as info:
        main(["run"])
    assert info.value.code == 2
    assert "Traceback" not in capsys.readouterr().err


def test_run_refuses_to_replace_a_folder_that_is_not_a_run(tmp_path, capsys):
    precious = tmp_path / "thesis"
    precious.mkdir()
    (precious / "chapter1.tex").write_text("months of work")
    status = main(["run", "rigid-body-free", "--out", str(precious), "-q", "--set", "sim.t_final_s=1.0"])
    assert status == 2
    assert "not a coopsat run folder" in capsys.readouterr().err
    assert [p.name for p in precious.iterdir()] == ["chapter1.tex"]
    plain = tmp_path / "notes.txt"
    plain.write_text("keep me")
    assert main(["run", "rigid-body-free", "--out", str(plain), "-q", "--set", "sim.t_final_s=1.0"]) == 2
    assert plain.read_text() == "keep me"
    assert main(["run", "rigid-body-free", "--out", str(plain / "sub"), "-q", "--set", "sim.t_final_s=1.0"]) == 2


def test_runaway_sizes_and_seeds_are_refused_before_running(capsys):
    for override in ("sim.dt_s=1e-300", "sim.t_final_s=1e12", "seed=99999999999999999999999"):
        assert main(["validate", "rigid-body-free", "--set", override]) == 2
        err = capsys.readouterr().err
        assert err.startswith("coopsat: error: ") and err.count("\n") == 1


def test_a_folder_named_like_a_bundled_scenario_does_not_hide_it(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "rigid-body-free").mkdir()
    assert main(["validate", "rigid-body-free"]) == 0


# ------------------------------------------------------------- plug-in bad input (issue 5)

GOOD_GAINS = "alpha = 1.0\nbeta = 2.0"


@pytest.mark.parametrize(
    "extra, expected",
    [
        # a delay that is not a whole number of control periods (0.01 s)
        ('[network.delivery]\nkind = "delayed"\ndelay_s = 0.015', "network.delivery.delay_s (0.015 s) must be a whole number"),
        # a delay bound below a delay the draw may give
        (
            '[network.delivery]\nkind = "delayed"\n[network.delivery.random_delay]\n'
            "min_s = 0.05\nmax_s = 0.02\nhold_min_s = 0.01\nhold_max_s = 0.02",
            "network.delivery.random_delay: min_s (0.05 s) is above the bound max_s (0.02 s)",
        ),
        # a sensor rate that does not divide into control periods
        ('[[sensors]]\nkind = "gyro"\nsigma_rad_s = 1e-4\nperiod_s = 0.015', "sensors[0].period_s (0.015 s) must be a whole multiple"),
        # kinds that no plug-in provides: the message lists the kinds that exist
        ('[[sensors]]\nkind = "lidar"', "'star-tracker', 'gyro'"),
        ('[actuators]\nkind = "ion-engine"', "'ideal-torque', 'pwm-thrusters'"),
        # an actuator that executes a command the controller never issues
        ('[actuators]\nkind = "proportional-thrusters"', "executes the command 'force_lvlh' but the controller issues torque_b"),
    ],
)
def test_run_with_bad_plugin_input(work, capsys, extra, expected):
    text = VALID.format(name="plug", q="[1.0, 0.0, 0.0, 0.0]", gains=GOOD_GAINS) + extra + "\n"
    out = work / "runs" / "r"
    status, _, err = run_main(capsys, ["run", write(work, "plug", text), "--out", out, "--no-figures", "-q"])
    assert status == EXIT_BAD_INPUT
    assert expected in error_line(err)
    assert_nothing_written(work, out)


def test_run_with_a_route_lost_after_a_failure(work, capsys):
    text = VALID.format(name="route", q="[1.0, 0.0, 0.0, 0.0]", gains=GOOD_GAINS).replace(
        'kind = "ring"', 'kind = "ring"\ndirected = true'
    ) + (
        '[network.delivery]\nkind = "delayed"\nrelay = true\n'
        '[[network.switches]]\nt_s = 0.5\nkind = "edges"\ndirected = true\nedges = [["sat1", "sat2", 1.0]]\n'
    )
    out = work / "runs" / "r"
    status, _, err = run_main(capsys, ["run", write(work, "route", text), "--out", out, "--no-figures", "-q"])
    assert status == EXIT_BAD_INPUT
    assert "network.switches[0]: no route from sat2 to sat1 is left after this switch" in error_line(err)
    assert_nothing_written(work, out)
