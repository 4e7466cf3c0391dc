"""PWM on/off thrusters: one ± thruster pair per body axis, fixed torque, minimum pulse.

2010 consensus paper, eq. (10) (SPEC §1): a commanded torque u on an axis gives the on-time

* ``t_on = T``           if ``T|u|/T_max ≥ T``  (saturated),
* ``t_on = T|u|/T_max``  if ``τ ≤ T|u|/T_max < T``  (proportional band: same impulse as u·T),
* ``t_on = 0``           if ``T|u|/T_max < τ``  (below the minimum pulse),

and the thruster of sign(u) fires for the first ``t_on`` of the period.
"""

from coopsat import _jax  # noqa: F401

import jax.numpy as jnp

from coopsat.actuators.pulses import Pulse

THRUSTER_NAMES = ("+x", "-x", "+y", "-y", "+z", "-z")
"""Thruster order of the ``thruster`` dimension: the pair of each body axis, + first."""


def pwm_on_time_s(command_nm, period_s, torque_max_nm, min_pulse_s):
    """On-time per axis from eq. (10), s; shape (n, 3) -> (n, 3).

    Parameters
    ----------
    command_nm : array, shape (n, 3)
        Commanded torque per body axis, N·m.
    period_s : scalar
        PWM (= control) period T, s.
    torque_max_nm : scalar
        Torque of one thruster pair, N·m.
    min_pulse_s : scalar
        Minimum pulse width τ, s.
    """
    t_req = period_s * jnp.abs(command_nm) / torque_max_nm
    return jnp.where(t_req >= period_s, period_s, jnp.where(t_req >= min_pulse_s, t_req, 0.0))


def pwm_pulse(command_nm, period_s, torque_max_nm, min_pulse_s):
    """Thruster pulse for one period: ``±T_max`` for the eq. (10) on-time. Returns :class:`Pulse`."""
    t_on = pwm_on_time_s(command_nm, period_s, torque_max_nm, min_pulse_s)
    return Pulse(jnp.sign(command_nm) * torque_max_nm, t_on)


def thruster_on_time_s(pulse, axis=-1):
    """On-time of each of the six thrusters in this period, s; (n, 3) pulse -> (n, 6).

    Ordered as :data:`THRUSTER_NAMES`: for each axis the + thruster, then the − thruster.
    With ``axis=0`` (component-major) the shapes are (3, n) -> (6, n).
    """
    plus = jnp.where(pulse.level_nm > 0.0, pulse.t_off_s, 0.0)
    minus = jnp.where(pulse.level_nm < 0.0, pulse.t_off_s, 0.0)
    if axis == 0:
        return jnp.stack([plus, minus], axis=1).reshape(6, *plus.shape[1:])
    return jnp.stack([plus, minus], axis=-1).reshape(*plus.shape[:-1], 6)
