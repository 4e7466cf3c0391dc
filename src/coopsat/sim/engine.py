"""The closed-loop engine: integer ticks, zero-order hold, RK4, one compiled scan.

Per control period (``ticks_per_period`` base ticks):

    sense → deliver → control → actuate (a :class:`~coopsat.actuators.pulses.Pulse`)
          → integrate every tick of the period with RK4 → account (impulse, on-time)

Pulsed actuation (PWM) switches inside a tick; each tick is then integrated piecewise between
the sorted switch instants of each spacecraft (at most three per tick, one per axis), so the
on-time is honoured exactly. Inside the loop every per-spacecraft array is component-major,
``(k, n)``: each component is a contiguous row, so XLA vectorises the arithmetic over spacecraft
(twice the throughput of ``(n, k)`` on the CPU); the layout changes only at the boundaries
(:func:`_engine_view`, :func:`simulate`). A record is taken every ``periods_per_record`` periods:
the state, command and auxiliary outputs at the record instant, the mean torque applied over
the interval that starts there, and the cumulative counters. The run is one jitted
``lax.scan`` over records, cut into equal power-of-two chunks (to move a progress bar, and so
that runs of similar length share a compiled program); ``jax.vmap`` over a batched
:class:`~coopsat.sim.system.System` runs many at once. There is no Python loop over ticks,
spacecraft or edges.
"""

import dataclasses
import math
import time
from dataclasses import dataclass
from functools import partial

from coopsat import _jax  # noqa: F401

import jax
import jax.numpy as jnp
import numpy as np

from coopsat.actuators.ideal import ideal_torque_pulse
from coopsat.actuators.pulses import pulse_mean_torque, torque_between
from coopsat.actuators.pwm import pwm_pulse, thruster_on_time_s
from coopsat.control.consensus import consensus_sync_torque, consensus_track_torque, reference_attitude
from coopsat.dynamics.plant import plant_derivative
from coopsat.geometry.quaternion import quat_normalize
from coopsat.network.delivery import deliver_ideal


class NonFiniteStateError(RuntimeError):
    """The state became NaN or infinite during a run."""


AXIS = 0
"""Component axis inside the compiled loop (component-major arrays, spacecraft last)."""


def _cm(a):
    """(n, ...) -> (..., n): spacecraft axis last."""
    return jnp.moveaxis(a, 0, -1)


def _engine_view(system):
    """The system with per-spacecraft plant arrays moved to the loop's component-major layout."""
    p = system.plant
    return dataclasses.replace(system, plant=p._replace(inertia_kgm2=_cm(p.inertia_kgm2), inertia_inv=_cm(p.inertia_inv)))


# --- controllers: (t, outbox, inbox, link weights, system) -> (command (3, n), aux dict) ------


def _no_control(t, own, inbox, weight, system):
    return jnp.zeros_like(own["omega"]), {}


def _sync_control(t, own, inbox, weight, system):
    p = system.controller
    u = consensus_sync_torque(
        own["q"], own["omega"], inbox["q"], inbox["omega"], system.links_dst, weight,
        p["alpha"], p["beta"], system.structure.short_way, AXIS,
    )
    return u, {}


def _track_control(t, own, inbox, weight, system):
    p = system.controller
    q_ref = reference_attitude(p["q_ref0"], p["omega_ref_b"], t)
    u = consensus_track_torque(
        own["q"], own["omega"], inbox["q"], inbox["omega"], system.links_dst, weight,
        p["alpha"], p["beta"], p["k_p"], p["k_d"], q_ref, p["omega_ref_b"], system.structure.short_way, AXIS,
    )
    return u, {"q_ref": q_ref}


CONTROLLERS = {
    "none": _no_control,
    "consensus-sync": _sync_control,
    "consensus-track": _track_control,
}
"""Control laws by scenario ``controller.kind``."""


# --- actuators: (command, system) -> Pulse; pulsed actuators switch inside a period ----------


@dataclass(frozen=True)
class _Actuator:
    plan: callable
    pulsed: bool
    counts_thrusters: bool


