"""MEMS micro-thrusters that deliver whole impulse bits (SPEC §2: 1e-5 N·s per bit, per axis).

Each control period the wanted impulse per axis is quantised to a whole number of bits, and the
bits are fired as one pulse of the thruster's force from the start of the period. The rounding
error is carried to the next period (first-order sigma-delta), so that over any run of unsaturated
periods the delivered impulse follows the commanded impulse to within half a bit.
"""


import jax.numpy as jnp


def quantise_impulse(impulse_cmd_ns, remainder_ns, bit_ns, max_bits):
    """Whole impulse bits to fire this period, and the remainder to carry to the next.

    Parameters
    ----------
    impulse_cmd_ns : array_like, shape (3, n) (any shape)
        Impulse wanted this period per axis, N·s (commanded force × period).
    remainder_ns : array_like, shape of ``impulse_cmd_ns``
        Carried from the previous period, N·s (zero at the start); always within ±bit/2.
    bit_ns : scalar
        Impulse of one bit, N·s.
    max_bits : scalar or array broadcastable to ``impulse_cmd_ns``
        Most bits one axis can fire in one period (``inf``: no limit).

    Returns
    -------
    bits : jax.Array, shape of ``impulse_cmd_ns``
        Signed bit count per axis: float64 holding whole numbers, so that it multiplies with
        ``bit_ns`` and accumulates in the loop's one dtype (exact up to 2⁵³ bits).
    new_remainder_ns : jax.Array, shape of ``impulse_cmd_ns``
        ``wanted − round(wanted/bit)·bit`` with ``wanted = impulse_cmd + remainder``, N·s.

    Notes
    -----
    Rounding is to the nearest whole bit, ties to even (``jnp.round``): symmetric in sign, and
    it keeps the remainder within ±bit/2.

    Clipping to ``±max_bits`` happens after the rounding, and the clipped excess is dropped,
    not carried: the remainder holds only the rounding error. Carrying the excess would
    accumulate without bound during a long saturation and discharge afterwards, the wind-up of
    an integrator; the feedback controller already sees the state error a saturated period
    leaves and commands it again.
    """
    wanted_bits = (impulse_cmd_ns + remainder_ns) / bit_ns
    rounded_bits = jnp.round(wanted_bits)
    bits = jnp.clip(rounded_bits, -max_bits, max_bits)
    return bits, (wanted_bits - rounded_bits) * bit_ns


def bits_pulse(bits, bit_ns, thrust_n):
    """Force pulse that delivers ``bits`` whole bits: ``±thrust_n`` from the period start.

    Parameters
    ----------
    bits : array_like, shape (3, n) (any shape)
        Signed bit count per axis, whole numbers (from :func:`quantise_impulse`).
    bit_ns : scalar
        Impulse of one bit, N·s.
    thrust_n : scalar
        Force of a firing thruster, N.

    Returns
    -------
    level_n : jax.Array, shape of ``bits``
        ``sign(bits)·thrust_n``, N (zero when no bit fires).
    t_on_s : jax.Array, shape of ``bits``
        ``|bits|·bit_ns/thrust_n``, s, so that ``level_n·t_on_s = bits·bit_ns``. It must not
        exceed the control period: choose ``max_bits ≤ period·thrust/bit``.
    """
    return jnp.sign(bits) * thrust_n, jnp.abs(bits) * bit_ns / thrust_n
