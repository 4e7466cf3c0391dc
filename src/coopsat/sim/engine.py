"""The closed-loop engine: integer ticks, zero-order hold, RK4, one compiled scan.

Per control period (``ticks_per_period`` base ticks), with the parts of a
:class:`~coopsat.sim.system.System` (docs/architecture.md §4):

    sense (sensors) → outbox → deliver (network) → control (flight software)
          → actuate (one pulse per actuator) → update disturbances
          → integrate every tick of the period with RK4 → account (actuator counters)

The engine names no law, actuator or sensor: it calls each part's methods, and asks the plant
which state quantities a run's wrench channels set moving. Pulsed actuators switch inside a
tick; each tick is then integrated piecewise between the
sorted switch instants of each spacecraft, so on-times are honoured exactly. Inside the loop
every per-spacecraft array is component-major, ``(k, n)``: each component is a contiguous row,
so XLA vectorises the arithmetic over spacecraft (twice the throughput of ``(n, k)`` on the
CPU); the layout changes only at the boundaries (:func:`_engine_view`, :func:`simulate`).
Random numbers come only from the run's key: ``fold_in(key, period)``, then a fixed
sub-stream per part. A record is taken every ``periods_per_record`` periods: the state and the
parts' records at the record instant, each actuator's mean output over the interval that
starts there, and the cumulative counters. The run is one jitted ``lax.scan`` over records, cut
into equal power-of-two chunks (to move a progress bar, and so that runs of similar length
share a compiled program). A batch of runs integrates its plant states together in the
batch-inner layout ``(k, B, n)`` and runs only the parts per run under ``jax.vmap``
(:func:`_run_chunk_batched`). There is no Python loop over ticks, spacecraft or edges.
"""

import math
import time
from dataclasses import dataclass, replace
from functools import partial

from coopsat.core import runtime

import jax
import jax.numpy as jnp
import numpy as np

from coopsat.actuators.pulses import torque_between
from coopsat.dynamics.plant import STATE_QUANTITIES, plant_derivative, state_quantities
from coopsat.geometry.quaternion import quat_normalize
from coopsat.sim import native
from coopsat.sim.flight_software import as_flight_software


class NonFiniteStateError(RuntimeError):
    """The state became NaN or infinite during a run."""


AXIS = 0
"""Component axis inside the compiled loop (component-major arrays, spacecraft last)."""

# Sub-streams of a period's random key, one per role, so that adding a sensor never changes
# the draws of another part (jax.random.fold_in of the period key with these numbers + index).
_KEY_CONTROLLER, _KEY_NETWORK, _KEY_SENSORS, _KEY_ACTUATORS, _KEY_DISTURBANCES = 1, 2, 1000, 2000, 3000


def _cm(a):
    """(n, ...) -> (..., n): spacecraft axis last."""
    return jnp.moveaxis(a, 0, -1)


def _engine_view(system):
    """The system with per-spacecraft plant arrays moved to the loop's component-major layout."""
    p = system.plant
    return replace(system, plant=p._replace(inertia_kgm2=_cm(p.inertia_kgm2), inertia_inv=_cm(p.inertia_inv)))


# --- integration ------------------------------------------------------------------------------


def _quantities(system):
    """Static: the state quantities that evolve in this run (:func:`state_quantities`)."""
    s = system.structure
    return state_quantities(s.attitude, s.gravity, (a.channel for a in system.actuators))


def _moving_fields(system):
    return tuple(STATE_QUANTITIES[q][0] for q in _quantities(system))


def _add(wrench, channel, value):
    wrench[channel] = wrench[channel] + value if channel in wrench else value
    return wrench


def _disturbance_wrench(system, t, x, d_states, wrench, batched):
    for d, st in zip(system.disturbances, d_states):
        if batched:  # x batch-inner, parts and their states batch-first (see _run_chunk_batched)
            t_axis = None if jnp.ndim(t) == 0 else 0
            value = jax.vmap(lambda dd, tt, xx, ss: dd.wrench(tt, xx, ss), in_axes=(0, t_axis, _inner_axes(x), 0),
                             out_axes=1)(d, t, x, st)
        else:
            value = d.wrench(t, x, st)
        for channel, v in value.items():
            wrench = _add(dict(wrench), channel, v)
    return wrench


