"""Proportional thrusters with a dead zone (SPEC §4: 1–100 mN per axis, no thrust below 1 mN)."""


import jax.numpy as jnp


def deadzone_thrust(force_cmd_n, force_min_n, force_max_n):
    """Force delivered per axis, N.

    Parameters
    ----------
    force_cmd_n : array_like, shape (3, n) (any shape)
        Commanded force per axis, N.
    force_min_n : scalar or array broadcastable to ``force_cmd_n``
        Smallest force a thruster can produce, N: ``|f| < force_min_n`` gives 0, and
        ``|f| = force_min_n`` fires.
    force_max_n : scalar or array broadcastable to ``force_cmd_n``
        Largest force, N: larger commands are clipped to ``±force_max_n``.

    Returns
    -------
    jax.Array, shape of ``force_cmd_n``
    """
    return jnp.where(jnp.abs(force_cmd_n) < force_min_n, 0.0, jnp.clip(force_cmd_n, -force_max_n, force_max_n))
