"""`coopsat bench` in its own process, as a user runs it: the cases build their arrays
themselves (float64 must be on before), and the ceiling column comes from the source
checkout's benchmarks/ceiling.py."""

import subprocess
import sys
from pathlib import Path

import coopsat.workflows.bench as bench


def test_bench_runs_small_and_quotes_the_ceiling():
    proc = subprocess.run([sys.executable, "-m", "coopsat.cli", "bench", "--sizes", "5", "--steps", "200", "--batch", "0", "--orbit-sizes", "2"],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    # Installed from a wheel (CI), there is no benchmarks/ beside the package: the line says so.
    from_source = (Path(bench.__file__).resolve().parents[3] / "benchmarks" / "ceiling.py").is_file()
    assert ("no ceiling column" not in proc.stdout) == from_source
    rows = [line.split() for line in proc.stdout.splitlines() if line.startswith(("torque-free", "consensus "))]
    assert len(rows) == 2
    assert all(float(r[4]) >= 0.0 and float(r[7]) > 0.0 for r in rows)  # build s, M spacecraft-steps/s
    if from_source:
        assert 0.0 < float(rows[1][-1]) < 2.0  # fraction of the ceiling measured beside it
    # The orbit rows: J2, then every perturbation quoted as a multiple of the J2 tick.
    orbit = [line.split() for line in proc.stdout.splitlines() if line.startswith("orbit ")]
    assert [r[1] for r in orbit] == ["J2", "all"]
    assert float(orbit[1][-4].rstrip("×")) > 0.0


def test_a_row_whose_state_does_not_fit_is_skipped_in_one_line(monkeypatch):
    """The delayed row holds 201 periods of every message: at a size whose state passes the share of
    memory it is skipped with its size and why, instead of running out of memory."""
    import os

    from coopsat.workflows import bench

    real = os.sysconf
    monkeypatch.setattr(os, "sysconf", lambda name: 4096 if name == "SC_PHYS_PAGES" else real(name))  # a 16 MB machine
    assert bench.too_big(1000, "consensus-sync") is None  # 0.2 MB of state
    line = bench.too_big(1000, "consensus-sync", delayed=True)  # 11.5 MB: more than a quarter of 16 MB
    assert line.startswith("skipped: its loop state is 0.0 GB (the delay line holds 201 periods") and "\n" not in line


def test_a_million_spacecraft_ring_builds_from_an_edge_list():
    """No n × n matrix: the ring of 1e6 spacecraft is 2e6 links (its dense adjacency would be 8 TB).
    Built in a process of its own, so that its memory is measured alone and not kept by a test worker."""
    script = (
        "import resource\n"
        "from coopsat.core import runtime\n"
        "from coopsat.sim.synthetic import bench_system\n"
        "runtime.enable()\n"
        "before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss\n"
        "system = bench_system(1_000_000, 'consensus-sync', record_ticks=1)\n"
        "grown = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before\n"
        "print(tuple(system.network.src.shape), grown / 1024**2)\n"
    )
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=600, check=True)
    shape, grown_gb = proc.stdout.split(") ")
    assert shape + ")" == "(2, 1000000)"  # the padded in-neighbour table of a ring
    assert float(grown_gb) < 2.0


def test_on_a_gpu_the_bench_adds_its_section():
    """The GPU section names the device and its memory and asks for the rows a GPU is for."""
    import contextlib
    import io
    import types

    rows = []
    device = types.SimpleNamespace(platform="gpu", device_kind="NVIDIA H200",
                                   memory_stats=lambda: {"bytes_limit": 140 * 2**30})
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        bench.gpu_section(lambda *args: rows.append(args), device)
    assert out.getvalue() == "GPU section: NVIDIA H200, 140 GiB\n"
    assert rows == [("torque-free", 100_000, "none", None), ("consensus", 100_000, "consensus-sync", None),
                    ("torque-free", 1_000_000, "none", None), ("consensus", 1_000_000, "consensus-sync", None),
                    ("consensus", 5, "consensus-sync", 10_000), ("consensus", 5, "consensus-sync", 100_000)]


def test_on_a_gpu_the_bench_quotes_no_cpu_ceiling(monkeypatch, capsys):
    """On a GPU the ceiling column (a numba loop on this machine's cores) is not measured: it
    bounds no GPU row, and at the GPU section's sizes it would take minutes of the CPU a row."""
    import types

    import jax
    import pytest

    device = types.SimpleNamespace(platform="gpu", device_kind="NVIDIA H100", memory_stats=lambda: {"bytes_limit": 80 * 2**30})
    monkeypatch.setattr(jax, "devices", lambda *args: [device])
    monkeypatch.setattr(bench, "load_ceiling", lambda: pytest.fail("the CPU ceiling was loaded for a GPU"))
    monkeypatch.setattr(bench, "too_big", lambda *args, **kwargs: None)
    measured = []
    monkeypatch.setattr(bench, "measure", lambda n, controller, ticks, **kw: measured.append((n, kw["batch"])) or (0.1, 0.2, 0.5, 1e9))
    bench.run_benchmarks(sizes=(1000,), steps=2000, batch=0, native=False, orbit_sizes=())
    out = capsys.readouterr().out
    assert "(no ceiling column: the ceiling is a CPU loop; JAX runs on gpu)" in out
    assert "GPU section: NVIDIA H100, 80 GiB" in out
    assert (100_000, None) in measured and (5, 100_000) in measured
    consensus = [line.split() for line in out.splitlines() if line.startswith("consensus ")]
    assert consensus and all(len(r) == 8 for r in consensus)  # no ceiling columns after M sc-steps/s