def _rk4(x, wrench, t, h, d_states, system, batched=False):
    """One RK4 step of length ``h`` (scalar, or (n,): one per spacecraft) from time ``t``, with
    the actuators' wrench constant and the disturbances evaluated at every stage.

    The moving fields are packed into one (K, n) array (K: their components together), so
    that each stage is two kernels over contiguous rows rather than one per field and
    operation (measured 1.6× faster at N = 5)."""
    fields = _moving_fields(system)
    rows = [getattr(x, name).shape[0] for name in fields]
    cuts = list(np.cumsum(rows)[:-1])

    def unpack(z):
        return x._replace(**dict(zip(fields, jnp.split(z, cuts, axis=0))))

    def f(z, tt):
        xx = unpack(z)
        w = _disturbance_wrench(system, tt, xx, d_states, wrench, batched) if system.disturbances else wrench
        d = plant_derivative(xx, w, system.plant, system.structure.gravity, AXIS, system.structure.attitude)
        return jnp.concatenate([getattr(d, name) for name in fields], axis=0)

    z = jnp.concatenate([getattr(x, name) for name in fields], axis=0)
    k1 = f(z, t)
    k2 = f(z + 0.5 * h * k1, t + 0.5 * h)
    k3 = f(z + 0.5 * h * k2, t + 0.5 * h)
    k4 = f(z + h * k3, t + h)
    return unpack(z + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4))


def _wrench(system, pulses, level_of):
    """Sum the actuators' contributions per channel; ``level_of(actuator, pulse)`` -> (3, n)."""
    wrench = {}
    for a, p in zip(system.actuators, pulses):
        wrench = _add(wrench, a.channel, level_of(a, p))
    return wrench


def _sorted_rows(a):
    """``a`` (K, …) sorted along its first axis, K small and static: an odd-even transposition
    network of elementwise min/max (K passes over adjacent rows), which XLA fuses with the
    code around it. XLA:CPU's sort is a library call per array: 560 ns for (3, 5) and
    1 µs for (6, 5) in a loop on this machine, against 45 and 84 ns for the network, and
    it was a third of a pulsed tick at N = 5."""
    rows = list(a)
    for i in range(len(rows)):
        for j in range(i % 2, len(rows) - 1, 2):
            rows[j], rows[j + 1] = jnp.minimum(rows[j], rows[j + 1]), jnp.maximum(rows[j], rows[j + 1])
    return jnp.stack(rows)


def _integrate_tick(x, pulses, t_in_period, t_period, d_states, system, batched):
    """Advance one base tick that starts ``t_in_period`` seconds into the control period
    (``t_period``: the period's start time, s). ``batched``: ``x``, ``pulses`` and the plant
    of ``system`` are in the batch-inner layout (:func:`_run_chunk_batched`)."""
    dt = system.dt_s
    sub = system.structure.substeps
    t0 = t_period + t_in_period
    pulsed = [p for a, p in zip(system.actuators, pulses) if a.pulsed]

    # The XLA ticks: a native kernel's fallback and derivative. The smooth tick is one segment
    # of the whole tick (t + 0 and w[None][0] are exact, so this is the same arithmetic).
    def segments(s, xx, wrenches, starts, lengths, t):
        def segment(m, xx):
            h = lengths[m] / sub
            for k in range(sub):
                xx = _rk4(xx, {c: w[m] for c, w in wrenches.items()}, t + starts[m] + k * h, h, d_states, s, batched)
            return xx

        # A loop over the segments, not one RK4 per segment unrolled: a plant without a
        # native kernel (orbits under J2) was traced and compiled once per segment
        # (cartwheel-keeping-ground: 2.9 s of tracing per batch structure).
        n_seg = lengths.shape[0]
        xx = segment(0, xx) if n_seg == 1 else jax.lax.fori_loop(0, n_seg, segment, xx)
        return _renormalise(s, xx)

    def reference(s, xx, wrench, t):
        one = jnp.reshape(s.dt_s, (1,))
        return segments(s, xx, {c: w[None] for c, w in wrench.items()}, jnp.zeros_like(one), one, t)

    def smooth(xx, wrench):
        return native.smooth_tick(system, xx, wrench, t0, _moving_fields(system), reference)

    def split(xx):
        # Switch instants of every pulsed axis inside this tick, sorted per spacecraft: the
        # wrench is constant between consecutive instants, so each segment is integrated
        # exactly as a smooth ODE. Zero-length segments are RK4 steps of length 0 (no-ops).
        cuts = _sorted_rows(jnp.concatenate([jnp.clip(p.t_off_s - t_in_period, 0.0, dt) for p in pulsed]))
        zero = jnp.zeros_like(cuts[:1])
        bounds = jnp.concatenate([zero, cuts, zero + dt], axis=0)
        per_segment = [
            _wrench(
                system, pulses,
                lambda act, p: torque_between(p, t_in_period + a, t_in_period + b) if act.pulsed else p.level_nm,
            )
            for a, b in zip(bounds[:-1], bounds[1:])
        ]
        wrenches = {c: jnp.stack([w[c] for w in per_segment]) for c in per_segment[0]}
        return native.piecewise_tick(
            system, xx, wrenches, bounds[:-1], bounds[1:] - bounds[:-1], t0, _moving_fields(system), segments,
        )

    if not pulsed:
        x = smooth(x, _wrench(system, pulses, lambda act, p: p.level_nm))
    else:
        # Most ticks of a long period hold no switch: integrate those in one piece, with each
        # axis on or off for the whole tick. A batch (not under vmap: _run_chunk_batched) takes
        # the piecewise branch when a switch falls inside the tick in any of its runs.
        switch_inside = jnp.any(jnp.stack([
            jnp.any((p.t_off_s > t_in_period) & (p.t_off_s < t_in_period + dt) & (p.level_nm != 0.0)) for p in pulsed
        ]))
        held = _wrench(
            system, pulses,
            lambda act, p: jnp.where(p.t_off_s >= t_in_period + dt, p.level_nm, 0.0) if act.pulsed else p.level_nm,
        )
        x = jax.lax.cond(switch_inside, split, lambda xx: smooth(xx, held), x)
    return x


