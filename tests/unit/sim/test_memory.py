"""A batch sized to the device's memory (sim.memory): a run's bytes against what a compiled call
really returns, the machine's memory, a batch larger than fits run in parts equal to the whole,
and one group per batch on an accelerator."""

import types

import jax
import numpy as np

from coopsat.scenarios.load import load_scenario
from coopsat.sim import batching, memory
from coopsat.sim.engine import simulate, state_bytes
from coopsat.sim.programs import _initial_carry, _run_chunk
from coopsat.sim.system import stack_systems
from coopsat.workflows.pipeline import prepare


def _runs(k=5):
    return [prepare(load_scenario("consensus-sync-b-stable", ["sim.t_final_s=2.0", f"seed={s}",
                                                              f"spacecraft.0.omega_b_rad_s=[0.0, 0.0, {0.01 * (s + 1)}]"]))
            for s in range(k)]


def _nbytes(tree):
    return sum(np.asarray(leaf).nbytes for leaf in jax.tree_util.tree_leaves(tree))


def test_a_runs_bytes_are_its_state_copies_and_one_chunk_of_record():
    built = _runs(1)[0]
    chunk = 4
    carry = _initial_carry(built.system)
    _, out = _run_chunk(built.system, carry, 0, chunk, chunk)  # run for real, measured as returned
    want = memory.WORKING_COPIES * state_bytes(built.system) + _nbytes(out)
    assert memory.run_bytes(built.system, chunk) == want
    assert _nbytes(carry) == state_bytes(built.system)


def test_the_cpu_reports_the_machines_memory():
    with open("/proc/meminfo") as f:
        total_kb = int(next(line for line in f if line.startswith("MemTotal:")).split()[1])
    got = memory.device_memory_bytes()
    assert abs(got - 1024 * total_kb) < 0.01 * got


def test_runs_per_call_is_the_share_of_memory_over_a_runs_bytes():
    builds = _runs(3)
    batch = stack_systems([b.system for b in builds])
    one = memory.run_bytes(builds[0].system, 8)
    assert memory.runs_per_call(batch, 8, memory_bytes=10 * one / memory.DEVICE_SHARE) == 10
    assert memory.runs_per_call(batch, 8, memory_bytes=one) == 1  # never none


def test_a_batch_larger_than_the_device_runs_in_parts_equal_to_the_whole(monkeypatch):
    builds = _runs(5)
    batch = stack_systems([b.system for b in builds])
    first = builds[0]
    whole = simulate(batch, first.n_records, first.record_interval_s, batched=True)
    calls = []
    real = memory.runs_per_call

    def two_fit(system, chunk, memory_bytes=None):
        calls.append(int(np.shape(system.key)[0]))
        return 2 if calls[-1] == 5 else real(system, chunk)

    monkeypatch.setattr("coopsat.sim.engine.runs_per_call", two_fit)
    parts = simulate(batch, first.n_records, first.record_interval_s, batched=True)
    assert calls[:1] == [5] and sorted(calls[1:]) == [1, 2, 2]  # parts of 2, 2 and 1 (padded to 2)
    assert parts.samples.keys() == whole.samples.keys()
    for key, want in whole.samples.items():
        assert parts.samples[key].shape == want.shape
        np.testing.assert_allclose(parts.samples[key], want, rtol=0, atol=1e-12 * max(np.max(np.abs(want)), 1e-3), err_msg=key)
    assert not np.array_equal(whole.samples["omega"][0], whole.samples["omega"][1])


def test_an_accelerator_integrates_a_batch_in_one_group(monkeypatch):
    assert batching._batch_groups(1000, 5) == (5, 200)  # the CPU: groups of at most 1024 spacecraft
    monkeypatch.setattr(jax, "devices", lambda *a: [types.SimpleNamespace(platform="gpu")])
    assert batching._batch_groups(1000, 5) == (1, 1000)
