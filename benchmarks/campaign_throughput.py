"""Campaign throughput: runs per minute, and the share of the time spent simulating.

    python benchmarks/campaign_throughput.py [--scenario consensus-sync-a-stable]
        [--runs 1 100] [--workers 1 2] [--batch-size 50] [--t-final 400]
        [--api-runs 200] [--api-t-final 100]

Two parts, numbers only (this machine is noisy: compare ratios taken in one sitting):

1. ``coopsat.run_batch`` of ``--api-runs`` runs of the scenario, one seed each, in this process,
   compiled beforehand by a batch of the same size (so compile time is out): wall time from
   making the scenarios to the results, runs per minute, and the seconds building, simulating
   and the rest (datasets and metrics), with the simulation's share of the wall time.
2. For each (runs, workers) pair, a fresh campaign (initial rates dispersed by 0.05 rad/s, so
   every run differs) into a temporary folder: the wall time (cluster start and compilation
   included), runs per minute, the largest worker's peak memory, how its batches were built,
   and the share of the workers' batch time spent simulating (compilation apart).
"""

import argparse
import tempfile
import time
from pathlib import Path

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


def api_batch(scenario, runs, t_final):
    """One row of part 1: ``coopsat.run_batch`` of ``runs`` seeds, compiled beforehand."""
    import coopsat

    base = coopsat.Scenario.load(scenario).set("sim.t_final_s", t_final)
    coopsat.run_batch([base.with_seed(k) for k in range(runs)])  # compiles this shape
    t0 = time.perf_counter()
    batch = coopsat.run_batch([base.with_seed(k) for k in range(runs)])
    wall = time.perf_counter() - t0
    rest = wall - batch.build_s - batch.compile_s - batch.run_s
    print(f"run_batch {runs} runs of {scenario} ({t_final:g} s): {wall:.2f} s wall, {60 * runs / wall:.0f} runs/min; "
          f"build {batch.build_s:.3f} s, compile {batch.compile_s:.2f} s, simulate {batch.run_s:.2f} s "
          f"({batch.run_s / wall:.0%} of the wall time), the rest {rest:.2f} s", flush=True)
    print(f"  {batch.build_note}", flush=True)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenario", default="consensus-sync-a-stable")
    p.add_argument("--runs", type=int, nargs="*", default=[1, 100])
    p.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    p.add_argument("--batch-size", type=int, default=50)
    p.add_argument("--t-final", type=float, default=400.0)
    p.add_argument("--api-runs", type=int, default=200, help="runs of part 1 (0: skip it)")
    p.add_argument("--api-t-final", type=float, default=100.0)
    a = p.parse_args()
    if a.api_runs:
        api_batch(a.scenario, a.api_runs, a.api_t_final)
    if not a.runs:
        return
    from coopsat.workflows.campaign.runner import run_campaign

    print(f"{'runs':>6} {'workers':>7} {'wall s':>8} {'runs/min':>9} {'peak MB/worker':>15} {'simulating':>10}  batches")
    for runs in a.runs:
        for workers in a.workers:
            with tempfile.TemporaryDirectory() as tmp:
                f = Path(tmp) / "c.toml"
                f.write_text(TEMPLATE.format(scenario=a.scenario, runs=runs, batch=min(a.batch_size, runs), t_final=a.t_final))
                out = run_campaign(f, Path(tmp) / "out", workers=workers)
            rate = 60.0 * runs / out["wall_s"]
            s = out["worker_s"]
            share = s["simulate"] / max(s["total"] - s["compile"], 1e-12)
            print(f"{runs:>6} {workers:>7} {out['wall_s']:>8.1f} {rate:>9.1f} {out['worker_peak_rss_mb']:>15.0f} {share:>10.0%}  "
                  f"{'; '.join(out['build_notes'])}", flush=True)


if __name__ == "__main__":
    main()