def _renormalise(system, x):
    """``q`` back to unit norm after a tick (RK4 does not keep it)."""
    return x._replace(q_bi=quat_normalize(x.q_bi, AXIS)) if "q" in _quantities(system) else x


# --- one control period ------------------------------------------------------------------------


def _truth(system, x):
    """The true state as named quantities, component-major: what ideal sensors read, and what
    a sample records of the plant."""
    return {q: getattr(x, STATE_QUANTITIES[q][0]) for q in _quantities(system)}


def _sense(system, x, st, frame, key, t):
    """Measurements of every spacecraft: the truth, with each sensor's quantity replaced by
    what the sensor reads (held between its updates)."""
    y = _truth(system, x)
    states, held = [], []
    for j, (s, s_state, s_held) in enumerate(zip(system.sensors, st["sensors"], st["held"])):
        value, s_state = s.measure(s.truth(y, x, t), x, s_state, jax.random.fold_in(key, _KEY_SENSORS + j))
        if s.every > 1:
            value = jnp.where(frame % s.every == 0, value, s_held)
        y[s.quantity] = value
        states.append(s_state)
        held.append(value)
    return y, {**st, "sensors": tuple(states), "held": tuple(held)}


def _command(system, x, st, tick):
    """Sense, deliver, control and actuate at the start of a period.

    Returns (pulses, states, record): one pulse per actuator, the parts' new states, and what
    is recorded at this instant: each sensor's reading (``measured_<quantity>``), and what the
    network, the controller, the actuators (from their state at the period's start) and the
    disturbances record.
    """
    t = tick * system.dt_s
    frame = tick // system.structure.ticks_per_period
    key = jax.random.fold_in(system.key, frame)
    y, st = _sense(system, x, st, frame, key, t)
    measured = {f"measured_{s.quantity}": y[s.quantity] for s in system.sensors}
    ctrl = as_flight_software(system.controller, system.structure.n_spacecraft)
    outbox = ctrl.outbox(y, st["controller"])
    inbox, net_state, net_record = system.network.deliver(
        tick, outbox, st["network"], jax.random.fold_in(key, _KEY_NETWORK)
    )
    cmd, ctrl_state, record = native.control_step(
        system, ctrl, t, y, inbox, st["controller"], jax.random.fold_in(key, _KEY_CONTROLLER)
    )
    record = {**measured, **net_record, **record}
    pulses, act_states = [], []
    for j, (a, a_state) in enumerate(zip(system.actuators, st["actuators"])):
        record = {**record, **a.record(x, a_state)}
        command = cmd[a.command] if a.command in cmd else jnp.zeros_like(x.omega_b)
        pulse, a_state = a.plan(command, x, a_state, system.period_s, jax.random.fold_in(key, _KEY_ACTUATORS + j), t)
        pulses.append(pulse)
        act_states.append(a_state)
    d_states = tuple(
        d.update(t, x, d_state, jax.random.fold_in(key, _KEY_DISTURBANCES + j))
        for j, (d, d_state) in enumerate(zip(system.disturbances, st["disturbances"]))
    )
    for d, d_state in zip(system.disturbances, d_states):
        record = {**record, **d.record(t, x, d_state)}
    st = {**st, "controller": ctrl_state, "network": net_state, "actuators": tuple(act_states), "disturbances": d_states}
    return tuple(pulses), st, record


def _account(system, pulses):
    """Per-period increments of every actuator's counters (impulse, on-time, firings, bits…)."""
    inc = {}
    for a, p in zip(system.actuators, pulses):
        for k, v in a.account(p).items():
            if k in inc:
                raise ValueError(f"two actuators both count '{k}'; give them distinct outputs")
            inc[k] = v
    return inc


def _per_run(fn, system, *args, in_axes, out_axes=0):
    """``fn(system, *args)`` for every run of a batch: ``jax.vmap`` over the parts (batch-first)
    with the plant left out (it is in the batch-inner layout; no part reads it)."""
    runs = replace(system, plant=None)
    axes = replace(jax.tree_util.tree_map(lambda _: 0, runs), dt_s=None)
    return jax.vmap(fn, in_axes=(axes, *in_axes), out_axes=out_axes)(runs, *args)


