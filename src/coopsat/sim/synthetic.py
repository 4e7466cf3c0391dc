"""A synthetic formation built without a scenario: the engine benchmark's cases
(``coopsat bench``) and the native kernels' probe (:mod:`coopsat.sim.native.capability`).

Random attitudes and rates of ``n`` rigid bodies with principal inertias (no orbit), free or
under law (3) on an undirected ring with an ideal torque actuator, over an ideal network or
one that delays every message.
"""

import numpy as np


DELAY_PERIODS = 200
"""Delay of every link in the delayed-network case: 2 s at the benchmark's 0.01 s period."""


def _network(links, delayed):
    """Ideal network, or every link delayed by :data:`DELAY_PERIODS` (a ring buffer of 201
    outboxes)."""
    from coopsat.network.delay import DelayedNetwork
    from coopsat.network.delivery import IdealNetwork
    from coopsat.sim.system import as_arrays

    weight, switch = links.weight[None], np.zeros(1, np.int64)
    if not delayed:
        return IdealNetwork(*as_arrays((links.src, links.dst, weight, switch)))
    fixed = np.where(weight > 0, DELAY_PERIODS, 0)
    return DelayedNetwork(
        *as_arrays((links.src, links.dst, weight, (weight > 0).astype(np.int64), fixed, np.zeros_like(weight), switch,
                    0, 0, 1, 1)),
        period_ticks=1, buffer_periods=DELAY_PERIODS + 1, random=False, lossy=False, hold=True,
    )


def random_formation(n, seed):
    """The benchmark's random spacecraft: ``(q_bi, omega_b, principal)``, shapes (n, 4), (n, 3),
    (n, 3) — unit quaternions, rates (rad/s, σ = 0.1) and principal inertias (kg·m², uniform in
    [0.5, 1.5]; body axes = principal axes, the loop's diagonal path), drawn from ``seed``."""
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    principal = rng.uniform(0.5, 1.5, size=(n, 3))
    return q, rng.normal(scale=0.1, size=(n, 3)), principal


def bench_system(n, controller, dt_s=0.01, record_ticks=1000, seed=0, delayed=False, native=True, pwm=False):
    """A random formation of ``n`` spacecraft for the benchmark (no orbit): free, or law (3)
    on an undirected ring with an ideal torque actuator, over an ideal network or one that
    delays every message by 2 s. ``native``: whether native CPU kernels may run the plant and the
    law (:mod:`coopsat.sim.native`). ``pwm``: PWM thrusters instead of the ideal actuator (a
    pulse switches inside the tick: the piecewise tick)."""
    import jax

    from coopsat.actuators.ideal import IdealTorque
    from coopsat.actuators.pwm import PwmThrusters
    from coopsat.control.consensus import ConsensusLaw
    from coopsat.control.free import NoControl
    from coopsat.dynamics.plant import PlantParams, PlantState
    from coopsat.network import edge_list
    from coopsat.network.topology import links_from_edges
    from coopsat.sim.system import Structure, System, as_arrays

    q, omega, principal = random_formation(n, seed)
    zeros = np.zeros((n, 3))
    # An edge list from the start: a ring of a million spacecraft is 2e6 links, not 1e12 entries.
    ring = edge_list.ring(n) if controller != "none" else edge_list.empty(n)
    links = links_from_edges(ring.src, ring.dst, ring.weight, n)
    structure = Structure(
        n_spacecraft=n, gravity="none", attitude="rigid-body", ticks_per_period=1, periods_per_record=record_ticks,
        substeps=1, native=native,
    )
    if controller == "none":
        law = NoControl()
    else:
        law = ConsensusLaw(*as_arrays((1.0, 2.0, 0.0, 0.0, [1.0, 0, 0, 0], np.zeros(3))), track=False, short_way=False)
    return System(
        structure,
        *as_arrays((
            dt_s, jax.random.PRNGKey(seed),
            PlantState(q, omega, zeros, zeros, zeros, zeros),
            PlantParams(principal, 1.0 / principal, 0.0, 0.0, 1.0, np.full(n, np.nan), 0),
        )),
        controller=law,
        network=_network(links, delayed),
        sensors=(),
        actuators=(PwmThrusters(*as_arrays((0.05, 0.0))) if pwm else IdealTorque(*as_arrays((0.05,))),),
        disturbances=(),
    )


def bench_batch(n, controller, batch, **options):
    """``batch`` formations of :func:`bench_system` (seeds ``0 … batch−1``) as one batched
    system: the same leaves as ``stack_systems([bench_system(n, controller, seed=k, **options)
    for k in range(batch)])``, but the system is made once and only what the seed draws (the
    random key, the attitudes, rates and inertias) is made per run, so a batch of 1000 builds
    in a fraction of a second."""
    import dataclasses

    import jax

    one = jax.tree_util.tree_map(np.asarray, bench_system(n, controller, seed=0, **options))
    q, omega, principal = (np.stack(d) for d in zip(*(random_formation(n, k) for k in range(batch))))
    host = jax.tree_util.tree_map(lambda leaf: np.broadcast_to(leaf, (batch, *np.shape(leaf))), one)
    host = dataclasses.replace(
        host, key=np.asarray(jax.vmap(jax.random.PRNGKey)(np.arange(batch))),
        x0=host.x0._replace(q_bi=q, omega_b=omega),
        plant=host.plant._replace(inertia_kgm2=principal, inertia_inv=1.0 / principal),
    )
    return jax.tree_util.tree_map(lambda leaf: jax.device_put(np.ascontiguousarray(leaf)), host)


def probe_systems():
    """The native kernels' probe (:mod:`coopsat.sim.native.capability`): per target, the same
    small run with the kernels and without, ``(native system, XLA system, n_records,
    record_interval_s)``. Two ticks each, so that a result goes through the kernels twice."""
    from coopsat.sim.native import LAW_MIN_SPACECRAFT
    from coopsat.sim.native.pool import PARALLEL_MIN

    cases = {
        "rigid-body tick and consensus law": dict(n=LAW_MIN_SPACECRAFT, controller="consensus"),
        "pulsed rigid-body tick": dict(n=5, controller="consensus", pwm=True),
        "XLA's thread pool": dict(n=PARALLEL_MIN, controller="consensus"),
    }
    return {
        what: (bench_system(**case, record_ticks=2, native=True), bench_system(**case, record_ticks=2, native=False), 1, 0.02)
        for what, case in cases.items()
    }
