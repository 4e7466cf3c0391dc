"""``coopsat campaign run|replay``: a real Dask scheduler and worker on loopback, a LocalCluster,
SIGKILL and resume, replay, and bad input (exit 2, one line, nothing written).

One small campaign (200 s of consensus-sync-a-stable, 8 runs in 4 batches of 2, initial
rates and the attitude gain dispersed) is run once with ``--workers 1`` into a reference folder;
the other ways of running it must give the same rows, bit for bit.

Campaign runs go through the installed ``coopsat`` command in a subprocess (as a user runs
them; Dask's spawned workers need a real entry point), each in its own session so that a kill
reaches the whole process group.
"""

import json
import math
import os
import re
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from coopsat.workflows.campaign.runner import read_results, replay
from coopsat.cli import EXIT_BAD_INPUT, main

BIN = Path(sys.executable).parent
COOPSAT = str(BIN / "coopsat")
DASK = str(BIN / "dask")
RUNS, BATCHES = 8, 4

CAMPAIGN = f"""
description = "test campaign: 8 runs in 4 batches"
scenario = "consensus-sync-a-stable"
runs = {RUNS}
master_seed = 4242
batch_size = 2
overrides = ["sim.t_final_s=400"]  # ~0.8 s a batch (native PWM tick): time to SIGKILL between two batches

[[dispersions]]
field = "spacecraft.*.omega_b_rad_s"
distribution = "normal"
sigma = 0.05
mode = "absolute"

[[dispersions]]
field = "controller.alpha"
distribution = "normal"
sigma = 0.1
mode = "relative"
"""


def coopsat(*args, cwd, timeout=240):
    return subprocess.run([COOPSAT, *map(str, args)], cwd=cwd, capture_output=True, text=True, timeout=timeout)


def run_main(capsys, argv):
    status = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def one_error_line(err):
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("coopsat: error: "), err
    assert "Traceback" not in err
    return lines[0]


def rows_by_run(out_dir):
    rows = read_results(out_dir).to_pylist()
    ids = [r["run_id"] for r in rows]
    assert sorted(ids) == list(range(RUNS)), ids  # every run exactly once
    return {r["run_id"]: r for r in rows}


def assert_same_rows(a_dir, b_dir):
    """The same columns and, per run, the same values: floats bit for bit."""
    a, b = rows_by_run(a_dir), rows_by_run(b_dir)
    assert set(read_results(a_dir).column_names) == set(read_results(b_dir).column_names)
    floats = 0
    for k in range(RUNS):
        assert a[k].keys() == b[k].keys()
        for name, va in a[k].items():
            vb = b[k][name]
            if isinstance(va, float):
                assert isinstance(vb, float) and np.float64(va).tobytes() == np.float64(vb).tobytes(), (k, name, va, vb)
                floats += 1
            else:
                assert va == vb, (k, name, va, vb)
    assert floats >= RUNS * 10


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def live_in_group(pgid):
    """Processes of a process group that are still running (zombies left out)."""
    live = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            text = stat.read_text()
        except OSError:
            continue
        state, _, group = text[text.rindex(")") + 2:].split()[:3]
        if int(group) == pgid and state not in "ZX":
            live.append(int(stat.parent.name))
    return live


def stop_group(proc, sig=signal.SIGTERM, wait_s=15.0):
    """Signal a process started with ``start_new_session=True`` and all of its group; SIGKILL
    what is left after ``wait_s``."""
    try:
        os.killpg(proc.pid, sig)
    except ProcessLookupError:
        pass
    deadline = time.monotonic() + wait_s
    while live_in_group(proc.pid) and time.monotonic() < deadline:
        proc.poll()
        time.sleep(0.1)
    if live_in_group(proc.pid):
        os.killpg(proc.pid, signal.SIGKILL)
    proc.wait(timeout=30)


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    d = tmp_path_factory.mktemp("campaign")
    (d / "camp.toml").write_text(CAMPAIGN)
    return d


@pytest.fixture(scope="module")
def reference(work):
    """The campaign run once with a LocalCluster of one worker, its progress on a pipe."""
    done = coopsat("campaign", "run", "camp.toml", "--out", "ref", "--workers", "1", cwd=work)
    assert done.returncode == 0, done.stderr
    assert f"{RUNS} runs in {BATCHES} batches (0 already on disk); 0 failed" in done.stdout
    (work / "ref.stderr").write_text(done.stderr)
    return work / "ref"


