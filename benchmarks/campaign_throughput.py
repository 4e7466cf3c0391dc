"""Campaign throughput: runs per minute of a scenario's campaign on 1 and 2 local workers.

    python benchmarks/campaign_throughput.py [--scenario consensus-sync-a-stable]
        [--runs 1 100] [--workers 1 2] [--batch-size 50] [--t-final 400]

Each (runs, workers) pair runs a fresh campaign (initial rates dispersed by 0.05 rad/s, so every
run differs) into a temporary folder and prints the wall time (cluster start included), runs
per minute, and the largest worker's peak memory. Numbers, not assertions: this machine is
noisy, compare ratios taken in one sitting.
"""

import argparse
import tempfile
from pathlib import Path

from coopsat.workflows.campaign.runner import run_campaign

TEMPLATE = """scenario = "{scenario}"
runs = {runs}
master_seed = 1
batch_size = {batch}
overrides = ["sim.t_final_s={t_final}"]

[[dispersions]]
field = "spacecraft.*.omega_b_rad_s"
distribution = "normal"
sigma = 0.05
"""


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenario", default="consensus-sync-a-stable")
    p.add_argument("--runs", type=int, nargs="+", default=[1, 100])
    p.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    p.add_argument("--batch-size", type=int, default=50)
    p.add_argument("--t-final", type=float, default=400.0)
    a = p.parse_args()
    print(f"{'runs':>6} {'workers':>7} {'wall s':>8} {'runs/min':>9} {'peak MB/worker':>15}")
    for runs in a.runs:
        for workers in a.workers:
            with tempfile.TemporaryDirectory() as tmp:
                f = Path(tmp) / "c.toml"
                f.write_text(TEMPLATE.format(scenario=a.scenario, runs=runs, batch=min(a.batch_size, runs), t_final=a.t_final))
                out = run_campaign(f, Path(tmp) / "out", workers=workers)
            rate = 60.0 * runs / out["wall_s"]
            print(f"{runs:>6} {workers:>7} {out['wall_s']:>8.1f} {rate:>9.1f} {out['worker_peak_rss_mb']:>15.0f}", flush=True)


if __name__ == "__main__":
    main()
