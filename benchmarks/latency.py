"""What a new user waits for: wall time of whole ``coopsat`` commands, warm and cold.

Each command runs as its own process, the way a user types it, and is timed from start to exit
(Python's start-up and every import included). Printed per row: the median and the range over
the repeats, and the target.

* warm: caches as a second run finds them (JAX's persistent compilation cache, the design
  results and the native kernels' verdict kept beside it: one untimed run fills them first);
* cold: each repeat with an empty cache folder (``COOPSAT_JAX_CACHE`` pointed at a new one),
  as the very first run after installing.

The import floor comes first: the imports alone that any one-shot run pays (JAX, xarray with
h5netcdf); a warm run's target is that floor plus 1.0 s, measured in the same sitting. A run
repeated in a process that has already run it (imports and compilation paid: what a resident
process would still pay per run) follows the table, and a run with ``--figures`` (no target:
PNG figures are drawn on request).

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

WARM_OVER_FLOOR_S = 1.0
"""A warm ``coopsat run``'s target: the import floor plus this, s."""

COMMANDS = [
    # (label, argv after "coopsat", target s (None: the floor + WARM_OVER_FLOOR_S; 0: no target), cold)
    ("coopsat list", ["list"], 0.3, False),
    ("coopsat validate consensus-sync-a-stable", ["validate", "consensus-sync-a-stable"], 1.0, False),
    ("coopsat run consensus-sync-a", ["run", "consensus-sync-a", "--out", "{out}"], None, False),
    ("coopsat run consensus-sync-a, cold caches", ["run", "consensus-sync-a", "--out", "{out}"], 8.0, True),
    ("coopsat run consensus-sync-a --figures", ["run", "consensus-sync-a", "--out", "{out}", "--figures"], 0, False),
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


FLOOR_IMPORTS = "import jax.numpy, xarray, h5netcdf"
"""What any one-shot ``coopsat run`` must import: the closed loop (JAX) and the record (xarray,
h5netcdf)."""

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


def import_floor(repeats, workdir):
    """Wall times of the imports alone (:data:`FLOOR_IMPORTS`), s."""
    return [timed([sys.executable, "-c", FLOOR_IMPORTS], dict(os.environ), workdir) for _ in range(repeats)]


def in_process(repeats, workdir):
    """Wall times of a run in a process that has already run it once, s."""
    env = dict(os.environ, COOPSAT_JAX_CACHE=str(Path(workdir) / "warm-cache"))
    done = subprocess.run([sys.executable, "-c", IN_PROCESS, workdir, str(repeats)], env=env, cwd=workdir,
                          capture_output=True, text=True, check=True)
    return [float(t) for t in done.stdout.split()]


def row(label, times, target=0):
    """One printed line: median, range and (unless ``target`` is 0) the target and its verdict."""
    median = statistics.median(times)
    line = f"{label:<50} {median:>9.2f} {min(times):>6.2f}–{max(times):<6.2f}"
    if target:
        line += f" {target:>9.2f}  {'met' if median <= target else 'NOT met'}"
    return line


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
        floor = import_floor(args.repeats, workdir)
        print(row("import floor (jax.numpy, xarray, h5netcdf)", floor), flush=True)
        for label, argv, target, cold in COMMANDS:
            times = measure(argv, args.cold_repeats if cold else args.repeats, cold, workdir, args.module)
            target = statistics.median(floor) + WARM_OVER_FLOOR_S if target is None else target
            print(row(label, times, target), flush=True)
        print(row("run_scenario again in one process (no target)", in_process(args.repeats, workdir)), flush=True)


if __name__ == "__main__":
    main()