ACTUATORS = {
    "ideal-torque": _Actuator(
        lambda u, s: ideal_torque_pulse(u, s.period_s, s.actuator["torque_max_nm"]), pulsed=False, counts_thrusters=False
    ),
    "pwm-thrusters": _Actuator(
        lambda u, s: pwm_pulse(u, s.period_s, s.actuator["torque_max_nm"], s.actuator["min_pulse_s"]),
        pulsed=True,
        counts_thrusters=True,
    ),
}
"""Actuators by scenario ``actuators.kind``."""


# --- integration ------------------------------------------------------------------------------


def _moving_fields(gravity):
    return ("q_bi", "omega_b") if gravity == "none" else ("q_bi", "omega_b", "r_eci", "v_eci")


def _rk4(x, torque, h, system):
    """One RK4 step of length ``h`` (scalar, or (n,): one per spacecraft) with a constant torque."""
    fields = _moving_fields(system.structure.gravity)

    def f(xx):
        d = plant_derivative(xx, torque, system.plant, system.structure.gravity, AXIS)
        return {k: getattr(d, k) for k in fields}

    def shifted(k, c):
        return x._replace(**{name: getattr(x, name) + c * k[name] for name in fields})

    k1 = f(x)
    k2 = f(shifted(k1, 0.5 * h))
    k3 = f(shifted(k2, 0.5 * h))
    k4 = f(shifted(k3, h))
    return x._replace(
        **{name: getattr(x, name) + (h / 6.0) * (k1[name] + 2.0 * k2[name] + 2.0 * k3[name] + k4[name]) for name in fields}
    )


def _integrate_tick(x, pulse, t_in_period, system, batched):
    """Advance one base tick that starts ``t_in_period`` seconds into the control period."""
    dt = system.dt_s
    sub = system.structure.substeps

    def smooth(xx, torque):
        for _ in range(sub):
            xx = _rk4(xx, torque, dt / sub, system)
        return xx

    def split(xx):
        # Switch instants of the three axes inside this tick, sorted per spacecraft: the torque
        # is constant between consecutive instants, so each segment is integrated exactly as a
        # smooth ODE. Zero-length segments are RK4 steps of length 0, i.e. no-ops.
        cuts = jnp.sort(jnp.clip(pulse.t_off_s - t_in_period, 0.0, dt), axis=0)  # (3, n)
        zero = jnp.zeros_like(cuts[:1])
        bounds = jnp.concatenate([zero, cuts, zero + dt], axis=0)  # (5, n)
        for m in range(4):
            a, b = bounds[m], bounds[m + 1]
            torque = torque_between(pulse, t_in_period + a, t_in_period + b)
            for _ in range(sub):
                xx = _rk4(xx, torque, (b - a) / sub, system)
        return xx

    if not ACTUATORS[system.structure.actuator].pulsed:
        x = smooth(x, pulse.level_nm)
    elif batched:
        x = split(x)  # under vmap a cond would evaluate both branches anyway
    else:
        # Most ticks of a long period hold no switch: integrate those in one piece, with each
        # axis on or off for the whole tick.
        switch_inside = (pulse.t_off_s > t_in_period) & (pulse.t_off_s < t_in_period + dt) & (pulse.level_nm != 0.0)
        held = jnp.where(pulse.t_off_s >= t_in_period + dt, pulse.level_nm, 0.0)
        x = jax.lax.cond(jnp.any(switch_inside), split, lambda xx: smooth(xx, held), x)
    return x._replace(q_bi=quat_normalize(x.q_bi, AXIS))


def _active_weights(system, tick):
    """Link weights of the graph in force at ``tick`` (switching topology: last switch ≤ tick)."""
    if system.links_weight.shape[0] == 1:
        return system.links_weight[0]
    return system.links_weight[jnp.searchsorted(system.switch_ticks, tick, side="right") - 1]


def _command(system, x, tick):
    """Sense, deliver and control at the start of a period: returns (pulse, command, aux)."""
    t = tick * system.dt_s
    outbox = {"q": x.q_bi, "omega": x.omega_b}
    inbox = deliver_ideal(outbox, system.links_src, spacecraft_axis=-1)
    u, aux = CONTROLLERS[system.structure.controller](t, outbox, inbox, _active_weights(system, tick), system)
    pulse = ACTUATORS[system.structure.actuator].plan(u, system)
    return pulse, u, aux


