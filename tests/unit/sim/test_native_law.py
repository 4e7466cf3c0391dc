"""The native consensus-law kernel (coopsat.sim.native) against the law's JAX code, on every
form of inbox it reads (padded tables with consecutive and scattered transmitters, edge lists,
a delay line), laws (3) and (4), both hemispheres; and the properties the engine relies on:
the kernel is compiled in only where it applies, a run in a batch equals the run alone,
derivatives are the JAX law's."""

from dataclasses import replace

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from coopsat.sim.synthetic import bench_system
from coopsat.control.consensus import ConsensusLaw
from coopsat.network.delay import DelayedNetwork
from coopsat.network.delivery import IdealNetwork
from coopsat.network.topology import links_from_adjacency, ring_adjacency, star_adjacency
from coopsat.sim.engine import run_samples
from coopsat.sim.native import LAW_MIN_SPACECRAFT
from coopsat.sim.native.consensus import TARGET
from coopsat.sim.native.laws import consensus_step
from coopsat.sim.system import as_arrays

N = 300  # above LAW_MIN_SPACECRAFT, and not a multiple of the kernel's block of 128


def random_adjacency(n, degree, seed):
    """Each spacecraft hears ``degree`` others drawn at random, weights in [0.5, 1.5]."""
    rng = np.random.default_rng(seed)
    a = np.zeros((n, n))
    for i in range(n):
        a[i, rng.choice(np.delete(np.arange(n), i), degree, replace=False)] = rng.uniform(0.5, 1.5, degree)
    return a


def law(track=False, short_way=False):
    gains = as_arrays((0.7, 1.9, 0.4, 1.1, np.array([0.6, 0.0, 0.8, 0.0]), np.array([0.01, -0.02, 0.03])))
    return ConsensusLaw(*gains, track=track, short_way=short_way)


def measurements(n, seed):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(4, n))
    return {"q": jnp.asarray(q / np.linalg.norm(q, axis=0)), "omega": jnp.asarray(rng.normal(scale=0.1, size=(3, n)))}


def ideal(a, layout="auto"):
    links = links_from_adjacency(a, layout)
    return IdealNetwork(*as_arrays((links.src, links.dst, links.weight[None], np.zeros(1, np.int64))))


def delayed(a, lossy=False, hold=False):
    """Every link delayed by 1 to 4 periods (per link), optionally lossy."""
    links = links_from_adjacency(a)
    rng = np.random.default_rng(5)
    weight = links.weight[None]
    fixed = np.where(weight > 0, rng.integers(1, 5, weight.shape), 0)
    return DelayedNetwork(
        *as_arrays((links.src, links.dst, weight, (weight > 0).astype(np.int64), fixed,
                    np.full_like(weight, 0.3 if lossy else 0.0), np.zeros(1, np.int64), 0, 0, 1, 1)),
        period_ticks=1, buffer_periods=5, random=False, lossy=lossy, hold=hold,
    )


def commands(controller, network, y, tick=7):
    """(native u, JAX u) after ``tick`` periods of the network (a delay line filled)."""
    @jax.jit
    def both(y):
        state = network.init({"q": y["q"], "omega": y["omega"]})
        for k in range(tick):  # earlier outboxes: the same attitudes, slowly rotating
            earlier = {"q": y["q"] * (1 + 0.01 * k), "omega": y["omega"]}
            _, state, _ = network.deliver(k, earlier, state, jax.random.PRNGKey(k))
        inbox, _, _ = network.deliver(tick, {"q": y["q"], "omega": y["omega"]}, state, jax.random.PRNGKey(tick))
        t = 3.7
        native = consensus_step(controller, t, y, inbox, (), None)[0]["torque_b"]
        return native, controller.step(t, y, inbox, (), None)[0]["torque_b"]

    return [np.asarray(u) for u in both(y)]


@pytest.mark.parametrize("network", [
    "ring",  # padded table, consecutive transmitters (read in place) but at the wrap-around
    "random",  # padded table, scattered transmitters (copied first)
    "star",  # edge list (a hub hears everyone)
    "delayed",  # a delay line: padded table into the ring buffer
])
@pytest.mark.parametrize("track,short_way", [(False, False), (True, False), (True, True)])
def test_native_law_matches_the_jax_law(network, track, short_way):
    a = {"ring": ring_adjacency(N), "random": random_adjacency(N, 4, 1), "star": star_adjacency(N),
         "delayed": random_adjacency(N, 3, 2)}[network]
    net = delayed(a) if network == "delayed" else ideal(a)
    native, xla = commands(law(track, short_way), net, measurements(N, 3))
    scale = np.max(np.abs(xla))
    assert scale > 0.1
    # Same products and sums in the same order; XLA may contract some into FMAs.
    np.testing.assert_allclose(native, xla, rtol=0, atol=1e-14 * scale)


