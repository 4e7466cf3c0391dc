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
    assert all(float(r[6]) > 0.0 for r in rows)  # M spacecraft-steps/s
    if from_source:
        assert 0.0 < float(rows[1][-1]) < 2.0  # fraction of the ceiling measured beside it
    # The orbit rows: J2, then every perturbation quoted as a multiple of the J2 tick.
    orbit = [line.split() for line in proc.stdout.splitlines() if line.startswith("orbit ")]
    assert [r[1] for r in orbit] == ["J2", "all"]
    assert float(orbit[1][-4].rstrip("×")) > 0.0
