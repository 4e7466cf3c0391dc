"""SIGINT and SIGTERM at every phase of a command that writes a folder: the exit status is 130
or 143, never 0, and the folder is either absent with the last line "nothing written", or
complete with a last line that says so (the rule of coopsat.workflows.interrupt: a stop before
the rename leaves nothing, one during or after it leaves the complete folder).

The signal is sent by the process to itself as a chosen function is entered (a monkeypatched
wrapper around it), through ``main`` in this process: each phase is hit exactly, and the
compiled loop is reused between cases. One case signals a ``coopsat run`` subprocess from
outside while its folder is being written, at whatever point that happens to be.
"""

import json
import os
import pathlib
import signal
import subprocess
import sys
import time

import pytest
import xarray as xr

from coopsat.cli import EXIT_INTERRUPTED, EXIT_TERMINATED, main
from coopsat.workflows import interrupt

RUN = ["run", "consensus-sync-a-stable", "--set", "sim.t_final_s=5"]
STATUS = {signal.SIGINT: EXIT_INTERRUPTED, signal.SIGTERM: EXIT_TERMINATED}
WORD = {signal.SIGINT: "interrupted (SIGINT)", signal.SIGTERM: "terminated (SIGTERM)"}


def signal_on_entry(monkeypatch, owner, name, sig, times=1):
    """Make ``owner.name`` send ``sig`` to this process ``times`` times as it is entered."""
    real = getattr(owner, name)

    def wrapped(*args, **kwargs):
        # Never SIGTERM a test process that has no handler of ours: fail instead.
        assert signal.getsignal(sig) is interrupt.request, "coopsat's handler is not installed"
        for _ in range(times):
            os.kill(os.getpid(), sig)
        return real(*args, **kwargs)

    monkeypatch.setattr(owner, name, wrapped)


def stopped(capsys, argv, sig):
    """Run ``coopsat argv`` in this process; check the status for ``sig``, no traceback, and
    return the last line on stderr."""
    status = main([str(a) for a in argv])
    err = capsys.readouterr().err
    assert status == STATUS[sig], err
    assert "Traceback" not in err
    return err.strip().splitlines()[-1]


