"""What a new user waits for: wall time of whole ``coopsat`` commands, warm and cold (issue 26).

Each command runs as its own process, the way a user types it, and is timed from start to exit
(Python's start-up and every import included). Printed per row: the median and the range over
the repeats, and the target.

* warm: caches as a second run finds them (JAX's persistent compilation cache, the design
  results and the native kernels' verdict kept beside it: one untimed run fills them first);
* cold: each repeat with an empty cache folder (``COOPSAT_JAX_CACHE`` pointed at a new one),
  as the very first run after installing.

Two lower bounds follow the table: the imports alone that any one-shot run with figures pays
(JAX, xarray with h5netcdf, matplotlib), and a run repeated in a process that has already run
it (imports and compilation paid: what a resident process would still pay per run).

Usage: ``python benchmarks/latency.py [--repeats N] [--cold-repeats N]``. A benchmark, not a
test: the machine's load moves the figures; quote them with the load (printed).
"""

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

COMMANDS = [
    # (label, argv after "coopsat", target s, cold)
    ("coopsat list", ["list"], 0.3, False),
    ("coopsat validate consensus-sync-a-stable", ["validate", "consensus-sync-a-stable"], 1.0, False),
    ("coopsat run consensus-sync-a (figures included)", ["run", "consensus-sync-a", "--out", "{out}"], 2.0, False),
    ("coopsat run consensus-sync-a, cold caches", ["run", "consensus-sync-a", "--out", "{out}"], 8.0, True),
]


def _coopsat(module=False):
    """The ``coopsat`` script beside this interpreter (the installed command), else (or with
    ``module``) ``python -m coopsat.cli``."""
    script = Path(sys.executable).with_name("coopsat")
    return [str(script)] if script.exists() and not module else [sys.executable, "-m", "coopsat.cli"]


def timed(argv, env, workdir):
    """Wall time of one command, s (it must succeed)."""
    start = time.perf_counter()
    done = subprocess.run(argv, env=env, cwd=workdir, capture_output=True, text=True)
    elapsed = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(argv)} failed ({done.returncode}): {done.stderr.strip()[-500:]}")
    return elapsed


def measure(args, repeats, cold, workdir, module=False):
    """Wall times of ``repeats`` runs of ``coopsat args`` (each in a new run folder)."""
    env = dict(os.environ)
    warm_cache = Path(workdir) / "warm-cache"
    times = []
    for k in range(repeats + (0 if cold else 1)):
        cache = Path(workdir) / f"cold-cache-{k}" if cold else warm_cache
        env["COOPSAT_JAX_CACHE"] = str(cache)
        argv = _coopsat(module) + [a.format(out=Path(workdir) / f"run-{k}") for a in args]
        elapsed = timed(argv, env, workdir)
        if cold:
            shutil.rmtree(cache, ignore_errors=True)
        if cold or k > 0:  # the first warm run fills the caches
            times.append(elapsed)
    return times


FLOOR_IMPORTS = "import jax.numpy, xarray, h5netcdf, matplotlib.figure"
"""What any one-shot ``coopsat run`` with figures must import: the closed loop (JAX), the
record (xarray, h5netcdf) and the figures (matplotlib)."""

IN_PROCESS = """
import shutil, statistics, sys, time
from coopsat.cli import configure_process
configure_process()
from coopsat.workflows.pipeline import run_scenario
times = []
for k in range(int(sys.argv[2]) + 1):
    out = f"{sys.argv[1]}/in-process-{k}"
    start = time.perf_counter()
    run_scenario("consensus-sync-a", out_dir=out)
    times.append(time.perf_counter() - start)
    shutil.rmtree(out)
print(" ".join(f"{t:.4f}" for t in times[1:]))
"""
"""A second and later ``run_scenario`` in one process: what a resident process would still pay
per run, everything imported and the program compiled."""


def floors(repeats, workdir):
    """(label, times) of the two lower bounds under the targets: the imports alone, and a run in
    a process that has already run it once."""
    env = dict(os.environ, COOPSAT_JAX_CACHE=str(Path(workdir) / "warm-cache"))
    imports = [timed([sys.executable, "-c", FLOOR_IMPORTS], env, workdir) for _ in range(repeats)]
    done = subprocess.run([sys.executable, "-c", IN_PROCESS, workdir, str(repeats)], env=env, cwd=workdir,
                          capture_output=True, text=True, check=True)
    return [("floor: imports (jax.numpy, xarray, h5netcdf, mpl)", imports),
            ("floor: run_scenario again in one process", [float(t) for t in done.stdout.split()])]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5, help="timed runs of each warm command (default 5)")
    parser.add_argument("--cold-repeats", type=int, default=3, help="timed cold runs (default 3)")
    parser.add_argument("--module", action="store_true",
                        help="time python -m coopsat.cli (another checkout through PYTHONPATH, say), not the script")
    args = parser.parse_args()
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"coopsat latency, {os.cpu_count()} cores, load average {load:.2f} at start")
    print(f"{'command':<50} {'median s':>9} {'range s':>13} {'target s':>9}")
    with tempfile.TemporaryDirectory(prefix="coopsat-latency-") as workdir:
        for label, argv, target, cold in COMMANDS:
            times = measure(argv, args.cold_repeats if cold else args.repeats, cold, workdir, args.module)
            verdict = "met" if statistics.median(times) <= target else "NOT met"
            print(f"{label:<50} {statistics.median(times):>9.2f} {min(times):>6.2f}–{max(times):<6.2f} {target:>9.1f}  {verdict}",
                  flush=True)
        print("lower bounds (no target: what the figures above cannot go below on this machine)")
        for label, times in floors(args.repeats, workdir):
            print(f"{label:<50} {statistics.median(times):>9.2f} {min(times):>6.2f}–{max(times):<6.2f}", flush=True)


if __name__ == "__main__":
    main()
