"""Reaction wheels: spin axes, torque limit and speed limit (SPEC §5).

Each wheel ``k`` spins about the unit body vector ``g_k``, the column ``k`` of ``G`` (3, m), and
stores the angular momentum ``h_k`` (N·m·s, relative to the body) along it. A motor torque
``τ_k`` changes ``h_k`` at the rate ``ḣ_k = τ_k``; the wheels' momentum in body axes is ``G h``
and, by reaction, the body receives ``−G τ``: with ``ḣ_w = G τ`` the rigid-body equation
``I ω̇ + ω × (I ω + h_w) = τ_ext − ḣ_w`` (docs/conventions.md).

Arrays are component-major: body vectors (3, n), per-wheel quantities (m, n).
"""


import jax.numpy as jnp
import numpy as np

THREE_AXIS_PLUS_SKEW_B = np.column_stack([np.eye(3), np.ones(3) / np.sqrt(3.0)])
"""Spin axes ``G`` (3, 4) of SPEC §5: one wheel on each body axis and one along (1, 1, 1)/√3."""


def wheel_motor_torque(torque_cmd_b_nm, h_wheels_nms, spin_axes_b, spin_axes_pinv, torque_max_nm, h_max_nms):
    """Motor torque of each wheel that puts the commanded torque on the body, within the limits.

    Parameters
    ----------
    torque_cmd_b_nm : array_like, shape (3, n)
        Torque the controller wants on the body, body axes, N·m.
    h_wheels_nms : array_like, shape (m, n)
        Momentum of each wheel along its spin axis, N·m·s.
    spin_axes_b : array_like, shape (3, m)
        ``G``: unit spin axes as columns, body components.
    spin_axes_pinv : array_like, shape (m, 3)
        ``G⁺``, the Moore–Penrose pseudo-inverse of ``G`` (``np.linalg.pinv``, computed once at
        design time).
    torque_max_nm : scalar or array_like, shape (m, 1)
        Motor torque limit per wheel, N·m.
    h_max_nms : scalar or array_like, shape (m, 1)
        Momentum limit per wheel, ``I_wheel · ω_max``, N·m·s (per wheel: the skewed wheel of
        SPEC §5 has its own rated speed).

    Returns
    -------
    tau_wheels_nm : jax.Array, shape (m, n)
        Motor torque per wheel, N·m: ``−G⁺ u``, the minimum-norm solution of ``−G τ = u``;
        then clipped to ``±torque_max_nm``, and zeroed where the wheel is at or beyond
        ``±h_max_nms`` and the torque would drive it further out (it may still slow down).
    h_dot_wheels_b_nms : jax.Array, shape (3, n)
        ``G τ``, the rate of the wheels' momentum in body axes, N·m; the body receives its
        negative, which equals ``u`` when no limit is active.

    Notes
    -----
    The speed limit is tested at the sample, so a wheel just inside it may overshoot by at most
    ``torque_max_nm`` × the hold time. A limited wheel is not compensated by the others: the
    body torque then differs from ``u`` and the controller sees it in the next sample.
    """
    tau = jnp.clip(-(spin_axes_pinv @ torque_cmd_b_nm), -torque_max_nm, torque_max_nm)
    saturated = ((h_wheels_nms >= h_max_nms) & (tau > 0.0)) | ((h_wheels_nms <= -h_max_nms) & (tau < 0.0))
    tau = jnp.where(saturated, 0.0, tau)
    return tau, spin_axes_b @ tau


def wheel_momentum_b(h_wheels_nms, spin_axes_b):
    """Wheels' angular momentum in body axes, ``G h``, N·m·s; (m, n) -> (3, n).

    Parameters
    ----------
    h_wheels_nms : array_like, shape (m, n) or (m,)
        Momentum of each wheel along its spin axis, N·m·s.
    spin_axes_b : array_like, shape (3, m)
        ``G``: unit spin axes as columns, body components.
    """
    return spin_axes_b @ h_wheels_nms
