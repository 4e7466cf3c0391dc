"""`coopsat bench` in its own process, as a user runs it: the cases build their arrays
themselves (float64 must be on before), and the ceiling column comes from the source
checkout's benchmarks/ceiling.py."""

import subprocess
import sys


def test_bench_runs_small_and_quotes_the_ceiling():
    proc = subprocess.run([sys.executable, "-m", "coopsat.cli", "bench", "--sizes", "5", "--steps", "200", "--batch", "0"],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "no ceiling column" not in proc.stdout
    rows = [line.split() for line in proc.stdout.splitlines() if line.startswith(("torque-free", "consensus "))]
    assert len(rows) == 2
    assert all(float(r[6]) > 0.0 for r in rows)  # M spacecraft-steps/s
    consensus = rows[1]
    assert 0.0 < float(consensus[-1]) < 2.0  # fraction of the ceiling measured beside it
