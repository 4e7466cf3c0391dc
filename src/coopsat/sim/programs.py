"""The compiled programs of a run: its initial carry and a chunk of record intervals (one run,
or a batch group after group and device by device), which takes the final sample too.

A record is taken every ``periods_per_record`` control periods: the state and the parts'
records at the record instant, each actuator's mean output over the interval that starts
there, and the cumulative counters. A chunk is one ``lax.scan`` over record intervals; the
interval at the run's end gives the final sample, and those past it pass the carry through, so
runs of similar length share a compiled chunk. There is no Python loop over ticks, spacecraft
or edges.
"""

from dataclasses import replace
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from coopsat.geometry.quaternion import quat_normalize
from coopsat.sim.flight_software import as_flight_software
from coopsat.sim.layout import AXIS, _cm, _engine_view, _from_inner, _inner_plant, _to_inner
from coopsat.sim.period import PeriodState, _per_run, _period, _sense, account, command, truth


def interval_means(system, counters_before, counters_after, interval_s):
    """Each actuator's mean output over an interval of ``interval_s`` seconds, from its counter
    (e.g. mean torque from the signed angular impulse): ``{name: (3, n)}``."""
    return {
        a.mean_output[0]: (counters_after[a.mean_output[1]] - counters_before[a.mean_output[1]]) / interval_s
        for a in system.actuators
    }


def sample(true_state, counters, record, means):
    """One recorded sample: the true state (:func:`~coopsat.sim.period.truth`) and the counters
    at its instant, what the parts record there, and each actuator's mean output over the
    interval that follows it."""
    return {**true_state, **counters, **record, **means}


def period_means(system, increments):
    """Each actuator's mean output over one control period, from its counters' increments in
    that period (:func:`~coopsat.sim.period.account`): ``{name: (3, n)}``."""
    return {a.mean_output[0]: increments[a.mean_output[1]] / system.period_s for a in system.actuators}


def _block(system, state, batched, periods=None, last=None):
    """One record interval: the sample at its start, then its periods.

    The sample holds the state and the controller's record at its instant and the mean
    output of each actuator over the whole interval that follows (from the counters
    accumulated over it), so no period is left out of the record.

    ``periods``: how many periods run; by default the interval's ``periods_per_record`` (a
    static count, so the loop is differentiable); traced by :func:`_scan_records`. ``last``
    (traced bool, with ``periods`` 1 where it holds): the interval is the one after the run's
    end, whose sample is :func:`final_sample`: each actuator's mean output is that of the one
    period that follows, so the sample is the same as a separately compiled last sample.
    """
    def period(i, c):
        after, (pulses, record) = _period(system, c[0], batched)
        keep = jax.tree_util.tree_map(lambda new, old: jnp.where(i == 0, new, old), (pulses, record), c[1])
        return after, keep

    # One loop over all the interval's periods, carrying the first one's record: a first period
    # outside the loop would put a second copy of the whole period (laws, sensors, the plant's
    # ticks) into the program, and XLA's compile time grows with the program (docs/engine-notes.md,
    # "One period in the program"). Carried, not stacked per period: a record is (k, n).
    template = jax.eval_shape(lambda c: _period(system, c, batched)[1], state)
    zeros = jax.tree_util.tree_map(lambda a: jnp.zeros(a.shape, a.dtype), template)
    per_record = system.structure.periods_per_record
    after, (pulses, record) = jax.lax.fori_loop(0, per_record if periods is None else periods, period, (state, zeros))
    true_state = truth(system, state.x)
    if batched:
        true_state = jax.tree_util.tree_map(_from_inner, true_state)
    means = interval_means(system, state.counters, after.counters, system.period_s * per_record)
    if last is not None:
        increments = _per_run(account, system, pulses, in_axes=(0,)) if batched else account(system, pulses)
        means = jax.tree_util.tree_map(lambda one, whole: jnp.where(last, one, whole),
                                       period_means(system, increments), means)
    return after, sample(true_state, state.counters, record, means)


def _scan_records(system, carry, first_record, n_records, chunk, batched):
    """``chunk`` record intervals from ``first_record``: those before ``n_records`` whole; the
    one at ``n_records`` the final sample (:func:`final_sample`; one period runs, for its
    record and mean outputs); those past it pass the carry through (their rows are padding).

    The final sample is the chunk's, not a program of its own: its command is the first
    period's, already in the chunk, where a separate program compiled it (sensors, navigation,
    laws) a second time (docs/engine-notes.md, "The last sample in the chunk")."""
    per_record = system.structure.periods_per_record

    def body(c, k):
        index = first_record + k
        periods = jnp.where(index < n_records, per_record, jnp.where(index == n_records, 1, 0))
        return _block(system, c, batched, periods, index == n_records)

    return jax.lax.scan(body, carry, jnp.arange(chunk))


@partial(jax.jit, static_argnames=("chunk",))
def _run_chunk(system, carry, first_record, n_records, chunk):
    """``chunk`` record intervals of one run."""
    return _scan_records(_engine_view(system), carry, first_record, n_records, chunk, False)


def _run_group(system, carry, first_record, n_records, chunk):
    """``chunk`` record intervals of one group of runs (batch-first in and out)."""
    system = replace(system, plant=_inner_plant(system.plant))
    carry = carry._replace(x=jax.tree_util.tree_map(_to_inner, carry.x))
    carry, out = _scan_records(system, carry, first_record, n_records, chunk, True)
    return (carry._replace(x=jax.tree_util.tree_map(_from_inner, carry.x)),
            jax.tree_util.tree_map(lambda a: jnp.moveaxis(a, 1, 0), out))


