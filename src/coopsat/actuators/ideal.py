"""Ideal torque actuator: the commanded torque, clipped per axis, held over the period."""

from coopsat import _jax  # noqa: F401

import jax.numpy as jnp

from coopsat.actuators.pulses import Pulse


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
