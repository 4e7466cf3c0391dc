"""Kernels that split one large run over XLA's CPU thread pool (coopsat.sim.native.pool):
the split changes no bit (each spacecraft's arithmetic is its own), the run still matches
the XLA engine, and a batch of such runs (one device each) equals each run alone."""

from dataclasses import replace

import jax
import numpy as np

from coopsat.sim.synthetic import bench_system
from coopsat.network.delivery import IdealNetwork
from coopsat.network.topology import links_from_adjacency
from coopsat.sim.engine import run_samples
from coopsat.sim.engine import simulate_as_built as simulate  # the kernels as built, whatever COOPSAT_NATIVE says
from coopsat.sim.native.pool import PARALLEL_MIN
from coopsat.sim.system import as_arrays, stack_systems

N = PARALLEL_MIN + 904  # split over the pool, not a multiple of a block or of two
KEYS = ("q", "omega", "torque_command")


def random_graph_system(seed):
    """Law (3) over a random graph (each spacecraft hears 3 others): a padded table whose
    transmitters are scattered, so the law kernel's spans copy messages across spans."""
    system = bench_system(N, "consensus-sync", record_ticks=40, seed=seed)
    rng = np.random.default_rng(seed)
    a = np.zeros((N, N))
    for i in range(N):
        a[i, rng.choice(np.delete(np.arange(N), i), 3, replace=False)] = 1.0
    links = links_from_adjacency(a)
    assert links.src.ndim == 2
    network = IdealNetwork(*as_arrays((links.src, links.dst, links.weight[None], np.zeros(1, np.int64))))
    return replace(system, network=network)


def test_split_run_equals_the_unsplit_kernel_bit_for_bit():
    # Under vmap the kernels receive two runs at once and do each on one thread; alone, the
    # same run is split over the pool. Equality, not a tolerance.
    system = random_graph_system(1)
    alone = jax.jit(run_samples, static_argnums=1)(system, 2)
    pair = jax.jit(jax.vmap(lambda s: run_samples(s, 2)))(stack_systems([system, system]))
    for key in KEYS:
        np.testing.assert_array_equal(np.asarray(alone[key]), np.asarray(pair[key][1]), err_msg=key)
    assert np.max(np.abs(np.asarray(alone["q"])[-1] - np.asarray(alone["q"])[0])) > 1e-3  # it moved


def test_split_run_matches_the_xla_engine():
    system = random_graph_system(2)
    native = simulate(system, 2, 0.4).samples
    xla = simulate(replace(system, structure=replace(system.structure, native=False)), 2, 0.4).samples
    for key in KEYS:
        np.testing.assert_allclose(np.asarray(native[key]), np.asarray(xla[key]), rtol=0, atol=1e-13, err_msg=key)


def test_batch_of_large_runs_equals_each_run_alone():
    # Each run is its own group (over 1024 spacecraft), groups shared among the CPU devices,
    # each device's kernels scheduling on the same pool at once.
    runs = [bench_system(N, "consensus-sync", record_ticks=40, seed=k) for k in range(3)]
    batch = simulate(stack_systems(runs), 2, 0.4, batched=True).samples
    for k in (0, 2):
        alone = simulate(runs[k], 2, 0.4).samples
        for key in KEYS:
            np.testing.assert_array_equal(np.asarray(alone[key]), np.asarray(batch[key])[k], err_msg=key)


def test_two_large_runs_at_once_from_two_threads():
    # Both runs' kernels schedule on the one XLA pool at the same time; a handler never waits
    # for its tasks, so neither can starve the other (a deadlock would hang here), and each
    # result is what it is alone.
    import threading

    runs = [bench_system(N, "consensus-sync", record_ticks=40, seed=k) for k in range(2)]
    alone = [simulate(r, 2, 0.4).samples for r in runs]
    together = [None, None]

    def go(k):
        together[k] = simulate(runs[k], 2, 0.4).samples

    threads = [threading.Thread(target=go, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=120)
    for k in range(2):
        assert together[k] is not None, "a run did not finish"
        for key in KEYS:
            np.testing.assert_array_equal(np.asarray(together[k][key]), np.asarray(alone[k][key]), err_msg=key)