def test_short_way_flips_the_error_of_far_neighbours():
    # The flags reach the kernel: with half the attitudes on the far hemisphere, the two
    # laws differ (by far more than rounding), each matching its JAX twin.
    y = measurements(N, 4)
    y["q"] = y["q"].at[:, ::2].multiply(-1.0)
    net = ideal(ring_adjacency(N))
    near, near_xla = commands(law(short_way=True), net, y)
    raw, raw_xla = commands(law(short_way=False), net, y)
    np.testing.assert_allclose(near, near_xla, rtol=0, atol=1e-13)
    np.testing.assert_allclose(raw, raw_xla, rtol=0, atol=1e-13)
    assert np.max(np.abs(near - raw)) > 0.1


def test_held_lost_messages_keep_the_jax_law():
    # A held message is no longer a gather of the delay line: the inbox says so (no source)
    # and the kernel does not apply; a dropped one keeps the gather (weight 0).
    y = measurements(N, 6)
    hold = delayed(ring_adjacency(N), lossy=True, hold=True)
    drop = delayed(ring_adjacency(N), lossy=True, hold=False)
    outbox = {"q": y["q"], "omega": y["omega"]}
    assert hold.deliver(3, outbox, hold.init(outbox), jax.random.PRNGKey(0))[0].source is None
    assert drop.deliver(3, outbox, drop.init(outbox), jax.random.PRNGKey(0))[0].source is not None
    native, xla = commands(law(), drop, y)
    np.testing.assert_allclose(native, xla, rtol=0, atol=1e-13)


def hlo(system):
    return jax.jit(run_samples, static_argnums=1).lower(system, 1).as_text()


def test_kernel_is_compiled_in_from_its_size_and_can_be_turned_off():
    big = bench_system(LAW_MIN_SPACECRAFT, "consensus-sync", record_ticks=10)
    assert TARGET in hlo(big)
    assert TARGET not in hlo(replace(big, structure=replace(big.structure, native=False)))
    assert TARGET not in hlo(bench_system(LAW_MIN_SPACECRAFT - 1, "consensus-sync", record_ticks=10))


def test_runs_under_vmap_equal_each_run_alone():
    # vmap hands the kernel every run at once (leading dimension); each run's command must
    # be exactly what it is alone, whatever its neighbours in the batch.
    controller, net = law(track=True), ideal(random_adjacency(N, 3, 7))
    ys = [measurements(N, 10 + k) for k in range(3)]

    def command(y):
        inbox = net.deliver(0, y, net.init(y), None)[0]
        return consensus_step(controller, 1.0, y, inbox, (), None)[0]["torque_b"]

    batch = jax.jit(jax.vmap(command))(jax.tree_util.tree_map(lambda *a: jnp.stack(a), *ys))
    for k, y in enumerate(ys):
        np.testing.assert_array_equal(np.asarray(batch[k]), np.asarray(jax.jit(command)(y)))


def test_gradient_is_the_jax_laws():
    controller, net = law(track=True), ideal(ring_adjacency(N))
    y = measurements(N, 8)
    inbox = net.deliver(0, y, net.init(y), None)[0]
    weights = jnp.asarray(np.random.default_rng(9).normal(size=(3, N)))

    def loss(alpha, k_p, q, step):
        c = replace(controller, alpha=alpha, k_p=k_p)
        yy = {"q": q, "omega": y["omega"]}
        box = net.deliver(0, yy, net.init(yy), None)[0]
        return jnp.sum(weights * step(c, 2.0, yy, box, (), None)[0]["torque_b"])

    args = (controller.alpha, controller.k_p, y["q"])
    native = jax.grad(loss, argnums=(0, 1, 2))(*args, consensus_step)
    xla = jax.grad(loss, argnums=(0, 1, 2))(*args, lambda c, *a: c.step(*a))
    assert inbox.source is not None
    for a, b in zip(native, xla):
        assert np.max(np.abs(np.asarray(b))) > 0
        np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("layout", ["padded", "edges"])
def test_a_column_outside_the_table_gives_nan_as_jnp_take(layout):
    # A corrupt index must not read stray memory: the kernel fills NaN as jnp.take does, so
    # the receiver's command is NaN (the engine then stops on the non-finite state).
    controller, net = law(), ideal(ring_adjacency(N), layout)
    y = measurements(N, 11)

    @jax.jit
    def both(y):
        inbox = net.deliver(0, y, net.init(y), None)[0]
        table, index = inbox.source
        index = index.at[(0, 5) if index.ndim == 2 else 5].set(10 * N)
        msg = {k: jnp.take(v, index, axis=-1) for k, v in table.items()}
        box = inbox._replace(msg=msg, source=(table, index))
        native = consensus_step(controller, 0.0, y, box, (), None)[0]["torque_b"]
        return native, controller.step(0.0, y, box, (), None)[0]["torque_b"]

    native, xla = (np.asarray(u) for u in both(y))
    assert np.isnan(xla).any()
    np.testing.assert_array_equal(np.isnan(native), np.isnan(xla))
    np.testing.assert_allclose(native[~np.isnan(xla)], xla[~np.isnan(xla)], rtol=0, atol=1e-13)
