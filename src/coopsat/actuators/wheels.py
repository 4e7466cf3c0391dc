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


def wheel_motor_torque(torque_cmd_b_nm, spin_axes_pinv, torque_max_nm):
    """Motor torque of each wheel that puts the commanded torque on the body, within the torque
    limit; (3, n) -> (m, n) N·m.

    Parameters
    ----------
    torque_cmd_b_nm : array_like, shape (3, n)
        Torque the controller wants on the body, body axes, N·m.
    spin_axes_pinv : array_like, shape (m, 3)
        ``G⁺``, the Moore–Penrose pseudo-inverse of ``G`` (``np.linalg.pinv``, computed once at
        design time).
    torque_max_nm : scalar or array_like, shape (m, 1)
        Motor torque limit per wheel, N·m.

    Returns
    -------
    tau_wheels_nm : jax.Array, shape (m, n)
        ``−G⁺ u``, the minimum-norm solution of ``−G τ = u``, clipped to ``±torque_max_nm``.

    Notes
    -----
    A clipped wheel is not compensated by the others: the body torque then differs from ``u``
    and the controller sees it in the next sample. The speed limit is the drive's
    (:func:`speed_limited_torque`), applied to this torque and any speed-loop error.
    """
    return jnp.clip(-(spin_axes_pinv @ torque_cmd_b_nm), -torque_max_nm, torque_max_nm)


def speed_limited_torque(tau_wheels_nm, h_wheels_nms, h_max_nms, hold_s):
    """The drive's speed limit: each wheel's motor torque, held for ``hold_s``, cut so that the
    wheel ends the hold within ``±h_max_nms``.

    Parameters
    ----------
    tau_wheels_nm : array_like, shape (m, n)
        Motor torque the drive would apply, N·m.
    h_wheels_nms : array_like, shape (m, n)
        Momentum of each wheel relative to the body (``I_k Ω_k``) at the start of the hold, N·m·s.
    h_max_nms : scalar or array_like, shape (m, 1)
        Momentum limit per wheel, ``I_k · Ω_max,k``, N·m·s (per wheel: the skewed wheel of
        SPEC §5 has its own rated speed).
    hold_s : scalar
        How long the torque is held (the control period), s.

    Returns
    -------
    tau_wheels_nm : jax.Array, shape (m, n)
        ``tau_wheels_nm`` clipped to ``[(−h_max − h)/hold_s, (h_max − h)/hold_s]``; bit for bit
        the input where that holds already.
    limited : jax.Array of bool, shape (m, n)
        The drive cut the torque (it would have taken the wheel past its rated speed).

    Notes
    -----
    A real drive regulates speed: a torque that would spin the wheel past its rated speed is
    cut, so the wheel runs up to the limit and stays there. Testing the limit only at the
    sample only lets a wheel just inside it overshoot by up to
    ``torque_max`` × the hold, about 2 % for SPEC §5's wheels at 10 Hz; cutting the torque to
    what is left of the limit over the hold stops the wheel at it, to rounding. What the
    drive cannot foresee is the body's rate change during the hold, which moves the speed
    relative to the body by ``g_k·Δω`` (2e-6 to 1e-5 of the limit in the observation runs):
    a wheel found beyond the limit is braked back over the next hold. Torque away from the
    limit is untouched.
    """
    upper = (h_max_nms - h_wheels_nms) / hold_s
    lower = (-h_max_nms - h_wheels_nms) / hold_s
    return jnp.clip(tau_wheels_nm, lower, upper), (tau_wheels_nm > upper) | (tau_wheels_nm < lower)


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
