"""Actuator commands as pulses within one control period.

Every actuator of this package turns a command into, per spacecraft and body axis, a constant
``level`` (torque, N·m) that acts from the start of the control period until ``t_off`` seconds
into it, and zero afterwards. A continuous (ideal) actuator has ``t_off = period``; a PWM
thruster pair has its on-time. The engine integrates each tick piecewise between the switch
instants, so on-times are honoured exactly rather than rounded to ticks.
"""

from typing import NamedTuple


import jax.numpy as jnp

from coopsat.core.parts import OutputSpec


class Pulse(NamedTuple):
    """Torque pulse of one control period.

    Attributes
    ----------
    level_nm : (n, 3)
        Torque while on, body axes, N·m ((3, n) inside the compiled loop).
    t_off_s : (n, 3)
        Time after the period start at which each axis switches off, s, in [0, period].
    """

    level_nm: jnp.ndarray
    t_off_s: jnp.ndarray


def pulse_mean_torque(pulse, period_s):
    """Mean torque over the period, ``level · t_off / T``, N·m, shape (n, 3)."""
    return pulse.level_nm * (pulse.t_off_s / period_s)


def torque_between(pulse, t_start_s, t_end_s):
    """Torque on the sub-interval ``[t_start, t_end)`` of the period, assumed switch-free.

    Parameters
    ----------
    pulse : Pulse
    t_start_s, t_end_s : array, broadcastable against the pulse's arrays
        Sub-interval bounds measured from the period start, s: shape (n,) for a
        component-major pulse (3, n), (n, 1) for (n, 3).

    Returns
    -------
    jax.Array, shape (n, 3)
        An axis is on iff it switches off after the sub-interval's midpoint.
    """
    mid = 0.5 * (t_start_s + t_end_s)
    return jnp.where(pulse.t_off_s > mid, pulse.level_nm, 0.0)


IMPULSE_OUTPUTS = {
    "angular_impulse": OutputSpec(
        ("component",), "N m s", "body",
        "cumulative signed angular impulse of the actuators per body axis, from t = 0 to the sample",
    ),
    "impulse": OutputSpec(
        ("component",), "N m s", "body",
        "cumulative absolute angular impulse per body axis (actuator effort), from t = 0 to the sample",
    ),
    "torque": OutputSpec(
        ("component",), "N m", "body",
        "mean torque actually applied over the record interval starting at the sample "
        "(last sample: over the control period that would follow)",
    ),
}
"""Recorded outputs of every torque actuator: its impulse counters and mean applied torque."""


def torque_impulse_increments(pulse):
    """Per-period increments of a torque pulse's counters: signed and absolute angular impulse,
    N·m·s, (3, n) each."""
    return {"angular_impulse": pulse.level_nm * pulse.t_off_s, "impulse": jnp.abs(pulse.level_nm) * pulse.t_off_s}