def listing(folder):
    return sorted(p.name for p in pathlib.Path(folder).iterdir())


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The run folder written without a signal, without and with figures."""
    base = tmp_path_factory.mktemp("reference")
    for name, extra in (("plain", []), ("figures", ["--figures"])):
        assert main([*RUN, "--out", str(base / name), "-q", *extra]) == 0
    return base


def assert_nothing_written(line, parent, sig):
    assert line == f"coopsat: {WORD[sig]}; nothing written"
    assert not parent.exists() or listing(parent) == []  # no folder, no temporary sibling


def assert_complete(line, out, reference, sig):
    assert line == f"coopsat: {WORD[sig]} after writing: the folder {out} is complete"
    assert listing(out) == listing(reference)
    assert json.loads((out / "metrics.json").read_text()) == json.loads((reference / "metrics.json").read_text())
    with xr.open_dataset(out / "result.nc", engine="h5netcdf") as ds:
        assert ds.sizes["time"] > 1
    assert listing(out.parent) == [out.name]  # no temporary sibling left


def _phase(name):
    """(object, attribute) whose entry marks a phase of ``coopsat run``, imported late so that
    the modules are those the run uses."""
    import coopsat.plots.figures
    import coopsat.scenarios.document
    import coopsat.sim.engine
    import coopsat.workflows.pipeline

    return {
        "load": (coopsat.scenarios.document, "with_overrides"),
        "build": (coopsat.workflows.pipeline, "prepare"),
        "compile": (coopsat.sim.engine, "simulate"),
        "simulate": (coopsat.sim.engine, "_run_chunks"),
        "metrics": (coopsat.workflows.pipeline, "analyse"),
        "write-result": (xr.Dataset, "dump_to_store"),
        "write-figures": (coopsat.plots.figures, "save_figures"),
    }[name]


BEFORE_RENAME = ["load", "build", "compile", "simulate", "metrics", "write-result", "write-figures"]


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
@pytest.mark.parametrize("phase", BEFORE_RENAME)
def test_a_signal_before_the_rename_leaves_nothing(phase, sig, tmp_path, capsys, monkeypatch):
    parent = tmp_path / "runs"
    signal_on_entry(monkeypatch, *_phase(phase), sig)
    figures = ["--figures"] if phase == "write-figures" else []
    line = stopped(capsys, [*RUN, "--out", parent / "r", "-q", *figures], sig)
    assert_nothing_written(line, parent, sig)


def test_a_stop_while_the_record_is_written_does_not_wait_for_the_figures(tmp_path, capsys, monkeypatch):
    import coopsat.plots.figures

    drawn = []
    monkeypatch.setattr(coopsat.plots.figures, "save_figures", lambda *args, **kwargs: drawn.append(args))
    signal_on_entry(monkeypatch, xr.Dataset, "dump_to_store", signal.SIGINT)
    line = stopped(capsys, [*RUN, "--out", tmp_path / "runs" / "r", "-q", "--figures"], signal.SIGINT)
    assert_nothing_written(line, tmp_path / "runs", signal.SIGINT)
    assert drawn == []


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
@pytest.mark.parametrize("times", [1, 2])
def test_a_signal_during_the_rename_leaves_the_complete_folder_and_says_so(times, sig, tmp_path, capsys, monkeypatch,
                                                                          reference):
    # A second signal stops at once, but not in the middle of the rename.
    from coopsat.workflows import folders

    out = tmp_path / "runs" / "r"
    signal_on_entry(monkeypatch, folders, "_rename_into_place", sig, times)
    line = stopped(capsys, [*RUN, "--out", out, "-q", "--no-figures"], sig)
    assert_complete(line, out, reference / "plain", sig)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_after_the_wrote_line_leaves_the_complete_folder_and_says_so(sig, tmp_path, capsys, monkeypatch,
                                                                             reference):
    import coopsat.workflows.pipeline as pipeline

    out = tmp_path / "runs" / "r"
    signal_on_entry(monkeypatch, pipeline, "summary_lines", sig)  # printed after "wrote OUT"
    status = main([str(a) for a in [*RUN, "--out", out, "--no-figures"]])
    captured = capsys.readouterr()
    assert status == STATUS[sig]
    assert captured.out.startswith(f"wrote {out}")
    assert_complete(captured.err.strip().splitlines()[-1], out, reference / "plain", sig)


def test_an_existing_folder_is_kept_whole_by_a_signal_before_the_rename(tmp_path, capsys, monkeypatch, reference):
    import coopsat.workflows.pipeline as pipeline

    out = tmp_path / "r"
    assert main([*RUN, "--out", str(out), "-q", "--no-figures", "--set", "seed=5"]) == 0
    before = (out / "metrics.json").read_bytes()
    capsys.readouterr()
    signal_on_entry(monkeypatch, pipeline, "analyse", signal.SIGINT)
    line = stopped(capsys, [*RUN, "--out", out, "-q", "--no-figures"], signal.SIGINT)
    assert line.endswith("; nothing written")
    assert (out / "metrics.json").read_bytes() == before and listing(tmp_path) == ["r"]


def test_a_handled_stop_is_forgotten_once_the_command_returns(tmp_path, capsys, monkeypatch):
    # A stop belongs to the command it interrupted: the next call in this process runs on.
    import coopsat.workflows.pipeline as pipeline

    signal_on_entry(monkeypatch, pipeline, "summary_lines", signal.SIGINT)
    stopped(capsys, [*RUN, "--out", tmp_path / "a", "--no-figures"], signal.SIGINT)
    interrupt.check()  # raises if the request were still pending
    monkeypatch.undo()
    assert main([*RUN, "--out", str(tmp_path / "b"), "-q", "--no-figures"]) == 0


SWEEP = ["sweep", "consensus-sync-a-stable", "--vary", "controller.alpha=0.8,1.2", "--set", "sim.t_final_s=5", "-q"]
PAIR = ["pair", "consensus-sync-a-stable", "consensus-sync-a-stable", "--seeds", "1", "--set", "sim.t_final_s=5", "-q"]


@pytest.mark.parametrize("argv, module", [(SWEEP, "sweep"), (PAIR, "pair")])
def test_sweep_and_pair_follow_the_same_rule(argv, module, tmp_path, capsys, monkeypatch):
    import importlib

    from coopsat.workflows import folders

    writer = importlib.import_module(f"coopsat.workflows.{module}")
    with monkeypatch.context() as patch:  # while the folder is written: nothing
        signal_on_entry(patch, writer, "json_ready", signal.SIGTERM)
        line = stopped(capsys, [*argv, "--out", tmp_path / "before" / "x"], signal.SIGTERM)
    assert_nothing_written(line, tmp_path / "before", signal.SIGTERM)
    out = tmp_path / "during" / "x"  # during the rename: the complete folder
    signal_on_entry(monkeypatch, folders, "_rename_into_place", signal.SIGINT)
    line = stopped(capsys, [*argv, "--out", out], signal.SIGINT)
    assert line == f"coopsat: interrupted (SIGINT) after writing: the folder {out} is complete"
    assert listing(out) and listing(out.parent) == ["x"]


def test_sigint_from_outside_while_the_folder_is_written(tmp_path, reference):
    """The issue's case: SIGINT while the run folder (figures included) is being written gives
    status 130 and either no folder ("nothing written") or the complete one, said last."""
    parent = tmp_path / "runs"
    parent.mkdir()
    out = parent / "r"
    proc = subprocess.Popen([sys.executable, "-m", "coopsat.cli", *RUN, "--out", str(out), "-q", "--figures"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 240
    while not any(p.name.startswith(".r.") for p in parent.iterdir()):  # the temporary sibling
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "the run folder was not started within 240 s"
        time.sleep(0.002)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == EXIT_INTERRUPTED, err
    assert "Traceback" not in err
    line = err.strip().splitlines()[-1]
    if out.exists():
        assert_complete(line, out, reference / "figures", signal.SIGINT)
    else:
        assert_nothing_written(line, parent, signal.SIGINT)


CAMPAIGN = """
scenario = "consensus-sync-a-stable"
runs = 6
master_seed = 3
batch_size = 1
overrides = ["sim.t_final_s=400"]  # about a second a batch: time to stop between two

