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

The stages are public (:mod:`coopsat.sim.stepping` gathers them): the compiled loop composes
them here and in :mod:`coopsat.sim.programs`, and software in the loop runs the same ones with
the flight software cut out.
"""

from dataclasses import replace
from typing import NamedTuple

import jax
import jax.numpy as jnp

from coopsat.dynamics.plant import STATE_QUANTITIES, PlantState
from coopsat.sim import native
from coopsat.sim.flight_software import as_flight_software
from coopsat.sim.layout import _inner_axes, _to_inner
from coopsat.sim.tick import _integrate_tick, _quantities

# Sub-streams of a period's random key, one per role, so that adding a sensor never changes
# the draws of another part (jax.random.fold_in of the period key with these numbers + index).
_KEY_CONTROLLER, _KEY_NETWORK, _KEY_SENSORS, _KEY_ACTUATORS, _KEY_DISTURBANCES = 1, 2, 1000, 2000, 3000


class PeriodState(NamedTuple):
    """The closed loop at a control period's start: the carry of the compiled scan.

    A pytree whose leaves are, in order, the plant state's, the parts' states', the counters'
    and the tick: what the scan carries, and what a batch's ``vmap`` axes
    (:data:`coopsat.sim.batching.CARRY_AXES`) follow field by field.

    Attributes
    ----------
    x : PlantState
        The true plant state, component-major ``(k, n)`` (batch-inner inside a batch's chunk).
    parts : dict
        Each part's state: ``controller``, ``network`` (``()`` until the network's history is
        filled), ``sensors`` and ``held`` (each sensor's reading held between its updates),
        ``actuators``, ``disturbances`` (tuples in the system's order).
    counters : dict of str -> (k, n)
        Every actuator's counters summed since t = 0 (impulse, on-time, firings…).
    tick : int64 scalar
        Base ticks since t = 0 (``t = tick · dt_s``).
    """

    x: PlantState
    parts: dict
    counters: dict
    tick: jax.Array


class Sensed(NamedTuple):
    """A control period's start once sensed (:func:`sense`).

    Attributes
    ----------
    t : scalar
        The period's start, s.
    key : PRNG key
        The period's key, ``fold_in(run key, period)`` (each part's stream folds in from it).
    y : dict of str -> (k, n)
        The measurements the flight software reads (docs/architecture.md §4).
    parts : dict
        The parts' states after sensing (as :attr:`PeriodState.parts`).
    measured : dict of str -> (k, n)
        Each sensor's reading to record, ``measured_<quantity>``.
    """

    t: jax.Array
    key: jax.Array
    y: dict
    parts: dict
    measured: dict


def controller_key(key):
    """The controller's key in the period whose key is ``key`` (spacecraft i's flight software
    gets ``fold_in(controller_key(key), i)``)."""
    return jax.random.fold_in(key, _KEY_CONTROLLER)


def network_key(key):
    """The network's key in the period whose key is ``key``."""
    return jax.random.fold_in(key, _KEY_NETWORK)


def truth(system, x):
    """The true state as named quantities, component-major: what ideal sensors read, and what
    a sample records of the plant."""
    return {q: getattr(x, STATE_QUANTITIES[q][0]) for q in _quantities(system)}


def _sense(system, x, st, frame, key, t):
    """Measurements of every spacecraft: the truth, with each sensor's quantity replaced by
    what the sensor reads (held between its updates)."""
    y = truth(system, x)
    states, held = [], []
    for j, (s, s_state, s_held) in enumerate(zip(system.sensors, st["sensors"], st["held"])):
        value, s_state = s.measure(s.truth(y, x, t), x, s_state, jax.random.fold_in(key, _KEY_SENSORS + j))
        if s.every > 1:
            value = jnp.where(frame % s.every == 0, value, s_held)
        y[s.quantity] = value
        states.append(s_state)
        held.append(value)
    return y, {**st, "sensors": tuple(states), "held": tuple(held)}


def sense(system, x, parts, tick):
    """The start of the period at ``tick``: its time, its random key, the measurements of every
    spacecraft, the parts' states after sensing and each sensor's reading to record
    (:class:`Sensed`)."""
    t = tick * system.dt_s
    frame = tick // system.structure.ticks_per_period
    key = jax.random.fold_in(system.key, frame)
    y, parts = _sense(system, x, parts, frame, key, t)
    measured = {f"measured_{s.quantity}": y[s.quantity] for s in system.sensors}
    return Sensed(t, key, y, parts, measured)


def deliver(system, tick, outbox, net_state, key):
    """The network's delivery of ``outbox`` (``{name: (k, n)}``) in the period at ``tick``
    whose key is ``key``: (inbox, the network's new state, its record)."""
    return system.network.deliver(tick, outbox, net_state, network_key(key))