@partial(jax.jit, static_argnames=("chunk", "groups", "devices"))
def _run_chunk_batched(system, carry, first_record, n_records, chunk, groups=1, devices=1):
    """``chunk`` record intervals of a batch (batch-first System, shared ``dt_s`` and tick).

    Takes and returns the carry batch-first, as the vmapped :func:`_initial_carry` makes it;
    samples ``(B, chunk, …)``. With ``groups`` > 1 (B a multiple of it), the runs are
    integrated group after group (``lax.map``), each group for the whole chunk; with
    ``devices`` > 1 (``groups`` a multiple of it) the groups are shared among the first
    ``devices`` devices (``jax.shard_map``).
    """
    if groups == 1:
        return _run_group(system, carry, first_record, n_records, chunk)
    dt_s, tick = system.dt_s, carry.tick
    split = lambda a: a.reshape(groups, a.shape[0] // groups, *a.shape[1:])  # noqa: E731
    merge = lambda a: a.reshape(a.shape[0] * a.shape[1], *a.shape[2:])  # noqa: E731
    # The tick is shared by every run (unbatched): it stays out of the groups.
    per_group = jax.tree_util.tree_map(split, (replace(system, dt_s=None), carry._replace(tick=None)))

    def one(group):
        g_system, g_carry = group
        return _run_group(replace(g_system, dt_s=dt_s), g_carry._replace(tick=tick), first_record, n_records, chunk)

    if devices > 1:
        # One share of the groups per device (on the CPU: per core, coopsat.core.runtime), each device
        # running its groups in turn.
        from jax.sharding import Mesh, PartitionSpec

        mesh = Mesh(np.array(jax.devices()[:devices]), ("device",))
        spec = PartitionSpec("device")
        carry, out = jax.shard_map(
            lambda pg: jax.lax.map(one, pg), mesh=mesh, in_specs=spec, out_specs=spec, check_vma=False
        )(per_group)
    else:
        carry, out = jax.lax.map(one, per_group)
    merged = jax.tree_util.tree_map(merge, carry._replace(tick=None))
    return merged._replace(tick=carry.tick[0]), jax.tree_util.tree_map(merge, out)


def final_sample(system, state, pulses, record):
    """The sample at the end of the run, from the :class:`~coopsat.sim.period.PeriodState` there
    and the ``pulses`` and ``record`` of the period that would follow: each actuator's mean
    output is that period's."""
    return sample(truth(system, state.x), state.counters, record, period_means(system, account(system, pulses)))


def _run_records(system, carry, n_records):
    """All ``n_records`` record intervals of one run, each of ``periods_per_record`` periods (a
    static count: differentiable end to end, :func:`~coopsat.sim.engine.run_samples`)."""
    return jax.lax.scan(lambda c, _: _block(_engine_view(system), c, False), carry, None, length=n_records)


@jax.jit
def _final_sample(system, carry):
    """The last sample on its own: the period that would follow commanded, then
    :func:`final_sample` (the compiled chunks take it in their loop, :func:`_scan_records`;
    :func:`_run_records` and the dataset's shapes take it from here)."""
    system = _engine_view(system)
    pulses, _, record = command(system, carry.x, carry.parts, carry.tick)
    return final_sample(system, carry, pulses, record)


def _initial_carry(system):
    """State of the plant and of every part at t = 0, and zeroed counters.

    The network's history before t = 0 is the first outbox (a constant initial function, as
    is usual for delay equations).
    """
    state, y0 = initial_parts(system)
    outbox0 = as_flight_software(system.controller, system.structure.n_spacecraft).outbox(y0, state.parts["controller"])
    return state._replace(parts={**state.parts, "network": system.network.init(outbox0)})


def initial_parts(system):
    """The :class:`~coopsat.sim.period.PeriodState` at t = 0 without the network's state
    (``parts["network"]`` is ``()``), and the first measurements ``y0`` (``{quantity: (k, n)}``),
    from which the flight software's first outbox fills the network's history. ``system`` in
    the interface layout."""
    system_cm = _engine_view(system)
    x0 = jax.tree_util.tree_map(_cm, system.x0)
    x0 = x0._replace(q_bi=quat_normalize(x0.q_bi, AXIS))
    n = system.structure.n_spacecraft
    true_state = truth(system_cm, x0)
    parts = {
        "controller": system.controller.init(n),
        "sensors": tuple(s.init(s.truth(true_state, x0, 0.0), n) for s in system.sensors),
        "held": tuple(s.truth(true_state, x0, 0.0) for s in system.sensors),
        "actuators": tuple(a.init(n) for a in system.actuators),
        "disturbances": tuple(d.init(n) for d in system.disturbances),
        "network": (),
    }
    y0, _ = _sense(system_cm, x0, parts, 0, jax.random.fold_in(system.key, 0), 0.0)
    zeros = jax.eval_shape(
        lambda: account(system_cm, tuple(a.plan(jnp.zeros_like(x0.omega_b), x0, s, system_cm.period_s, system.key, 0.0)[0]
                                         for a, s in zip(system_cm.actuators, parts["actuators"])))
    )
    counters = jax.tree_util.tree_map(lambda s: jnp.zeros(s.shape, s.dtype), zeros)
    return PeriodState(x0, parts, counters, jnp.zeros((), jnp.int64)), y0
