"""PWM on-time law, eq. (10) of the 2010 consensus paper, at its three branches."""

import numpy as np
import pytest

from coopsat.actuators.pulses import Pulse, pulse_mean_torque, torque_between
from coopsat.actuators.pwm import THRUSTER_NAMES, pwm_on_time_s, pwm_pulse, thruster_on_time_s

T, T_MAX, TAU = 0.5, 0.05, 0.05


@pytest.mark.parametrize(
    "u, expected",
    [
        (0.05, 0.5),  # T|u|/T_max = T: saturated, fires the whole period
        (-0.2, 0.5),  # beyond saturation
        (0.02, 0.2),  # proportional band: T|u|/T_max = 0.2 s
        (0.0049, 0.0),  # just below the minimum pulse: nothing
        (0.0, 0.0),
    ],
)
def test_on_time_branches(u, expected):
    assert float(pwm_on_time_s(np.array([[u, 0.0, 0.0]]), T, T_MAX, TAU)[0, 0]) == pytest.approx(expected, abs=1e-15)


def test_exactly_the_minimum_pulse_fires():
    """At T|u|/T_max = τ the pulse fires (eq. (10)'s ≥), a hair below it does not. Dyadic values,
    so that T·|u|/T_max is exact in any order a compiler evaluates it: with the paper's numbers
    (0.5·0.005/0.05) the IEEE result is 0.049999999999999996, below τ = 0.05, and jax 0.10 and
    0.12 round that expression differently (0.05 and 0.049999999999999996)."""
    t_on = pwm_on_time_s(np.array([[-0.0625, 0.0625 * (1 - 2.0**-40), 0.0]]), 0.5, 0.25, 0.125)
    assert float(t_on[0, 0]) == 0.125
    assert float(t_on[0, 1]) == 0.0


def test_proportional_band_delivers_the_commanded_impulse():
    u = np.array([[0.01, -0.03, 0.045]])
    pulse = pwm_pulse(u, T, T_MAX, TAU)
    np.testing.assert_allclose(pulse_mean_torque(pulse, T), u, rtol=1e-14)


def test_sign_and_thruster_accounting():
    pulse = pwm_pulse(np.array([[0.02, -0.03, 0.0]]), T, T_MAX, TAU)
    np.testing.assert_array_equal(np.sign(pulse.level_nm), [[1, -1, 0]])
    on = np.asarray(thruster_on_time_s(pulse))
    assert THRUSTER_NAMES == ("+x", "-x", "+y", "-y", "+z", "-z")
    np.testing.assert_allclose(on, [[0.2, 0.0, 0.0, 0.3, 0.0, 0.0]])
    # Component-major layout gives the same numbers transposed.
    pulse_cm = Pulse(pulse.level_nm.T, pulse.t_off_s.T)
    np.testing.assert_allclose(np.asarray(thruster_on_time_s(pulse_cm, axis=0)), on.T)


def test_torque_between_switches_at_the_on_time():
    pulse = pwm_pulse(np.array([[0.02, -0.03, 0.05]]), T, T_MAX, TAU)
    before = np.asarray(torque_between(pulse, np.array([[0.1]]), np.array([[0.15]])))
    after = np.asarray(torque_between(pulse, np.array([[0.25]]), np.array([[0.28]])))
    np.testing.assert_allclose(before, [[0.05, -0.05, 0.05]])
    np.testing.assert_allclose(after, [[0.0, -0.05, 0.05]])
