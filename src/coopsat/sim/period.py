"""One control period of the closed loop.

Per control period (``ticks_per_period`` base ticks), with the parts of a
:class:`~coopsat.sim.system.System` (docs/architecture.md §4):

    sense (sensors) → outbox → deliver (network) → control (flight software)
          → actuate (one pulse per actuator) → update disturbances
          → integrate every tick of the period (:mod:`coopsat.sim.tick`) → account (counters)

Random numbers come only from the run's key: ``fold_in(key, period)``, then a fixed
sub-stream per part. The functions here name no law, actuator or sensor: they call each part's
methods. ``batched``: the plant state and plant are batch-inner and the parts run per run
under ``vmap`` (:mod:`coopsat.sim.layout`).
"""

from dataclasses import replace

import jax
import jax.numpy as jnp

from coopsat.dynamics.plant import STATE_QUANTITIES
from coopsat.sim import native
from coopsat.sim.flight_software import as_flight_software
from coopsat.sim.layout import _inner_axes, _to_inner
from coopsat.sim.tick import _integrate_tick, _quantities

# Sub-streams of a period's random key, one per role, so that adding a sensor never changes
# the draws of another part (jax.random.fold_in of the period key with these numbers + index).
_KEY_CONTROLLER, _KEY_NETWORK, _KEY_SENSORS, _KEY_ACTUATORS, _KEY_DISTURBANCES = 1, 2, 1000, 2000, 3000


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


def _sense_period(system, x, st, tick):
    """The start of a period: its time ``t`` (s), its random key, the measurements ``y`` of
    every spacecraft (component-major), the parts' states after sensing, and each sensor's
    reading to record (``measured_<quantity>``)."""
    t = tick * system.dt_s
    frame = tick // system.structure.ticks_per_period
    key = jax.random.fold_in(system.key, frame)
    y, st = _sense(system, x, st, frame, key, t)
    measured = {f"measured_{s.quantity}": y[s.quantity] for s in system.sensors}
    return t, key, y, st, measured


def _actuate(system, x, st, t, key, cmd, record):
    """The end of a period's control: each actuator plans its pulse for the commands ``cmd``
    (``{name: (3, n)}``; zero for a command the controller does not issue), the disturbances
    update. Returns (pulses, states, record), the record extended with what the actuators
    (from their state at the period's start) and the disturbances record."""
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
    return tuple(pulses), {**st, "actuators": tuple(act_states), "disturbances": d_states}, record


def _command(system, x, st, tick):
    """Sense, deliver, control and actuate at the start of a period.

    Returns (pulses, states, record): one pulse per actuator, the parts' new states, and what
    is recorded at this instant: each sensor's reading (``measured_<quantity>``), and what the
    network, the controller, the actuators (from their state at the period's start) and the
    disturbances record. Software in the loop (:mod:`coopsat.workflows.sil`) runs the same
    steps with the flight software in other processes.
    """
    t, key, y, st, measured = _sense_period(system, x, st, tick)
    ctrl = as_flight_software(system.controller, system.structure.n_spacecraft)
    outbox = ctrl.outbox(y, st["controller"])
    inbox, net_state, net_record = system.network.deliver(
        tick, outbox, st["network"], jax.random.fold_in(key, _KEY_NETWORK)
    )
    cmd, ctrl_state, record = native.control_step(
        system, ctrl, t, y, inbox, st["controller"], jax.random.fold_in(key, _KEY_CONTROLLER)
    )
    st = {**st, "controller": ctrl_state, "network": net_state}
    return _actuate(system, x, st, t, key, cmd, {**measured, **net_record, **record})


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
    x = _integrate_period(system, x, pulses_now, tick, st["disturbances"], batched)
    acc = jax.tree_util.tree_map(jnp.add, acc, increments)
    return (x, st, acc, tick + system.structure.ticks_per_period), (pulses, record)


def _integrate_period(system, x, pulses, tick, d_states, batched=False):
    """The plant over the period that starts at ``tick``: every base tick under the pulses."""
    tpp = system.structure.ticks_per_period
    t_period = tick * system.dt_s
    if tpp == 1:
        return _integrate_tick(x, pulses, 0.0, t_period, d_states, system, batched)
    return jax.lax.fori_loop(
        0, tpp, lambda k, xx: _integrate_tick(xx, pulses, k * system.dt_s, t_period, d_states, system, batched), x
    )

