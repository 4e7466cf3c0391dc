"""Engine throughput: spacecraft-steps per second, compile time apart (same as `coopsat bench`).

Run: python benchmarks/engine_throughput.py [N ...]
Prints a table; asserts nothing (timings are measurements, not tests).
"""

import sys

from coopsat.cli import configure_process
from coopsat.workflows.bench import run_benchmarks

if __name__ == "__main__":
    configure_process()  # as `coopsat bench`: one CPU device per core, before JAX starts
    sizes = [int(a) for a in sys.argv[1:]] or [1, 5, 1000, 10000]
    run_benchmarks(sizes=sizes)