def _account(system, pulse):
    """Per-period increments of the counters: angular impulse per axis (signed and absolute),
    and per thruster the on-time and the number of firings."""
    inc = {"impulse_nms": pulse.level_nm * pulse.t_off_s, "abs_impulse_nms": jnp.abs(pulse.level_nm) * pulse.t_off_s}
    if ACTUATORS[system.structure.actuator].counts_thrusters:
        on = thruster_on_time_s(pulse, AXIS)
        inc["thruster_on_time_s"] = on
        inc["thruster_firings"] = (on > 0.0).astype(on.dtype)
    return inc


def _period(system, carry, batched):
    """One control period. Returns the new carry and the period's (pulse, command, aux)."""
    x, acc, tick = carry
    pulse, u, aux = _command(system, x, tick)
    tpp = system.structure.ticks_per_period
    if tpp == 1:
        x = _integrate_tick(x, pulse, 0.0, system, batched)
    else:
        x = jax.lax.fori_loop(0, tpp, lambda k, xx: _integrate_tick(xx, pulse, k * system.dt_s, system, batched), x)
    acc = jax.tree_util.tree_map(jnp.add, acc, _account(system, pulse))
    return (x, acc, tick + tpp), (pulse, u, aux)


def _sample(system, x, acc, torque, u, aux):
    sample = {"q_bi": x.q_bi, "omega_b": x.omega_b, "command_nm": u, "torque_nm": torque, **acc, **aux}
    if system.structure.gravity != "none":
        sample.update(r_eci=x.r_eci, v_eci=x.v_eci)
    return sample


def _block(system, carry, batched):
    """One record interval: the sample at its start, then ``periods_per_record`` periods.

    The sample holds the state and command at its instant and the mean torque actually
    applied over the whole interval that follows (from the signed impulse accumulated over
    it), so no period is left out of the record.
    """
    x, acc, _ = carry
    carry, (_, u, aux) = _period(system, carry, batched)
    rest = system.structure.periods_per_record - 1
    if rest > 0:
        carry = jax.lax.fori_loop(0, rest, lambda _, c: _period(system, c, batched)[0], carry)
    interval = system.period_s * system.structure.periods_per_record
    torque = (carry[1]["impulse_nms"] - acc["impulse_nms"]) / interval
    return carry, _sample(system, x, acc, torque, u, aux)


@partial(jax.jit, static_argnames=("chunk", "batched"))
def _run_chunk(system, carry, first_record, n_records, chunk, batched=False):
    """``chunk`` record intervals; those at or past ``n_records`` pass the carry through."""
    system = _engine_view(system)

    def body(c, k):
        template = jax.eval_shape(lambda cc: _block(system, cc, batched)[1], c)
        return jax.lax.cond(
            first_record + k < n_records,
            lambda cc: _block(system, cc, batched),
            lambda cc: (cc, jax.tree_util.tree_map(lambda s: jnp.zeros(s.shape, s.dtype), template)),
            c,
        )

    return jax.lax.scan(body, carry, jnp.arange(chunk))


@jax.jit
def _final_sample(system, carry):
    """The sample at the end of the run; its torque is the mean of the period that would follow."""
    system = _engine_view(system)
    x, acc, tick = carry
    pulse, u, aux = _command(system, x, tick)
    return _sample(system, x, acc, pulse_mean_torque(pulse, system.period_s), u, aux)


def _initial_carry(system):
    x0 = jax.tree_util.tree_map(_cm, system.x0)
    x0 = x0._replace(q_bi=quat_normalize(x0.q_bi, AXIS))
    zeros = jax.eval_shape(lambda s: _account(s, ACTUATORS[s.structure.actuator].plan(x0.omega_b, s)), system)
    acc = jax.tree_util.tree_map(lambda s: jnp.zeros(s.shape, s.dtype), zeros)
    return (x0, acc, jnp.zeros((), jnp.int64))


def output_shapes(system):
    """Shape of each recorded output of one sample, interface layout, without compiling.

    Returns
    -------
    dict of str -> tuple
        ``(n_spacecraft, k)`` per spacecraft output, ``(k,)`` for reference outputs.
    """
    shapes = jax.eval_shape(lambda s: _final_sample(s, _initial_carry(s)), system)
    return {k: v.shape if k in _REFERENCE_OUTPUTS else v.shape[::-1] for k, v in shapes.items()}


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
"""Compiled chunk programs of this process, by system structure, leaf shapes, chunk and batching
(least recently used first)."""
_COMPILED_MAX = 32