def test_progress_on_a_pipe_is_a_plain_line_per_tenth(work, reference):
    err = (work / "ref.stderr").read_text()
    assert "\r" not in err  # no tqdm bar redrawn into a log
    lines = [line for line in err.splitlines() if line.startswith("campaign: ")]
    assert lines == [f"campaign: {25 * k} % ({2 * k}/{RUNS} runs)" for k in range(1, 5)], err


@pytest.mark.slow  # long: runs in CI's second pytest pass (README)
def test_quiet_resume_writes_nothing_on_stderr_and_records_each_calls_wall_time(work, reference):
    import shutil

    out = work / "quiet"
    shutil.copytree(reference, out)
    (out / "batches" / f"batch_{BATCHES - 1:06d}.parquet").unlink()
    done = coopsat("campaign", "run", "camp.toml", "--out", out, "--workers", "1", "-q", cwd=work)
    assert done.returncode == 0 and f"({BATCHES - 1} already on disk)" in done.stdout, done.stderr
    assert done.stderr == ""
    calls = json.loads((out / "calls.json").read_text())
    assert [c["batches"] for c in calls] == [BATCHES, 1] and all(c["wall_s"] > 0 for c in calls)


def test_campaign_list_names_every_bundled_campaign_with_its_description(capsys):
    from coopsat.workflows.campaign.catalogue import bundled_names, description

    status, out, err = run_main(capsys, ["campaign", "list"])
    assert status == 0 and err == ""
    lines = out.splitlines()
    assert [line.split()[0] for line in lines] == bundled_names() and len(lines) >= 5
    for name, line in zip(bundled_names(), lines):
        assert line.endswith(description(name)) and len(description(name)) > 20


def test_campaign_run_of_an_unknown_name(tmp_path, capsys):
    status, out, err = run_main(capsys, ["campaign", "run", "no-such-campaign", "--out", tmp_path / "c", "-q"])
    assert status == EXIT_BAD_INPUT and out == ""
    assert "no-such-campaign: neither a campaign file nor a bundled campaign" in one_error_line(err)


def test_local_cluster_writes_every_run_once(reference):
    rows = rows_by_run(reference)
    assert sorted(p.name for p in (reference / "batches").iterdir()) == [f"batch_{b:06d}.parquet" for b in range(BATCHES)]
    assert {r["status"] for r in rows.values()} == {"ok"}
    for r in rows.values():
        params = json.loads(r["params"])
        assert set(params) == {f"spacecraft.{i}.omega_b_rad_s" for i in range(5)} | {"controller.alpha"}
        assert math.isfinite(r["final_rate_spread_rad_s"]) and r["final_rate_spread_rad_s"] > 0
    assert len({r["seed"] for r in rows.values()}) == RUNS
    assert len({r["final_rate_spread_rad_s"] for r in rows.values()}) == RUNS  # dispersed: all differ
    marker = json.loads((reference / "campaign.json").read_text())
    assert marker["campaign"]["runs"] == RUNS and marker["campaign"]["master_seed"] == 4242


@pytest.mark.slow  # long: runs in CI's second pytest pass (README)
def test_dask_scheduler_and_worker_on_loopback_give_the_same_rows(work, reference, tmp_path):
    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    scheduler_log, worker_log = tmp_path / "scheduler.log", tmp_path / "worker.log"
    procs = []
    try:
        with open(scheduler_log, "w") as log:
            procs.append(subprocess.Popen(
                [DASK, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard",
                 "--dashboard-address", "127.0.0.1:0"],
                cwd=tmp_path, stdout=log, stderr=subprocess.STDOUT, start_new_session=True))
        with open(worker_log, "w") as log:
            procs.append(subprocess.Popen(
                [DASK, "worker", address, "--nthreads", "1", "--no-dashboard", "--local-directory", str(tmp_path / "w")],
                cwd=tmp_path, stdout=log, stderr=subprocess.STDOUT, start_new_session=True))
        deadline = time.monotonic() + 90
        while "Registered to:" not in worker_log.read_text():
            assert all(p.poll() is None for p in procs), scheduler_log.read_text() + worker_log.read_text()
            assert time.monotonic() < deadline, "the worker did not register within 90 s"
            time.sleep(0.2)
        done = coopsat("campaign", "run", "camp.toml", "--out", tmp_path / "sched", "--scheduler", address, "-q", cwd=work)
        assert done.returncode == 0, done.stderr
        assert f"{RUNS} runs in {BATCHES} batches (0 already on disk); 0 failed" in done.stdout
        assert "Register worker" in scheduler_log.read_text()
    finally:
        for p in reversed(procs):
            stop_group(p)
    assert_same_rows(reference, tmp_path / "sched")


