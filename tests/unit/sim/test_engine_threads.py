"""The engine under threads: runs at the same time equal the runs alone, and the cache of
compiled programs keeps its bound, its order and one set of programs per key."""

import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from coopsat.scenarios.load import load_scenario
from coopsat.sim import engine
from coopsat.sim.program_cache import ProgramCache
from coopsat.sim.system import stack_systems
from coopsat.workflows.pipeline import prepare


@pytest.fixture
def fast_switching():
    """Threads switch every microsecond, so that they interleave inside the cache's methods."""
    before = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    yield
    sys.setswitchinterval(before)


def _built(w):
    return prepare(load_scenario("consensus-sync-a-stable", ["sim.t_final_s=2", f"spacecraft.1.omega_b_rad_s=[0.5, {w}, 0.0]"]))


def _together(calls):
    """Run the ``calls`` (no argument each) in threads released at the same instant."""
    start = threading.Barrier(len(calls))

    def run(call):
        start.wait()
        return call()

    with ThreadPoolExecutor(len(calls)) as pool:
        return list(pool.map(run, calls))


def _assert_same(got, want):
    assert got.samples.keys() == want.samples.keys()
    np.testing.assert_array_equal(got.t_s, want.t_s)
    for k in want.samples:
        np.testing.assert_array_equal(got.samples[k], want.samples[k], err_msg=k)


def test_two_threads_running_at_once_get_what_each_gets_alone():
    """Same structure, different initial states: one cache key, compiled by both threads at
    once (the cache is cleared first), and each result bit for bit the run's alone."""
    built = [_built(w) for w in (5.0, 3.0)]
    alone = [engine.simulate(b.system, b.n_records, b.record_interval_s) for b in built]
    assert not np.array_equal(alone[0].samples["q"], alone[1].samples["q"])
    engine._COMPILED.clear()
    together = _together([lambda b=b: engine.simulate(b.system, b.n_records, b.record_interval_s) for b in built])
    for got, want in zip(together, alone):
        _assert_same(got, want)
    assert len(engine._COMPILED) == 1  # the duplicate compile of the race is dropped


def test_a_batch_and_a_single_run_at_once_get_what_each_gets_alone():
    built = [_built(w) for w in (5.0, 4.0, 3.0)]
    batch = stack_systems([b.system for b in built[:2]])
    b0, b2 = built[0], built[2]
    alone = [engine.simulate(batch, b0.n_records, b0.record_interval_s, batched=True, every_core=False),
             engine.simulate(b2.system, b2.n_records, b2.record_interval_s)]
    together = _together([
        lambda: engine.simulate(batch, b0.n_records, b0.record_interval_s, batched=True, every_core=False),
        lambda: engine.simulate(b2.system, b2.n_records, b2.record_interval_s),
    ])
    for got, want in zip(together, alone):
        _assert_same(got, want)


def test_cache_keeps_its_bound_and_order_under_contention(fast_switching):
    cache = ProgramCache(max_size=16)
    errors, sizes = [], []

    def work(seed):
        rng = np.random.default_rng(seed)
        try:
            for _ in range(2000):
                key = int(rng.integers(40))
                op = rng.integers(3)
                if op == 0:
                    cache.put(key, ("programs", key))
                elif op == 1:
                    value = cache.get(key)
                    assert value is None or value == ("programs", key)
                else:
                    assert cache.get_or_make(key, lambda: ("programs", key)) == ("programs", key)
                sizes.append(len(cache))
        except Exception as err:  # noqa: BLE001 - reported below
            errors.append(err)

    _together([lambda s=s: work(s) for s in range(8)])
    assert not errors
    assert max(sizes) <= 16 and len(cache) == 16
    keys = cache.keys()
    assert len(set(keys)) == len(keys) == 16
    assert all(cache[k] == ("programs", k) for k in keys)


def test_threads_missing_one_key_at_once_all_get_the_programs_kept(fast_switching):
    cache = ProgramCache(max_size=4)
    made = []

    def make():
        time.sleep(0.02)  # a compile: long enough for every thread to miss
        programs = object()
        made.append(programs)
        return programs

    got = _together([lambda: cache.get_or_make("key", make) for _ in range(8)])
    assert len(made) >= 1
    assert all(g is got[0] for g in got) and cache["key"] is got[0] and got[0] in made
    assert len(cache) == 1


def test_cache_drops_the_least_recently_used():
    cache = ProgramCache(max_size=2)
    cache.put("a", 1)
    cache.put("b", 2)
    assert cache.get("a") == 1  # a is now the most recently used
    cache.put("c", 3)
    assert cache.keys() == ["a", "c"] and "b" not in cache
    assert cache.put("a", 10) == 1  # the programs already stored are kept
    assert cache.keys() == ["c", "a"] and cache.get("b", "missing") == "missing"
    with pytest.raises(ValueError):
        ProgramCache(max_size=0)