def _period(system, carry, batched):
    """One control period. Returns the new carry and the period's (pulses, record).

    ``batched``: the carry's plant state and ``system.plant`` are in the batch-inner layout,
    every other leaf batch-first (:func:`_run_chunk_batched`); the parts run per run under
    ``vmap`` and the plant is integrated for all runs at once.
    """
    x, st, acc, tick = carry
    if batched:
        pulses, st, record = _per_run(_command, system, x, st, tick, in_axes=(_inner_axes(x), 0, None))
        increments = _per_run(_account, system, pulses, in_axes=(0,))
        pulses_now = jax.tree_util.tree_map(_to_inner, pulses)
    else:
        pulses, st, record = _command(system, x, st, tick)
        increments = _account(system, pulses)
        pulses_now = pulses
    tpp = system.structure.ticks_per_period
    t_period = tick * system.dt_s
    d_states = st["disturbances"]
    if tpp == 1:
        x = _integrate_tick(x, pulses_now, 0.0, t_period, d_states, system, batched)
    else:
        x = jax.lax.fori_loop(
            0, tpp, lambda k, xx: _integrate_tick(xx, pulses_now, k * system.dt_s, t_period, d_states, system, batched), x
        )
    acc = jax.tree_util.tree_map(jnp.add, acc, increments)
    return (x, st, acc, tick + tpp), (pulses, record)


def _means(system, acc_before, acc_after, interval_s):
    """Each actuator's mean output over an interval, from its counter (e.g. mean torque from
    the signed angular impulse)."""
    return {
        a.mean_output[0]: (acc_after[a.mean_output[1]] - acc_before[a.mean_output[1]]) / interval_s
        for a in system.actuators
    }


def _block(system, carry, batched):
    """One record interval: the sample at its start, then ``periods_per_record`` periods.

    The sample holds the state and the controller's record at its instant and the mean
    output of each actuator over the whole interval that follows (from the counters
    accumulated over it), so no period is left out of the record.
    """
    x, _, acc, _ = carry
    carry, (_, record) = _period(system, carry, batched)
    rest = system.structure.periods_per_record - 1
    if rest > 0:
        carry = jax.lax.fori_loop(0, rest, lambda _, c: _period(system, c, batched)[0], carry)
    interval = system.period_s * system.structure.periods_per_record
    truth = _truth(system, x)
    if batched:
        truth = jax.tree_util.tree_map(_from_inner, truth)
    return carry, {**truth, **acc, **record, **_means(system, acc, carry[2], interval)}


def _scan_records(system, carry, first_record, n_records, chunk, batched):
    """``chunk`` record intervals; those at or past ``n_records`` pass the carry through."""

    def body(c, k):
        template = jax.eval_shape(lambda cc: _block(system, cc, batched)[1], c)
        return jax.lax.cond(
            first_record + k < n_records,
            lambda cc: _block(system, cc, batched),
            lambda cc: (cc, jax.tree_util.tree_map(lambda s: jnp.zeros(s.shape, s.dtype), template)),
            c,
        )

    return jax.lax.scan(body, carry, jnp.arange(chunk))


@partial(jax.jit, static_argnames=("chunk",))
def _run_chunk(system, carry, first_record, n_records, chunk):
    """``chunk`` record intervals of one run."""
    return _scan_records(_engine_view(system), carry, first_record, n_records, chunk, False)


# --- batches -----------------------------------------------------------------------------------
#
# A batch is not the one-run loop under vmap: vmap would keep every array batch-first,
# (B, k, n), where a component row is only n long (5 for the consensus paper) and strided, so
# the RK4 arithmetic vectorised over 5 spacecraft at a time (a batch of 256 runs of N = 5 ran
# no faster per spacecraft than one run). Here the plant state and plant parameters are
# *batch-inner*, (k, B, n): each component is one contiguous row of B·n values, and RK4 runs
# on all runs at once, outside vmap (so the switch test of pulsed actuation is a real branch
# again). Only the parts (sense, deliver, control, plan, account, disturbances) run per run
# under vmap, once per control period, with the plant state handed over in place
# (``in_axes`` = the run axis). Everything else in the carry stays batch-first.


def _run_axis(ndim):
    """Position of the run axis of a batch-inner array of rank ``ndim``: just before the last
    (spacecraft) axis; 0 for per-run scalars."""
    return max(ndim - 2, 0)


def _inner_axes(tree):
    """``vmap`` axes of a batch-inner tree."""
    return jax.tree_util.tree_map(lambda a: _run_axis(jnp.ndim(a)), tree)


def _to_inner(a):
    """Batch-first (B, …, n) -> batch-inner (…, B, n); a per-run scalar (B,) -> (B, 1)."""
    return a[:, None] if jnp.ndim(a) == 1 else jnp.moveaxis(a, 0, -2)


