"""Ideal torque actuator: the commanded torque, clipped per axis, held over the period."""


import jax.numpy as jnp

from coopsat.core.parts import part
from coopsat.actuators.smooth import soft_clip
from coopsat.actuators.pulses import IMPULSE_OUTPUTS, Pulse, torque_impulse_increments


def ideal_torque_pulse(command_nm, period_s, torque_max_nm):
    """Zero-order hold of the command, saturated at ``±torque_max_nm`` per body axis.

    Parameters
    ----------
    command_nm : array, shape (n, 3)
    period_s : scalar
    torque_max_nm : scalar or (n, 3)
        ``inf`` for no saturation.

    Returns
    -------
    Pulse
    """
    level = jnp.clip(command_nm, -torque_max_nm, torque_max_nm)
    return Pulse(level, jnp.full_like(level, period_s))


@part(static=("command",))
class IdealTorque:
    """Torque actuator part: the commanded body torque, saturated per axis, held over the period.

    Attributes
    ----------
    torque_max_nm : scalar
        Saturation per body axis, N·m (``inf``: none).
    command : str
        Static: the controller command it executes.
    """

    torque_max_nm: jnp.ndarray
    command: str = "torque_b"

    channel = "torque_b"
    pulsed = False
    mean_output = ("torque", "angular_impulse")

    def init(self, n):
        return ()

    def plan(self, command, x, state, period_s, key, t=0.0):
        return ideal_torque_pulse(command, period_s, self.torque_max_nm), state

    def record(self, x, state):
        return {}

    def account(self, pulse):
        return torque_impulse_increments(pulse)

    def surrogate(self):
        """The smooth stand-in used for gradients, and what it is."""
        return SmoothIdealTorque(self.torque_max_nm, self.command), "ideal torque: saturation rounded over 0.01·torque_max_nm (softplus)"

    def output_specs(self):
        return dict(IMPULSE_OUTPUTS)


@part(static=("command",))
class SmoothIdealTorque(IdealTorque):
    """:class:`IdealTorque` with its saturation rounded over 0.01·torque_max_nm, for gradients
    only (``coopsat tune``; :func:`~coopsat.actuators.smooth.soft_clip`)."""

    def plan(self, command, x, state, period_s, key, t=0.0):
        level = soft_clip(command, self.torque_max_nm, 0.01 * self.torque_max_nm)
        return Pulse(level, jnp.full_like(level, period_s)), state