MAX_CHUNK = 4096
"""Most record intervals per compiled call: bounds the padding of the last chunk (memory)."""

_REFERENCE_OUTPUTS = {"q_ref"}
"""Outputs that are not per spacecraft (no spacecraft axis to move)."""


def _check_finite(samples, t_s, offset, batched, names=None):
    """Raise :class:`NonFiniteStateError` naming the first sample, spacecraft and field."""
    for name in ("q_bi", "omega_b", "r_eci", "v_eci"):
        if name not in samples:
            continue
        a = np.asarray(samples[name])
        bad = ~np.isfinite(a)
        if bad.any():
            idx = np.argwhere(bad)[0]  # ([run,] record, component, spacecraft)
            k = idx[1] if batched else idx[0]
            sc = idx[-1]
            run = f"run {idx[0]}, " if batched else ""
            label = {"q_bi": "attitude q", "omega_b": "rate omega"}.get(name, name)
            who = names[sc] if names is not None else f"spacecraft index {sc}"
            raise NonFiniteStateError(
                f"state became non-finite: {run}{label} of {who} at t = {t_s[offset + k]:g} s "
                "(check gains, control period and step size)"
            )


def simulate(system, n_records, record_interval_s, *, batched=False, progress=False, chunk=None, names=None):
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
    chunk : int, optional
        Record intervals per compiled call. Default: a power of two (so that runs of similar
        length reuse the compiled program) covering the whole run, at most :data:`MAX_CHUNK`,
        or about 1/50 of the run when a progress bar is shown.

    Returns
    -------
    RunOutput

    Raises
    ------
    NonFiniteStateError
        When the state becomes NaN or infinite; the run stops at the chunk where it happened.
    """
    if chunk is None:
        # Powers of two, so that runs of different lengths share compiled programs (the padded
        # record intervals of the last chunk are skipped, not simulated).
        chunk = min(2 ** math.ceil(math.log2(max(1, n_records / 50 if progress else n_records))), MAX_CHUNK)
    n_chunks = math.ceil(n_records / chunk)
    run_chunk = _run_chunk
    final = _final_sample
    init = _initial_carry
    if batched:
        run_chunk = jax.vmap(partial(_run_chunk, batched=True), in_axes=(0, 0, None, None, None))
        final = jax.vmap(_final_sample)
        init = jax.vmap(_initial_carry)
    carry = init(system)
    t_s = np.arange(n_records + 1) * record_interval_s

    # Compile apart from running, so that the two can be reported separately; a program is
    # compiled once per process for each structure, shape and chunk (then JAX's persistent
    # cache serves new processes).
    t0 = time.perf_counter()
    key = (jax.tree_util.tree_structure(system), tuple(jax.ShapeDtypeStruct(jnp.shape(v), jnp.result_type(v))
           for v in jax.tree_util.tree_leaves(system)), chunk, batched)
    compiled = _COMPILED.pop(key, None)
    if compiled is None:
        jitted = jax.jit(run_chunk, static_argnums=(4,)) if batched else _run_chunk
        compiled = jitted.lower(system, carry, 0, n_records, chunk).compile()
    _COMPILED[key] = compiled  # most recently used last
    while len(_COMPILED) > _COMPILED_MAX:
        _COMPILED.pop(next(iter(_COMPILED)))
    compile_s = time.perf_counter() - t0

    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=n_records, unit="rec", delay=2.0, leave=False, desc="simulating")
    chunks = []
    t0 = time.perf_counter()
    try:
        for c in range(n_chunks):
            carry, out = compiled(system, carry, c * chunk, n_records)
            out = jax.tree_util.tree_map(np.asarray, out)
            _check_finite(out, t_s, c * chunk, batched, names)
            chunks.append(out)
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
    samples = {k: v if k in _REFERENCE_OUTPUTS else np.swapaxes(v, -1, -2) for k, v in samples.items()}
    return RunOutput(t_s=t_s, samples=samples, compile_s=compile_s, run_s=run_s)