def _from_inner(a):
    """Inverse of :func:`_to_inner` for arrays of rank ≥ 2."""
    return jnp.moveaxis(a, -2, 0)


def _inner_plant(plant):
    """Batch-first plant parameters in the batch-inner layout: per-spacecraft leaves
    (B, n, k…) -> (k…, B, n) (the one-run loop's component-major layout, runs inserted),
    masses (B, n) unchanged, scalars (B,) -> (B, 1) (they broadcast against (…, B, n))."""
    return plant._replace(
        inertia_kgm2=jnp.moveaxis(plant.inertia_kgm2, (0, 1), (-2, -1)),
        inertia_inv=jnp.moveaxis(plant.inertia_inv, (0, 1), (-2, -1)),
        mu_m3_s2=plant.mu_m3_s2[:, None], j2=plant.j2[:, None], r_body_m=plant.r_body_m[:, None],
        chief=plant.chief[:, None],
    )


GROUP_SPACECRAFT = 1024
"""Spacecraft (runs × N) integrated together in one group of a batch: a larger batch is run
group after group (:func:`_batch_groups`), so that the RK4 stages' working set stays in the
core's cache. Measured, consensus N = 5: 18.2–18.5 M spacecraft-steps/s for groups of 64–256
runs, 13.3–13.5 for 512–1000 runs in one group."""


def _batch_groups(n_runs, n_spacecraft, devices=1):
    """(groups, runs per group) for a batch: the fewest groups of at most
    :data:`GROUP_SPACECRAFT` spacecraft, balanced (the last is padded to the same size), and a
    multiple of ``devices`` (to share among them)."""
    groups = max(1, math.ceil(n_runs * n_spacecraft / GROUP_SPACECRAFT))
    if devices > 1 and n_runs >= devices:
        groups = math.ceil(groups / devices) * devices
    return groups, math.ceil(n_runs / groups)


def _run_group(system, carry, first_record, n_records, chunk):
    """``chunk`` record intervals of one group of runs (batch-first in and out)."""
    system = replace(system, plant=_inner_plant(system.plant))
    x, st, acc, tick = carry
    carry = (jax.tree_util.tree_map(_to_inner, x), st, acc, tick)
    (x, st, acc, tick), out = _scan_records(system, carry, first_record, n_records, chunk, True)
    return (jax.tree_util.tree_map(_from_inner, x), st, acc, tick), jax.tree_util.tree_map(lambda a: jnp.moveaxis(a, 1, 0), out)