[[dispersions]]
field = "controller.alpha"
distribution = "normal"
sigma = 0.1
mode = "relative"
"""


@pytest.mark.slow  # long: runs in CI's second pytest pass (README)
def test_ctrl_c_stops_a_campaign_between_batches_and_the_same_command_resumes_it(tmp_path):
    """SIGINT to the whole process group (as Ctrl-C sends it): the workers ignore it, the driver
    writes the batch in hand and stops, status 130, its last line counting the batches on disk."""
    import re

    from coopsat.workflows.campaign.runner import read_results

    (tmp_path / "camp.toml").write_text(CAMPAIGN)
    argv = [str(pathlib.Path(sys.executable).parent / "coopsat"), "campaign", "run", "camp.toml", "--out", "c",
            "--workers", "1", "-q"]
    proc = subprocess.Popen(argv, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    batches = tmp_path / "c" / "batches"
    deadline = time.monotonic() + 240
    while not (batches.is_dir() and any(batches.glob("batch_*.parquet"))):
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "no batch within 240 s"
        time.sleep(0.01)
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == EXIT_INTERRUPTED, err
    assert "Traceback" not in err and "still alive" not in err, err
    on_disk = len(list(batches.glob("batch_*.parquet")))
    out = pathlib.Path("c")
    expected = (f"the folder {out} is complete (6 batches)" if on_disk == 6 else
                f"the folder {out} holds {on_disk} of 6 batches, each complete (the same command resumes the campaign)")
    assert err.strip().splitlines()[-1] == f"coopsat: interrupted (SIGINT) after writing: {expected}"
    done = subprocess.run(argv, cwd=tmp_path, capture_output=True, text=True, timeout=240)
    assert done.returncode == 0, done.stderr
    assert re.search(rf"6 runs in 6 batches \({on_disk} already on disk\)", done.stdout), done.stdout
    assert sorted(read_results(tmp_path / "c").column("run_id").to_pylist()) == list(range(6))
