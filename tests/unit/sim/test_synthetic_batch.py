"""The benchmark's batch made once (sim.synthetic.bench_batch) is the batch of its runs made one
by one and stacked, leaf for leaf, in every case the benchmark runs."""

import jax
import numpy as np
import pytest

from coopsat.sim.synthetic import bench_batch, bench_system
from coopsat.sim.system import stack_systems


@pytest.mark.parametrize("case", [
    dict(controller="none"),
    dict(controller="consensus-sync"),
    dict(controller="consensus-sync", delayed=True),
    dict(controller="consensus-sync", pwm=True, native=False),
])
def test_bench_batch_is_its_runs_stacked(case):
    n, batch = 6, 4
    made = bench_batch(n, batch=batch, record_ticks=10, **case)
    stacked = stack_systems([bench_system(n, seed=k, record_ticks=10, **case) for k in range(batch)])
    assert jax.tree_util.tree_structure(made) == jax.tree_util.tree_structure(stacked)
    for a, b in zip(jax.tree_util.tree_leaves(made), jax.tree_util.tree_leaves(stacked)):
        assert a.dtype == b.dtype and a.shape == b.shape
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))  # NaN masses equal too
    # The runs differ where the seed draws: a batch of one repeated draw would pass the rest.
    q = np.asarray(made.x0.q_bi)
    assert not np.array_equal(q[0], q[1])