@partial(jax.jit, static_argnames=("chunk", "groups", "devices"))
def _run_chunk_batched(system, carry, first_record, n_records, chunk, groups=1, devices=1):
    """``chunk`` record intervals of a batch (batch-first System, shared ``dt_s`` and tick).

    Takes and returns the carry batch-first, as the vmapped per-run functions
    (:func:`_initial_carry`, :func:`_final_sample`) do; samples ``(B, chunk, …)``. With
    ``groups`` > 1 (B a multiple of it), the runs are integrated group after group
    (``lax.map``), each group for the whole chunk; with ``devices`` > 1 (``groups`` a multiple
    of it) the groups are shared among the first ``devices`` devices (``jax.shard_map``).
    """
    if groups == 1:
        return _run_group(system, carry, first_record, n_records, chunk)
    dt_s, tick = system.dt_s, carry[3]
    split = lambda a: a.reshape(groups, a.shape[0] // groups, *a.shape[1:])  # noqa: E731
    merge = lambda a: a.reshape(a.shape[0] * a.shape[1], *a.shape[2:])  # noqa: E731
    per_group = jax.tree_util.tree_map(split, (replace(system, dt_s=None), carry[:3]))

    def one(group):
        g_system, g_carry = group
        return _run_group(replace(g_system, dt_s=dt_s), (*g_carry, tick), first_record, n_records, chunk)

    if devices > 1:
        # One share of the groups per device (on the CPU: per core, coopsat.core.runtime), each device
        # running its groups in turn.
        from jax.sharding import Mesh, PartitionSpec

        mesh = Mesh(np.array(jax.devices()[:devices]), ("device",))
        spec = PartitionSpec("device")
        (x, st, acc, ticks), out = jax.shard_map(
            lambda pg: jax.lax.map(one, pg), mesh=mesh, in_specs=spec, out_specs=spec, check_vma=False
        )(per_group)
    else:
        (x, st, acc, ticks), out = jax.lax.map(one, per_group)
    return jax.tree_util.tree_map(merge, (x, st, acc)) + (ticks[0],), jax.tree_util.tree_map(merge, out)


@jax.jit
def _final_sample(system, carry):
    """The sample at the end of the run; actuator means are those of the period that would follow."""
    system = _engine_view(system)
    x, st, acc, tick = carry
    pulses, _, record = _command(system, x, st, tick)
    inc = _account(system, pulses)
    means = {a.mean_output[0]: inc[a.mean_output[1]] / system.period_s for a in system.actuators}
    return {**_truth(system, x), **acc, **record, **means}


def _initial_carry(system):
    """State of the plant and of every part at t = 0, and zeroed counters.

    The network's history before t = 0 is the first outbox (a constant initial function, as
    is usual for delay equations).
    """
    system_cm = _engine_view(system)
    x0 = jax.tree_util.tree_map(_cm, system.x0)
    x0 = x0._replace(q_bi=quat_normalize(x0.q_bi, AXIS))
    n = system.structure.n_spacecraft
    truth = _truth(system_cm, x0)
    st = {
        "controller": system.controller.init(n),
        "sensors": tuple(s.init(s.truth(truth, x0, 0.0), n) for s in system.sensors),
        "held": tuple(s.truth(truth, x0, 0.0) for s in system.sensors),
        "actuators": tuple(a.init(n) for a in system.actuators),
        "disturbances": tuple(d.init(n) for d in system.disturbances),
        "network": (),
    }
    y0, _ = _sense(system_cm, x0, st, 0, jax.random.fold_in(system.key, 0), 0.0)
    st["network"] = system.network.init(as_flight_software(system.controller, n).outbox(y0, st["controller"]))
    zeros = jax.eval_shape(
        lambda: _account(system_cm, tuple(a.plan(jnp.zeros_like(x0.omega_b), x0, s, system_cm.period_s, system.key, 0.0)[0]
                                          for a, s in zip(system_cm.actuators, st["actuators"])))
    )
    acc = jax.tree_util.tree_map(lambda s: jnp.zeros(s.shape, s.dtype), zeros)
    return (x0, st, acc, jnp.zeros((), jnp.int64))


def output_specs(system):
    """How each recorded output appears in the dataset: the plant's, then every part's.

    Returns
    -------
    dict of str -> coopsat.core.parts.OutputSpec
    """
    from coopsat.sim.outputs import measured_output_spec, state_output_specs

    specs = state_output_specs(_quantities(system))
    # A sensor of a derived quantity describes its own reading (in its output_specs).
    specs.update({f"measured_{s.quantity}": measured_output_spec(s.quantity) for s in system.sensors if s.quantity in STATE_QUANTITIES})
    for p in (system.controller, system.network, *system.sensors, *system.actuators, *system.disturbances):
        specs.update(p.output_specs())
    return specs


def output_shapes(system):
    """Shape of each recorded output of one sample, interface layout, without compiling.

    Returns
    -------
    dict of str -> tuple
        ``(n_spacecraft, k…)`` per spacecraft output, ``(k…,)`` for the others.
    """
    shapes = jax.eval_shape(lambda s: _final_sample(s, _initial_carry(s)), system)
    specs = output_specs(system)
    return {k: (v.shape[-1], *v.shape[:-1]) if specs[k].per_spacecraft else v.shape for k, v in shapes.items()}


@dataclass
class RunOutput:
    """Recorded samples of one run (or a batch) as NumPy arrays.

    Attributes
    ----------
    t_s : ndarray (n_samples,)
        Sample times, s.
    samples : dict of ndarray
        Each ``([batch,] n_samples, n_spacecraft, ...)`` except reference quantities
        (``q_ref``: ``([batch,] n_samples, 4)``).
    compile_s, run_s : float
        Wall time spent compiling (first call of a structure in this process, cache misses
        included) and running, s.
    """

    t_s: np.ndarray
    samples: dict
    compile_s: float
    run_s: float


_COMPILED = {}
"""Compiled programs of this process (first sample, chunk, last sample), by system structure,
leaf shapes, chunk and batching (least recently used first)."""
_COMPILED_MAX = 32

MAX_CHUNK = 4096
"""Most record intervals per compiled call: bounds the padding of the last chunk (memory)."""

def _check_finite(samples, t_s, offset, batched, names=None):
    """Raise :class:`NonFiniteStateError` naming the first sample, spacecraft and field."""
    for name, (_, label) in STATE_QUANTITIES.items():
        if name not in samples:
            continue
        a = np.asarray(samples[name])
        bad = ~np.isfinite(a)
        if bad.any():
            idx = np.argwhere(bad)[0]  # ([run,] record, component, spacecraft)
            k = idx[1] if batched else idx[0]
            sc = idx[-1]
            run = f"run {idx[0]}, " if batched else ""
            who = names[sc] if names is not None else f"spacecraft index {sc}"
            raise NonFiniteStateError(
                f"state became non-finite: {run}{label} of {who} at t = {t_s[offset + k]:g} s "
                "(check gains, control period and step size)"
            )


def _shared_time_base(system):
    """A batched system with its tick ``dt_s`` unbatched, and the matching ``vmap`` axes.

    Raises
    ------
    ValueError
        When the runs of the batch have different ticks (they cannot share a time base).
    """
    dt = np.asarray(system.dt_s)
    if not np.all(dt == dt.flat[0]):
        raise ValueError(f"simulate: the runs of a batch share one time base, but their dt_s differ ({sorted(set(dt.tolist()))})")
    system = replace(system, dt_s=jnp.asarray(dt.flat[0]))
    axes = replace(jax.tree_util.tree_map(lambda _: 0, system), dt_s=None)
    return system, axes


def bucket_runs(n_runs, full):
    """Runs a batch of ``n_runs`` is padded to so that its shape recurs: the smallest
    ``ceil(full / 2^j) ≥ n_runs`` (``full``: the largest batch expected, a campaign's batch
    size; ``n_runs`` itself above it).

    A campaign batch split by structure (a dispersed delay choice changes the delay line's
    length) gives groups of every size, and each size was its own program, traced and compiled
    again: a batch of 20 ``cartwheel-navigation-dispersed`` runs took 16 s, against 0.65 s
    for its runs once compiled. With these sizes a structure has at most ``⌈log2(full)⌉ + 1``
    programs, a full batch is not padded, and a part batch less than doubled."""
    if n_runs >= full:
        return n_runs
    size = full
    while size > 1 and -(-size // 2) >= n_runs:
        size = -(-size // 2)
    return size


def simulate(system, n_records, record_interval_s, *, batched=False, progress=False, chunk=None, names=None,
             every_core=True, bucket=None, cancel=None):
    """Run the closed loop for ``n_records`` record intervals.

    Parameters
    ----------
    system : System
        Single run, or a batch from :func:`~coopsat.sim.system.stack_systems` with
        ``batched=True``.
    n_records : int
        Record intervals; the run ends at ``n_records · record_interval_s`` and
        ``n_records + 1`` samples are returned (both ends included).
    record_interval_s : float
        Time between samples, s (a whole number of control periods).
    batched : bool
        ``vmap`` over the leading axis of every data leaf of ``system``.
    progress : bool
        Show a progress bar (it appears only once a run has taken 2 s).
    names : sequence of str, optional
        Spacecraft names, for error messages.
    every_core : bool
        Share a batch's groups among every device (one per CPU core, ``coopsat.core.runtime``). False
        runs it on one device, so that its results do not depend on the machine's core count
        (grouping can change a result in the last bit).
    chunk : int, optional
        Record intervals per compiled call. Default: a power of two (so that runs of similar
        length reuse the compiled program) near 1/50 of the run, at most :data:`MAX_CHUNK`.
    bucket : int, optional
        Pad a batch to :func:`bucket_runs` (``n_runs``, ``bucket``) runs (copies of its last
        run, dropped from the results), so that batches of nearby sizes share one compiled
        program (a campaign: its batch size).
    cancel : callable, optional
        Called with no argument at the run's safe points (after compiling, after each compiled
        chunk); it stops the run by raising. The command line passes
        :func:`coopsat.workflows.interrupt.check`, so that a signal ends a run promptly.

    Returns
    -------
    RunOutput

    Raises
    ------
    NonFiniteStateError
        When the state becomes NaN or infinite; the run stops at the chunk where it happened.
    """
    runtime.enable()
    if chunk is None:
        # Powers of two, so that runs of different lengths share compiled programs (the padded
        # record intervals of the last chunk are skipped, not simulated).
        # About 1/50 of the run per call: a progress bar moves, and an interrupt (which Python
        # handles between calls) ends the run promptly.
        chunk = min(2 ** math.ceil(math.log2(max(1, n_records / 50))), MAX_CHUNK)
    n_chunks = math.ceil(n_records / chunk)
    final = _final_sample
    init = _initial_carry
    n_runs, groups, devices = None, 1, 1
    if batched:
        system, sys_axes = _shared_time_base(system)
        # The tick stays unbatched too, so time (and every schedule indexed by it) is the same
        # traced value for all runs: a branch on time (a planner due every so often) stays a
        # branch under vmap instead of becoming a select that evaluates both sides every period.
        carry_axes = (0, 0, 0, None)
        n_runs = int(np.shape(system.key)[0])
        devices = len(jax.devices()) if every_core else 1
        n_padded = bucket_runs(n_runs, bucket) if bucket else n_runs
        groups, per_group = _batch_groups(n_padded, system.structure.n_spacecraft, devices)
        devices = devices if groups % devices == 0 else 1
        # Pad to whole groups with copies of the last run (their results are dropped).
        pad = groups * per_group - n_runs
        if pad:
            system = jax.tree_util.tree_map(
                lambda a, ax: a if ax is None else jnp.concatenate([a, jnp.repeat(a[-1:], pad, axis=0)]), system, sys_axes
            )
        final = jax.vmap(_final_sample, in_axes=(sys_axes, carry_axes))
        init = jax.vmap(_initial_carry, in_axes=(sys_axes,), out_axes=carry_axes)
    t_s = np.arange(n_records + 1) * record_interval_s

    # Compile apart from running, so that the two can be reported separately; the programs
    # are compiled once per process for each structure, shape and chunk (then JAX's persistent
    # cache serves new processes). The first and last samples are compiled too: run op by op
    # they dispatched (and, for each new batch size, compiled) hundreds of small programs,
    # 0.5 s each for observation-cooperative.
    t0 = time.perf_counter()
    key = (jax.tree_util.tree_structure(system), tuple(jax.ShapeDtypeStruct(jnp.shape(v), jnp.result_type(v))
           for v in jax.tree_util.tree_leaves(system)), chunk, batched, groups, devices)
    compiled = _COMPILED.pop(key, None)
    if compiled is None:
        carry = jax.eval_shape(init, system)
        init = jax.jit(init).lower(system).compile()
        lowered = (_run_chunk_batched.lower(system, carry, 0, n_records, chunk, groups, devices) if batched
                   else _run_chunk.lower(system, carry, 0, n_records, chunk))
        run_chunk = lowered.compile()
        # The last sample reads the carry as the chunks leave it (shared among devices when a
        # batch is).
        carry = jax.tree_util.tree_map(lambda a, sharding: jax.ShapeDtypeStruct(a.shape, a.dtype, sharding=sharding),
                                       carry, run_chunk.output_shardings[0])
        compiled = (init, run_chunk, jax.jit(final).lower(system, carry).compile())
    _COMPILED[key] = compiled  # most recently used last
    init, run_chunk, final = compiled
    while len(_COMPILED) > _COMPILED_MAX:
        _COMPILED.pop(next(iter(_COMPILED)))
    compile_s = time.perf_counter() - t0
    if cancel is not None:
        cancel()

    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=n_records, unit="rec", delay=2.0, leave=False, desc="simulating")
    chunks = []
    t0 = time.perf_counter()
    carry = init(system)
    try:
        for c in range(n_chunks):
            carry, out = run_chunk(system, carry, c * chunk, n_records)
            out = jax.tree_util.tree_map(np.asarray, out)
            _check_finite(out, t_s, c * chunk, batched, names)
            chunks.append(out)
            if cancel is not None:
                cancel()
            if bar is not None:
                bar.update(min(chunk, n_records - c * chunk))
        last = jax.tree_util.tree_map(np.asarray, final(system, carry))
        _check_finite({k: np.expand_dims(v, 1 if batched else 0) for k, v in last.items()}, t_s, n_records, batched, names)
    finally:
        if bar is not None:
            bar.close()
    run_s = time.perf_counter() - t0
    axis = 1 if batched else 0
    # The last chunk may run past n_records (its extra rows are padding): keep n_records rows,
    # then append the final sample; per-spacecraft arrays go back to (spacecraft, component).
    samples = {
        k: np.concatenate(
            [np.take(np.concatenate([ch[k] for ch in chunks], axis=axis), np.arange(n_records), axis=axis),
             np.expand_dims(last[k], axis)],
            axis=axis,
        )
        for k in last
    }
    specs = output_specs(system)
    samples = {k: np.moveaxis(v, -1, axis + 1) if specs[k].per_spacecraft else v for k, v in samples.items()}
    if batched:
        samples = {k: v[:n_runs] for k, v in samples.items()}  # without the padding runs
    return RunOutput(t_s=t_s, samples=samples, compile_s=compile_s, run_s=run_s)


def run_samples(system, n_records):
    """Every sample of one run as a pure function of ``system``: differentiable end to end.

    The same closed loop as :func:`simulate` (one ``lax.scan`` over all ``n_records`` record
    intervals, then the final sample), without chunks, progress or NumPy conversion, so that
    ``jax.grad``/``jax.jvp`` of a metric of the samples with respect to any data leaf of
    ``system`` (a gain, a weight) goes through the whole run. Used by ``coopsat tune``.

    Parameters
    ----------
    system : System
        One run (not a batch; ``jax.vmap`` this function to batch).
    n_records : int
        Record intervals (static).

    Returns
    -------
    dict of str -> jax.Array
        Each ``(n_records + 1, n_spacecraft, k…)`` for per-spacecraft outputs (interface
        layout, as :class:`RunOutput` samples), ``(n_records + 1, k…)`` for the others.
    """
    carry, out = _run_chunk(system, _initial_carry(system), 0, n_records, n_records)
    last = _final_sample(system, carry)
    specs = output_specs(system)
    samples = {k: jnp.concatenate([out[k], last[k][None]], axis=0) for k in last}
    return {k: jnp.moveaxis(v, -1, 1) if specs[k].per_spacecraft else v for k, v in samples.items()}