def actuate(system, x, parts, t, key, cmd, record):
    """The end of a period's control: each actuator plans its pulse for the commands ``cmd``
    (``{name: (3, n)}``; zero for a command the controller does not issue), the disturbances
    update. Returns (pulses, parts' states, record), the record extended with what the
    actuators (from their state at the period's start) and the disturbances record."""
    pulses, act_states = [], []
    for j, (a, a_state) in enumerate(zip(system.actuators, parts["actuators"])):
        record = {**record, **a.record(x, a_state)}
        issued = cmd[a.command] if a.command in cmd else jnp.zeros_like(x.omega_b)
        pulse, a_state = a.plan(issued, x, a_state, system.period_s, jax.random.fold_in(key, _KEY_ACTUATORS + j), t)
        pulses.append(pulse)
        act_states.append(a_state)
    d_states = tuple(
        d.update(t, x, d_state, jax.random.fold_in(key, _KEY_DISTURBANCES + j))
        for j, (d, d_state) in enumerate(zip(system.disturbances, parts["disturbances"]))
    )
    for d, d_state in zip(system.disturbances, d_states):
        record = {**record, **d.record(t, x, d_state)}
    return tuple(pulses), {**parts, "actuators": tuple(act_states), "disturbances": d_states}, record


def command(system, x, parts, tick):
    """Sense, deliver, control and actuate at the start of the period at ``tick``.

    Returns (pulses, parts' states, record): one pulse per actuator, the parts' new states, and
    what is recorded at this instant: each sensor's reading (``measured_<quantity>``), and what
    the network, the controller, the actuators (from their state at the period's start) and the
    disturbances record. Software in the loop (:mod:`coopsat.workflows.sil`) runs the same
    stages with the flight software in other processes.
    """
    sensed = sense(system, x, parts, tick)
    ctrl = as_flight_software(system.controller, system.structure.n_spacecraft)
    outbox = ctrl.outbox(sensed.y, sensed.parts["controller"])
    inbox, net_state, net_record = deliver(system, tick, outbox, sensed.parts["network"], sensed.key)
    cmd, ctrl_state, record = native.control_step(
        system, ctrl, sensed.t, sensed.y, inbox, sensed.parts["controller"], controller_key(sensed.key)
    )
    parts = {**sensed.parts, "controller": ctrl_state, "network": net_state}
    return actuate(system, x, parts, sensed.t, sensed.key, cmd, {**sensed.measured, **net_record, **record})


def account(system, pulses):
    """Per-period increments of every actuator's counters (impulse, on-time, firings, bits…)."""
    inc = {}
    for a, p in zip(system.actuators, pulses):
        for k, v in a.account(p).items():
            if k in inc:
                raise ValueError(f"two actuators both count '{k}'; give them distinct outputs")
            inc[k] = v
    return inc


def integrate(system, x, pulses, tick, d_states, batched=False):
    """The plant over the period that starts at ``tick``: every base tick under the pulses."""
    tpp = system.structure.ticks_per_period
    t_period = tick * system.dt_s
    if tpp == 1:
        return _integrate_tick(x, pulses, 0.0, t_period, d_states, system, batched)
    return jax.lax.fori_loop(
        0, tpp, lambda k, xx: _integrate_tick(xx, pulses, k * system.dt_s, t_period, d_states, system, batched), x
    )


def advance(system, state, parts, pulses, increments, batched=False):
    """The :class:`PeriodState` at the next period's start: the plant integrated over the
    period under ``pulses`` (with the disturbances of ``parts``), the counters advanced by
    ``increments`` (:func:`account`), ``parts`` the parts' states."""
    x = integrate(system, state.x, pulses, state.tick, parts["disturbances"], batched)
    counters = jax.tree_util.tree_map(jnp.add, state.counters, increments)
    return PeriodState(x, parts, counters, state.tick + system.structure.ticks_per_period)


def _per_run(fn, system, *args, in_axes, out_axes=0):
    """``fn(system, *args)`` for every run of a batch: ``jax.vmap`` over the parts (batch-first)
    with the plant left out (it is in the batch-inner layout; no part reads it)."""
    runs = replace(system, plant=None)
    axes = replace(jax.tree_util.tree_map(lambda _: 0, runs), dt_s=None)
    return jax.vmap(fn, in_axes=(axes, *in_axes), out_axes=out_axes)(runs, *args)


def _period(system, state, batched):
    """One control period. Returns the next :class:`PeriodState` and the period's (pulses, record).

    ``batched``: the plant state and ``system.plant`` are in the batch-inner layout, every
    other leaf batch-first (:func:`~coopsat.sim.programs._run_chunk_batched`); the parts run per
    run under ``vmap`` and the plant is integrated for all runs at once.
    """
    if batched:
        pulses, parts, record = _per_run(command, system, state.x, state.parts, state.tick,
                                         in_axes=(_inner_axes(state.x), 0, None))
        increments = _per_run(account, system, pulses, in_axes=(0,))
        pulses_now = jax.tree_util.tree_map(_to_inner, pulses)
    else:
        pulses, parts, record = command(system, state.x, state.parts, state.tick)
        increments = account(system, pulses)
        pulses_now = pulses
    return advance(system, state, parts, pulses_now, increments, batched), (pulses, record)
