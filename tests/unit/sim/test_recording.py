"""Recorded quantities mean what the docs say, whatever the record interval."""

import numpy as np

from coopsat.workflows.pipeline import prepare, simulate_built
from coopsat.scenarios.load import load_scenario
from coopsat.sim import engine


def test_torque_is_the_mean_over_the_whole_record_interval():
    # Record every period, then every 50 periods: the coarse record's torque must equal the
    # mean of the fine record's over each interval (no period may be left out).
    base = ["sim.t_final_s=10.0"]
    fine, _ = simulate_built(prepare(load_scenario("consensus-sync-a-stable", [*base, "sim.record_interval_s=0.01"])))
    coarse, _ = simulate_built(prepare(load_scenario("consensus-sync-a-stable", [*base, "sim.record_interval_s=0.5"])))
    per_period = fine.torque.values[:-1].reshape(20, 50, 5, 3).mean(axis=1)
    np.testing.assert_allclose(coarse.torque.values[:-1], per_period, atol=1e-12)
    np.testing.assert_allclose(coarse.q.values, fine.q.values[::50], atol=1e-13)


def test_thruster_counters_are_consistent():
    ds, _ = simulate_built(prepare(load_scenario("consensus-sync-a", ["sim.t_final_s=20.0"])))
    firings, on_time = ds.thruster_firings.values[-1], ds.thruster_on_time.values[-1]
    assert np.all(firings <= 40) and np.all(firings == np.round(firings))
    # Every firing lasts at least the minimum pulse and at most the period.
    assert np.all(on_time >= 0.05 * firings - 1e-12) and np.all(on_time <= 0.5 * firings + 1e-12)
    # A ± pair never fires both ways in one period: together at most one firing per period.
    assert np.all(firings.reshape(5, 3, 2).sum(axis=-1) <= 40)


def test_runs_of_similar_length_share_one_compiled_program():
    """11, 14 and 16 records: one chunk size, so one key and the same compiled programs (looked
    up by key: another thread of the process may be compiling programs of its own)."""
    built = [prepare(load_scenario("rigid-body-free", [f"sim.t_final_s={t}"])) for t in (1.1, 1.4, 1.6)]
    # The key of the system as simulate runs it: outside the native kernels' jax range (or before
    # this process's verdict) it runs with structure.native False, another structure.
    (key,) = {engine._program_key(engine.with_native_decided(b.system, b.n_records), engine._chunk_size(b.n_records), None)
              for b in built}
    programs = []
    for b in built:
        engine.simulate(b.system, b.n_records, b.record_interval_s)
        programs.append(engine._COMPILED.get(key))
    assert programs[0] is not None and all(p is programs[0] for p in programs)
