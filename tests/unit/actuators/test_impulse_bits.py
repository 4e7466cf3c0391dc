"""Impulse-bit quantisation with a carried remainder, and the pulse that fires the bits (SPEC §2)."""

import numpy as np
import pytest

from coopsat.actuators.impulse_bits import bits_pulse, quantise_impulse

BIT = 1e-5  # N·s


def run_periods(commands_ns, max_bits=np.inf):
    """Quantise a sequence of per-period commands (periods first), carrying the remainder."""
    remainder = np.zeros_like(commands_ns[0])
    bits_all, rem_all = [], []
    for cmd in commands_ns:
        bits, remainder = quantise_impulse(cmd, remainder, BIT, max_bits)
        bits_all.append(np.asarray(bits))
        rem_all.append(np.asarray(remainder))
    return np.array(bits_all), np.array(rem_all)


def test_whole_bits_and_remainder_within_half_a_bit():
    rng = np.random.default_rng(3)
    bits, rem = run_periods(rng.normal(scale=3 * BIT, size=(200, 3, 4)))
    assert bits.dtype == np.float64
    np.testing.assert_array_equal(bits, np.round(bits))
    assert np.max(np.abs(rem)) <= 0.5 * BIT * (1 + 1e-12)


def test_delivered_impulse_tracks_the_commanded_sum_within_one_bit():
    rng = np.random.default_rng(4)
    commands = rng.uniform(-2.5 * BIT, 2.5 * BIT, size=(500, 3, 2))
    bits, _ = run_periods(commands)
    gap = np.cumsum(commands, axis=0) - BIT * np.cumsum(bits, axis=0)
    # At every period, not just at the end: the gap is the carried remainder.
    assert np.max(np.abs(gap)) <= 0.5 * BIT * (1 + 1e-9)


def test_four_tenths_of_a_bit_gives_two_bits_every_five_periods():
    bits, _ = run_periods(np.full((50, 3, 1), 0.4 * BIT))
    per_window = bits[:, 0, 0].reshape(10, 5).sum(axis=1)
    np.testing.assert_array_equal(per_window, 2.0)
    np.testing.assert_array_equal(bits[:5, 0, 0], [0, 1, 0, 1, 0])
    # Symmetric in sign.
    neg, _ = run_periods(np.full((50, 3, 1), -0.4 * BIT))
    np.testing.assert_array_equal(neg, -bits)


def test_rounding_to_nearest_ties_to_even():
    bits, rem = quantise_impulse(np.array([0.49, 0.51, 0.5, 1.5, -2.5, -0.5]) * BIT, 0.0, BIT, np.inf)
    np.testing.assert_array_equal(bits, [0, 1, 0, 2, -2, 0])
    np.testing.assert_allclose(np.asarray(rem) / BIT, [0.49, -0.49, 0.5, -0.5, -0.5, -0.5], atol=1e-12)


def test_clipping_drops_the_excess_and_carries_only_the_rounding_error():
    # Wanted 7.3 bits with a 5-bit limit: fire 5, carry 0.3 bit (the rounding error), drop 2.
    bits, rem = quantise_impulse(np.array([7.0, -7.0]) * BIT, np.array([0.3, -0.3]) * BIT, BIT, 5.0)
    np.testing.assert_array_equal(bits, [5.0, -5.0])
    np.testing.assert_allclose(np.asarray(rem) / BIT, [0.3, -0.3], atol=1e-12)
    # A long saturation does not wind up: once the command falls to zero, firing stops at once.
    bits_seq, _ = run_periods(np.concatenate([np.full((20, 1), 12 * BIT), np.zeros((5, 1))]), max_bits=5.0)
    np.testing.assert_array_equal(bits_seq[:20, 0], 5.0)
    np.testing.assert_array_equal(bits_seq[20:, 0], 0.0)
    # Per-axis limits broadcast.
    bits, _ = quantise_impulse(np.full((3, 2), 9 * BIT), np.zeros((3, 2)), BIT, np.array([[1.0], [4.0], [20.0]]))
    np.testing.assert_array_equal(bits, [[1, 1], [4, 4], [9, 9]])


def test_pulse_delivers_exactly_the_bits():
    thrust = 2e-3  # N
    bits = np.array([[3.0, 0.0], [-7.0, 1.0], [12.0, -1.0]])
    level, t_on = (np.asarray(a) for a in bits_pulse(bits, BIT, thrust))
    np.testing.assert_array_equal(np.abs(level[bits != 0]), thrust)
    np.testing.assert_array_equal(np.sign(level), np.sign(bits))
    np.testing.assert_array_equal(t_on[bits == 0], 0.0)
    np.testing.assert_allclose(level * t_on, bits * BIT, rtol=1e-15, atol=0.0)
    np.testing.assert_allclose(t_on[2, 0], 12 * BIT / thrust, rtol=1e-15)  # 0.06 s
    # The integral of the pulse over a fine grid of the period agrees (midpoint rule).
    period, steps = 0.1, 100_000
    t = (np.arange(steps) + 0.5) * (period / steps)
    integral = np.sum(np.where(t[:, None, None] < t_on, level, 0.0), axis=0) * (period / steps)
    np.testing.assert_allclose(integral, bits * BIT, rtol=0.0, atol=thrust * period / steps)


@pytest.mark.parametrize("bits", [0.0, 1.0, -1.0])
def test_pulse_of_zero_and_single_bits(bits):
    level, t_on = bits_pulse(np.array([bits]), BIT, 1e-3)
    assert float(level[0] * t_on[0]) == pytest.approx(bits * BIT, abs=1e-20)


def test_dropping_the_remainder_never_fires_below_half_a_bit_and_rounds_each_period_alone():
    from coopsat.actuators.force_thrusters import ImpulseBitThrusters

    carry = ImpulseBitThrusters(np.asarray(1e-5), np.asarray(1e-3), np.asarray(np.inf), carry=True)
    drop = ImpulseBitThrusters(np.asarray(1e-5), np.asarray(1e-3), np.asarray(np.inf), carry=False)
    # 0.4 bit per period: carried, it fires 2 bits every 5 periods; dropped, never.
    command = np.full((3, 1), 0.4e-5)  # N over a 1 s period
    fired = {}
    for name, part in (("carry", carry), ("drop", drop)):
        state, total = part.init(1), 0.0
        for _ in range(50):
            pulse, state = part.plan(command, None, state, 1.0, None)
            total += float(np.asarray(part.account(pulse)["impulse_bits"])[0, 0])
        fired[name] = total
        if name == "drop":
            np.testing.assert_array_equal(np.asarray(state), 0.0)
    assert fired == {"carry": 20.0, "drop": 0.0}
    # 0.6 bit per period rounds to one bit every period when dropped: 50 bits for 30 wanted.
    state, total = drop.init(1), 0.0
    for _ in range(50):
        pulse, state = drop.plan(np.full((3, 1), 0.6e-5), None, state, 1.0, None)
        total += float(np.asarray(drop.account(pulse)["impulse_bits"])[0, 0])
    assert total == 50.0
