"""PWM on/off thrusters: one ± thruster pair per body axis, fixed torque, minimum pulse.

2010 consensus paper, eq. (10) (SPEC §1): a commanded torque u on an axis gives the on-time

* ``t_on = T``           if ``T|u|/T_max ≥ T``  (saturated),
* ``t_on = T|u|/T_max``  if ``τ ≤ T|u|/T_max < T``  (proportional band: same impulse as u·T),
* ``t_on = 0``           if ``T|u|/T_max < τ``  (below the minimum pulse),

and the thruster of sign(u) fires for the first ``t_on`` of the period.
"""


import jax.numpy as jnp

from coopsat.core.parts import OutputSpec, part
from coopsat.actuators.pulses import IMPULSE_OUTPUTS, Pulse, torque_impulse_increments

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


@part(static=("command",))
class PwmThrusters:
    """PWM thruster part: a ± pair per body axis, eq. (10), switching inside the period.

    Attributes
    ----------
    torque_max_nm : scalar
        Torque of one thruster pair T_max, N·m.
    min_pulse_s : scalar
        Minimum pulse τ, s.
    command : str
        Static: the controller command it executes.
    """

    torque_max_nm: jnp.ndarray
    min_pulse_s: jnp.ndarray
    command: str = "torque_b"

    channel = "torque_b"
    pulsed = True
    mean_output = ("torque", "angular_impulse")

    def init(self, n):
        return ()

    def plan(self, command, x, state, period_s, key, t=0.0):
        return pwm_pulse(command, period_s, self.torque_max_nm, self.min_pulse_s), state

    def record(self, x, state):
        return {}

    def account(self, pulse):
        """Impulse counters, and per thruster the on-time and whether it fired this period."""
        on = thruster_on_time_s(pulse, 0)
        return {**torque_impulse_increments(pulse), "thruster_on_time": on, "thruster_firings": (on > 0.0).astype(jnp.int64)}

    def output_specs(self):
        thrusters = (("thruster", THRUSTER_NAMES),)
        return {
            **IMPULSE_OUTPUTS,
            "thruster_on_time": OutputSpec(
                ("thruster",), "s", "", "cumulative on-time of each thruster, from t = 0 to the sample", coords=thrusters
            ),
            "thruster_firings": OutputSpec(
                ("thruster",), "1", "", "cumulative number of firings (control periods with a pulse) of each thruster",
                coords=thrusters,
            ),
        }
