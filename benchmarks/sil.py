"""Software-in-the-loop speed: control periods per second in lockstep on loopback (docs/sil.md).

    python benchmarks/sil.py [--sizes 5 20] [--t-final 10]

For each formation size N (law (3) on a ring, consensus-sync-a-stable's rates: a 0.01 s control
period) it prints the SIL rate, and where a period's time goes:

* simulator: the simulator's own work per period (its jitted period functions, stacking,
  encoding), measured with the flight software called in-process instead of over ZeroMQ;
* flight software: one spacecraft's work per period (decode, its two jitted functions,
  encode), times N: what the processes compute between them;
* transport and scheduling: the rest of the lockstep period (ZeroMQ, waking N + 1 processes
  twice a period on the machine's cores).

and the CPU time a period costs in the real run (``getrusage``: the simulator, its ZeroMQ
thread included, and the flight-software processes together; the difference between a run
and a short one, so that starting the processes does not count): on C cores a period can take
no less than that CPU time / C.
"""

import argparse
import os
import pickle
import resource
import time

from coopsat.cli import configure_process


def _scenario(n, t_final_s):
    """consensus-sync-a-stable with n spacecraft on a ring (its first five states repeated)."""
    import coopsat

    base = coopsat.Scenario.load("consensus-sync-a-stable")
    five = [{k: v for k, v in c.model_dump(mode="json", exclude_defaults=True).items() if k != "name"}
            for c in base.model.spacecraft]
    fleet = [{**five[k % 5], "name": f"sat{k + 1}"} for k in range(n)]
    return (base.set("spacecraft", fleet).set("network", {"kind": "ring"}).set("published", [])
            .set("sim.t_final_s", t_final_s))


class _InProcess:
    """The flight software called in this process (no ZeroMQ): what the simulator costs alone."""

    def __init__(self):
        self.killed, self.paused, self.fsw_s = set(), set(), 0.0

    def handshake(self, setups, timeout_s):
        from coopsat.workflows.sil import protocol
        from coopsat.workflows.sil.fsw import OneSpacecraft

        self.hosts = {}
        for name, s in setups.items():
            s = protocol.decode(protocol.encode(s))
            self.hosts[name] = OneSpacecraft(pickle.loads(s["part"]), s["index"], len(s["names"]), s["links"]["dst"],
                                             s["links"]["mine"])
            self.hosts[name].warm_up(s["reads"])

    def exchange(self, messages, answer, k, due=None):
        from coopsat.workflows.sil import protocol

        t0, replies = time.perf_counter(), {}
        for name, m in messages.items():
            m, host = protocol.decode(protocol.encode(m)), self.hosts[name]
            if m["type"] == protocol.SENSE:
                r = {"type": answer, "k": k, "msg": protocol.lists(host.outbox(m["y"]))}
            else:
                cmd, rec = host.step(m["t"], m["msg"], m["weight"], m["key"])
                r = {"type": answer, "k": k, "commands": protocol.lists(cmd), "record": protocol.lists(rec)}
            replies[name] = protocol.decode(protocol.encode(r))
        self.fsw_s += time.perf_counter() - t0
        return replies


def _in_process(scenario):
    """(simulator s, flight software s, periods) of the loop with the flight software here."""
    from coopsat.sim.engine import with_native_decided
    from coopsat.workflows.pipeline import prepare
    from coopsat.workflows.sil.loop import run_loop

    built = prepare(scenario.model)
    system = with_native_decided(built.system, built.n_records)
    fleet = _InProcess()
    out, _, _ = run_loop(built, system, fleet, built.system.controller, built.n_records, handshake_s=60)
    periods = built.n_records * system.structure.periods_per_record
    return out.run_s - fleet.fsw_s, fleet.fsw_s, periods


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[5, 20])
    parser.add_argument("--t-final", type=float, default=10.0, help="simulated seconds per timed run (default 10)")
    args = parser.parse_args()
    configure_process()
    import jax

    jax.config.update("jax_cpu_enable_async_dispatch", False)  # as coopsat sil does
    from coopsat.workflows.sil.run import sil

    cores = os.cpu_count()
    print(f"SIL, lockstep, loopback IPC; {cores} CPU cores; load average {os.getloadavg()[0]:.1f}")
    for n in args.sizes:
        scenario = _scenario(n, args.t_final)
        short_s = 0.5
        sil(scenario.set("sim.t_final_s", short_s))  # compile the simulator's functions and fill the caches
        cpu_short = _cpu(lambda: sil(scenario.set("sim.t_final_s", short_s)))[1]
        result, cpu_long = _cpu(lambda: sil(scenario))
        periods = round(args.t_final / result.scenario.model.controller.period_s)
        per_period = [(a - b) / (periods - round(short_s / result.scenario.model.controller.period_s)) * 1e6
                      for a, b in zip(cpu_long, cpu_short)]
        sim_s, fsw_s, p_in = _in_process(scenario)
        per = result.run_s / periods * 1e6
        sim_us, fsw_us = sim_s / p_in * 1e6, fsw_s / p_in * 1e6
        print(f"N = {n:3d}: {periods / result.run_s:7.0f} periods/s ({per:6.0f} us a period: simulator {sim_us:5.0f} us, "
              f"flight software {fsw_us / n:4.0f} us x {n} = {fsw_us:5.0f} us, transport and scheduling "
              f"{per - sim_us - fsw_us:6.0f} us)")
        print(f"        CPU a period in the run: simulator {per_period[0]:5.0f} us, flight software {per_period[1] / n:4.0f} "
              f"us x {n} = {per_period[1]:5.0f} us; on {cores} cores a period takes at least "
              f"{sum(per_period) / cores:5.0f} us (at most {cores / sum(per_period) * 1e6:5.0f} periods/s)")


def _cpu(call):
    """``call()``'s value and the CPU seconds (user + system) it cost this process and the
    child processes it waited for."""
    def now():
        me, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
        return me.ru_utime + me.ru_stime, kids.ru_utime + kids.ru_stime

    before = now()
    value = call()
    return value, tuple(a - b for a, b in zip(now(), before))


if __name__ == "__main__":
    main()