@pytest.mark.slow  # long: runs in CI's second pytest pass (README)
def test_unreachable_scheduler_is_one_line_within_15_s(work, tmp_path):
    port = free_port()  # bound, then closed: nothing listens there
    out = tmp_path / "nowhere"
    t0 = time.monotonic()
    done = coopsat("campaign", "run", "camp.toml", "--out", out, "--scheduler", f"tcp://127.0.0.1:{port}", cwd=work, timeout=60)
    elapsed = time.monotonic() - t0
    assert done.returncode == EXIT_BAD_INPUT
    line = one_error_line(done.stderr)
    assert f"tcp://127.0.0.1:{port}" in line and "cannot reach" in line
    assert elapsed < 15.0, elapsed
    assert not out.exists()  # the scheduler is tried before the folder is made


@pytest.mark.slow  # long: runs in CI's second pytest pass (README)
def test_sigkill_then_resume_runs_every_run_exactly_once(work, reference):
    out = work / "killed"
    batches = out / "batches"
    argv = [COOPSAT, "campaign", "run", "camp.toml", "--out", str(out), "--workers", "1", "-q"]
    with open(work / "killed.log", "w") as log:
        proc = subprocess.Popen(argv, cwd=work, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    try:
        deadline = time.monotonic() + 180
        while not list(batches.glob("batch_*.parquet")):
            assert proc.poll() is None, "the campaign ended before a batch was seen: " + (work / "killed.log").read_text()
            assert time.monotonic() < deadline, "no batch within 180 s"
            time.sleep(0.01)
        group = live_in_group(proc.pid)
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            stop_group(proc, signal.SIGKILL)
    assert proc.returncode == -signal.SIGKILL
    assert len(group) >= 3, group  # the driver, the LocalCluster's nanny and its worker
    deadline = time.monotonic() + 15
    while live_in_group(proc.pid):  # the LocalCluster's nanny and worker died with the driver
        assert time.monotonic() < deadline, f"still running after SIGKILL: {live_in_group(proc.pid)}"
        time.sleep(0.1)
    kept = {p.name: p.stat() for p in batches.glob("batch_*.parquet")}
    assert 1 <= len(kept) < BATCHES, f"killed too late to test a resume: {sorted(kept)}"

    done = subprocess.run(argv, cwd=work, capture_output=True, text=True, timeout=240)
    assert done.returncode == 0, done.stderr
    assert f"({len(kept)} already on disk)" in done.stdout
    for name, st in kept.items():  # the batches on disk were not run or written again
        again = (batches / name).stat()
        assert (again.st_ino, again.st_mtime_ns, again.st_size) == (st.st_ino, st.st_mtime_ns, st.st_size)
    visible = sorted(str(p.relative_to(out)) for p in out.rglob("*") if not p.name.startswith("."))
    assert visible == sorted(["batches", "campaign.json", "calls.json", *[f"batches/batch_{b:06d}.parquet" for b in range(BATCHES)]])
    assert_same_rows(reference, out)


def test_replay_of_a_run_is_identical(reference, capsys):
    status, out, err = run_main(capsys, ["campaign", "replay", reference, 5])
    assert status == 0, out + err
    assert out.startswith("run 5: identical to the stored result, bit for bit")
    assert out.splitlines()[-1].startswith("provenance: replayed as the batch ran (")  # one line (issue 43)
    result = replay(reference, 3)
    stored, replayed = result.stored, result.replayed
    assert result.identical is True and result.provenance_differences == ()
    assert stored["status"] == replayed["status"] == "ok"
    numbers = [k for k, v in stored.items() if isinstance(v, float)]
    assert len(numbers) >= 10
    for k in numbers:
        assert np.float64(stored[k]).tobytes() == np.float64(replayed[k]).tobytes(), k
    assert stored["params"] == replayed["params"] and stored["seed"] == replayed["seed"]


def test_replay_of_a_run_that_is_not_there(reference, capsys):
    status, out, err = run_main(capsys, ["campaign", "replay", reference, RUNS])
    assert status == EXIT_BAD_INPUT and out == ""
    assert f"run {RUNS}" in one_error_line(err)


UNSATURATED = (Path(__file__).resolve().parents[1] / "data" / "consensus-unsaturated.toml").read_text()

UNSATURATED_CAMPAIGN = """
scenario = "unsaturated.toml"
runs = 4
master_seed = 20
batch_size = 4

[[dispersions]]
field = "spacecraft.*.omega_b_rad_s"
distribution = "normal"
sigma = 0.05
"""


@pytest.mark.slow  # long: runs in CI's second pytest pass (README)
def test_replay_of_a_run_from_a_batch_of_four_is_identical(tmp_path, capsys):
    (tmp_path / "unsaturated.toml").write_text(UNSATURATED)
    (tmp_path / "camp.toml").write_text(UNSATURATED_CAMPAIGN)
    done = coopsat("campaign", "run", "camp.toml", "--out", "c", "--workers", "1", "-q", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    differ = []
    for k in range(4):
        result = replay(tmp_path / "c", k)
        stored, replayed = result.stored, result.replayed
        assert stored["status"] == "ok"
        if not result.identical:
            differ.append((k, {n: (stored[n], replayed[n]) for n in stored if stored[n] != replayed[n]}))
    assert not differ, differ


# --- Bad input: one line, exit 2, nothing written ----------------------------------------------

BASE = 'scenario = "consensus-sync-a-stable"\nruns = 4\nmaster_seed = 1\n'


def dispersion(field, distribution="normal", **kw):
    if distribution == "normal":
        kw.setdefault("sigma", 0.1)
    extra = "".join(f"{k} = {json.dumps(v)}\n" for k, v in kw.items())
    return f'{BASE}\n[[dispersions]]\nfield = "{field}"\ndistribution = "{distribution}"\n{extra}'


BAD_FILES = {
    "unknown-field": (dispersion("spacecraft.*.nonexistent"), r"dispersions\[0\]\.field: 'spacecraft\.0\.nonexistent' is not a field"),
    "not-numeric": (dispersion("controller.kind"), r"dispersions\[0\]\.field: 'controller\.kind' is str .*not a number"),
    "negative-sigma": (dispersion("controller.alpha", sigma=-0.1), r"dispersions\[0\]: sigma must be ≥ 0"),
    "star-on-a-table": (dispersion("controller.*.alpha"), r"`\*` follows 'controller', which is not a list"),
    "star-on-a-number": (dispersion("controller.alpha.*"), r"`\*` follows 'controller\.alpha', which is not a list"),
    "unknown-top-level-key": (BASE + 'colour = "red"\n', r"^coopsat: error: colour: unknown field"),
    "low-above-high": (dispersion("controller.alpha", "uniform", low=2.0, high=1.0), r"dispersions\[0\]: uniform needs low ≤ high"),
    "choice-not-replace": (dispersion("controller.alpha", "choice", values=[1.0, 2.0]), r"dispersions\[0\]: choice .*mode = \"replace\""),
    "no-runs": (BASE.replace("runs = 4", "runs = 0"), r"runs: .*greater than 0"),
    "unknown-scenario": (BASE.replace("consensus-sync-a-stable", "no-such-scenario"), r"no-such-scenario"),
    "bad-override": (BASE + 'overrides = ["sim.t_final_s=-1"]\n', r"t_final_s"),
    "not-toml": ("scenario = \n", r"not valid TOML"),
}


@pytest.mark.parametrize("case", sorted(BAD_FILES))
def test_bad_campaign_file(case, tmp_path, capsys):
    text, pattern = BAD_FILES[case]
    (tmp_path / "bad.toml").write_text(text)
    out = tmp_path / "out"
    status, stdout, err = run_main(capsys, ["campaign", "run", tmp_path / "bad.toml", "--out", out, "-q"])
    assert status == EXIT_BAD_INPUT, stdout + err
    assert re.search(pattern, one_error_line(err)), err
    assert not out.exists()


def test_workers_zero(work, capsys):
    out = work / "zero"
    status, stdout, err = run_main(capsys, ["campaign", "run", work / "camp.toml", "--out", out, "--workers", 0, "-q"])
    assert status == EXIT_BAD_INPUT
    assert "--workers 0" in one_error_line(err)
    assert not out.exists()


def test_folder_holding_another_campaign(work, reference, capsys):
    before = {str(p): p.stat().st_mtime_ns for p in reference.rglob("*")}
    other = work / "other.toml"
    other.write_text(CAMPAIGN.replace("master_seed = 4242", "master_seed = 4243"))
    status, stdout, err = run_main(capsys, ["campaign", "run", other, "--out", reference, "-q"])
    assert status == EXIT_BAD_INPUT
    assert "holds another campaign" in one_error_line(err)
    assert {str(p): p.stat().st_mtime_ns for p in reference.rglob("*")} == before


def test_folder_that_is_not_a_campaign_folder(work, tmp_path, capsys):
    (tmp_path / "keep.txt").write_text("mine")
    status, stdout, err = run_main(capsys, ["campaign", "run", work / "camp.toml", "--out", tmp_path, "-q"])
    assert status == EXIT_BAD_INPUT
    assert "not a campaign folder" in one_error_line(err)
    assert [p.name for p in tmp_path.iterdir()] == ["keep.txt"]


@pytest.mark.slow  # long: runs in CI's second pytest pass (README)
def test_a_full_disk_stops_with_one_line_keeps_finished_batches_and_resumes(work, reference, tmp_path, capsys, monkeypatch):
    """The disk fills while the second batch is written (a partial Parquet file, then ENOSPC):
    exit 2 with one line, the first batch complete, nothing half-written; with room again the
    same command finishes the campaign, every run once and equal to the reference."""
    import errno

    import pyarrow.parquet as pq

    real_write, written = pq.write_table, []

    def fills_up(table, where, **kw):
        written.append(where)
        if len(written) == 2:
            Path(where).write_bytes(b"PAR1 half a footer")  # what a full disk leaves behind
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real_write(table, where, **kw)

    out = tmp_path / "full"
    monkeypatch.setattr(pq, "write_table", fills_up)
    status, _, err = run_main(capsys, ["campaign", "run", work / "camp.toml", "--out", out, "--workers", "1", "-q"])
    assert status == EXIT_BAD_INPUT
    line = one_error_line(err)
    assert os.strerror(errno.ENOSPC) in line and "the 1 batches on disk are complete" in line, line
    assert [p.name for p in (out / "batches").iterdir()] == ["batch_000000.parquet"]  # no partial file, no temporary
    assert read_results(out).num_rows == 2

    monkeypatch.setattr(pq, "write_table", real_write)
    status, stdout, _ = run_main(capsys, ["campaign", "run", work / "camp.toml", "--out", out, "--workers", "1", "-q"])
    assert status == 0 and f"{RUNS} runs in {BATCHES} batches (1 already on disk)" in stdout
    assert_same_rows(out, reference)


@pytest.mark.slow  # long: runs in CI's second pytest pass (README)
def test_finished_batches_are_released_on_the_worker_as_they_are_written(work, tmp_path, capsys, monkeypatch):
    """A campaign larger than memory streams to disk: when the k-th batch is about to be
    written, the worker holds only the results not yet written (BATCHES − k), not every result
    so far. (Releases travel to the worker asynchronously: each count is polled for up to 5 s.)"""
    from distributed import default_client

    import coopsat.workflows.campaign.runner as runner

    real_write, held = runner.write_batch, []

    def worker_results():
        return sum(default_client().run(lambda dask_worker: sum(str(k).startswith("batch-") for k in dask_worker.data)).values())

    def counting_write(out_dir, b, rows, series=None, provenance=None):
        unwritten = BATCHES - len(held)
        deadline = time.monotonic() + 5.0
        while (n := worker_results()) > unwritten and time.monotonic() < deadline:
            time.sleep(0.05)
        held.append(n)
        return real_write(out_dir, b, rows, series, provenance)

    monkeypatch.setattr(runner, "write_batch", counting_write)
    status, _, err = run_main(capsys, ["campaign", "run", work / "camp.toml", "--out", tmp_path / "c", "--workers", "1", "-q"])
    assert status == 0, err
    assert len(held) == BATCHES and all(n <= BATCHES - k for k, n in enumerate(held)), held


def test_local_workers_run_on_one_cpu_device():
    """Each local worker is one process on one CPU device (its batches are not split between
    cores, so a stored result does not depend on the machine's core count)."""
    from coopsat.workflows.campaign.runner import client_for

    def devices():
        from coopsat.core import runtime  # noqa: F401

        import jax

        return len(jax.devices())

    client = client_for(workers=1)
    try:
        assert list(client.run(devices).values()) == [1]
    finally:
        cluster = client.cluster
        client.close()
        cluster.close()
