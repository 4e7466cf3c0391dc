"""One base tick of the plant: RK4 under the actuators' held wrench, cut at pulse switches.

A smooth tick (no switch inside it) is ``substeps`` RK4 steps under a held wrench. Pulsed
actuators switch inside a tick; such a tick is integrated piecewise between the sorted switch
instants of each spacecraft, so on-times are honoured exactly. Either goes to a native CPU
kernel where one applies (:mod:`coopsat.sim.native`), else to the XLA code here, which is also
the kernels' fallback and derivative. Arrays are component-major, or batch-inner for a batch
(:mod:`coopsat.sim.layout`).
"""

import jax
import jax.numpy as jnp
import numpy as np

from coopsat.actuators.pulses import torque_between
from coopsat.dynamics.plant import STATE_QUANTITIES, plant_derivative, state_quantities
from coopsat.geometry.quaternion import quat_normalize
from coopsat.sim import native
from coopsat.sim.layout import AXIS, _flat_plant, _flat_rows, _inner_axes


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
    operation (docs/engine-notes.md, "Packed RK4 stages"). A batch's (…, B, n) arrays are
    integrated as flat (…, B·n) rows (:func:`~coopsat.sim.layout._flat_rows`), which XLA
    vectorises over every run's spacecraft, handed back to the disturbances in the batch-inner
    layout. The operations are the same; XLA's vector loops round some of them differently
    from its scalar ones, so a run in a batch can differ from the same run alone in the last
    bits (as a batch's regrouped sums already could)."""
    fields = _moving_fields(system)
    rows = [getattr(x, name).shape[0] for name in fields]
    cuts = list(np.cumsum(rows)[:-1])
    plant, wrench_inner = system.plant, wrench
    flat = unflat = lambda a: a  # noqa: E731
    if batched:
        runs_sc = getattr(x, fields[0]).shape[-2:]
        flat, unflat = _flat_rows(runs_sc)
        plant, wrench, t, h = _flat_plant(plant, runs_sc), {c: flat(w) for c, w in wrench.items()}, flat(t), flat(h)
    x_flat = jax.tree_util.tree_map(flat, x)

    def unpack(z, like):
        return like._replace(**dict(zip(fields, jnp.split(z, cuts, axis=0))))

    def f(z, tt):
        w = wrench
        if system.disturbances:
            w = {c: flat(v) for c, v in
                 _disturbance_wrench(system, unflat(tt), unpack(unflat(z), x), d_states, wrench_inner, batched).items()}
        d = plant_derivative(unpack(z, x_flat), w, plant, system.structure.gravity, AXIS, system.structure.attitude)
        return jnp.concatenate([getattr(d, name) for name in fields], axis=0)

    z = jnp.concatenate([getattr(x_flat, name) for name in fields], axis=0)
    k1 = f(z, t)
    k2 = f(z + 0.5 * h * k1, t + 0.5 * h)
    k3 = f(z + 0.5 * h * k2, t + 0.5 * h)
    k4 = f(z + h * k3, t + h)
    return unpack(unflat(z + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)), x)


def _wrench(system, pulses, level_of):
    """Sum the actuators' contributions per channel; ``level_of(actuator, pulse)`` -> (3, n)."""
    wrench = {}
    for a, p in zip(system.actuators, pulses):
        wrench = _add(wrench, a.channel, level_of(a, p))
    return wrench


def _sorted_rows(a):
    """``a`` (K, …) sorted along its first axis, K small and static: an odd-even transposition
    network of elementwise min/max (K passes over adjacent rows), which XLA fuses with the
    code around it; XLA:CPU's sort is a library call per array, which it cannot fuse
    (docs/engine-notes.md, "Sorting switch instants")."""
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

        # A loop over the segments, not one RK4 per segment unrolled, so that a plant without
        # a native kernel (orbits under J2) is traced and compiled once, not once per segment
        # (docs/engine-notes.md, "Segment loop").
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

