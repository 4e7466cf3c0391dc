"""Proportional thrusters with a dead zone (SPEC §4: 1–100 mN per axis)."""

import numpy as np
import pytest

from coopsat.actuators.thrusters import deadzone_thrust

F_MIN, F_MAX = 1e-3, 0.1  # N


@pytest.mark.parametrize(
    "f_cmd, expected",
    [
        (0.0, 0.0),
        (0.5e-3, 0.0),  # inside the dead zone
        (-0.999e-3, 0.0),
        (1e-3, 1e-3),  # exactly f_min: fires
        (-1e-3, -1e-3),
        (0.05, 0.05),  # proportional
        (-0.0734, -0.0734),
        (0.1, 0.1),  # exactly f_max
        (0.25, 0.1),  # clipped
        (-3.0, -0.1),
    ],
)
def test_hand_values(f_cmd, expected):
    assert float(deadzone_thrust(np.array(f_cmd), F_MIN, F_MAX)) == expected


def test_shape_and_per_axis_limits():
    f = np.array([[0.0005, 0.002, -0.2], [0.003, -0.0025, 0.04], [-0.5, 0.0, 0.009]])  # (3, n)
    out = np.asarray(deadzone_thrust(f, np.array([[1e-3], [3e-3], [1e-3]]), np.array([[0.1], [0.1], [0.005]])))
    np.testing.assert_array_equal(out, [[0.0, 0.002, -0.1], [0.003, 0.0, 0.04], [-0.005, 0.0, 0.005]])
