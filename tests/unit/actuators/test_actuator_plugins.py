"""Force and wheel actuator plug-ins, through real scenarios: impulse-bit thrusters,
proportional thrusters and reaction wheels."""

import math

import numpy as np
import pytest

from coopsat.analysis.metrics import inertial_angular_momentum_nms
from coopsat.geometry.frames import lvlh_dcm
from coopsat.workflows.pipeline import prepare
from coopsat.scenarios.load import ScenarioError, load_scenario

A_M = 6878137.0  # 500 km circular orbit
BIT_NS = 1e-5


def _formation(n_spacecraft, mass_kg, controller, actuators, t_final_s=3.0, period_s=0.1):
    """n spacecraft on the same circular orbit, at the same point (sat1 is the chief)."""
    craft = "".join(
        f'\n[[spacecraft]]\nname = "sat{k + 1}"\nelements = {{ a_m = {A_M}, i_deg = 45.0, raan_deg = 20.0 }}\n'
        for k in range(n_spacecraft)
    )
    return f"""
name = "force-actuators"
[sim]
t_final_s = {t_final_s}
dt_s = {period_s}
[orbit]
gravity = "two-body"
[spacecraft_defaults]
inertia_kgm2 = [1.0, 1.0, 1.0]
mass_kg = {mass_kg}
{craft}
{controller}
{actuators}
"""


# --- impulse bits ---------------------------------------------------------------------------

BITS_SCENARIO = _formation(
    2, 4.0,
    # The deputy sits on the chief and is told to be 1 m ahead: f_x = k_p (1 − ρ_x) ≈ 1.23456 mN,
    # i.e. 12.3456 bits per 0.1 s period, so every period leaves a remainder to carry.
    """[controller]
kind = "lvlh-pd"
period_s = 0.1
k_p = 1.23456e-3
k_d = 0.0
rho_target_lvlh_m = [1.0, 0.0, 0.0]""",
    # 1 N thrusters: a bit lasts 10 µs, so the LVLH frame turns by ~1e-7 rad during a pulse.
    """[actuators]
kind = "impulse-bit-thrusters"
bit_ns = 1e-5
thrust_n = 1.0""",
)


@pytest.fixture(scope="module")
def bits_run(tmp_path_factory, run_toml):
    return run_toml(tmp_path_factory.mktemp("bits"), BITS_SCENARIO)


def test_impulse_bits_are_whole_and_the_remainder_is_carried(bits_run):
    built, ds = bits_run
    bits = ds.impulse_bits.values  # (time, spacecraft, axis), cumulative
    np.testing.assert_array_equal(bits, np.round(bits))
    assert np.all(bits[:, 0] == 0.0)  # the chief commands nothing
    per_period = np.diff(bits[:, 1, 0])
    assert set(per_period) == {12.0, 13.0}  # 12.3456 wanted: rounding alone would always give 12
    # Signed impulse = whole bits × bit (all firings are +x here).
    np.testing.assert_allclose(ds.force_impulse.values[:, 1, 0], bits[:, 1, 0] * BIT_NS, rtol=1e-14, atol=0)
    np.testing.assert_allclose(ds.abs_force_impulse.values, np.abs(ds.force_impulse.values), rtol=0, atol=0)
    # Sigma-delta: after every period the delivered impulse is within half a bit of the
    # commanded impulse Σ f_k T (without the carry the deficit would grow by 0.35 bit a period).
    period = built.scenario.control_period_s
    wanted = np.concatenate([[0.0], np.cumsum(ds.force_command.values[:-1, 1, 0] * period)])
    deficit = (wanted - ds.force_impulse.values[:, 1, 0]) / BIT_NS
    assert np.abs(deficit).max() <= 0.5 + 1e-9
    assert bits[-1, 1, 0] == 370.0  # 30 periods × 12.3456 = 370.4 (the command decays by 0.1 %)
    # The mean force over each period is its bits × bit / T.
    np.testing.assert_allclose(ds.force.values[:-1, 1, 0], per_period * BIT_NS / period, rtol=1e-12)


def test_impulse_bits_change_the_velocity_by_bits_times_bit_over_mass(bits_run):
    built, ds = bits_run
    # Both start at the same point of the same orbit; only the deputy thrusts. Over 3 s the
    # differential gravity of the ≤ 1.4 mm separation changes the relative velocity by about
    # n²·1.4 mm·3 s ≈ 5e-9 m/s, against the 9.25e-4 m/s of the bits.
    dv = ds.v_eci.values[-1, 1] - ds.v_eci.values[-1, 0]
    total = ds.impulse_bits.values[-1, 1, 0] * BIT_NS / 4.0
    assert abs(np.linalg.norm(dv) - total) < 1e-5 * total
    # Direction: each period's impulse along the chief's LVLH axes at its sample.
    impulse = np.diff(ds.force_impulse.values[:, 1], axis=0)  # (periods, 3), LVLH
    c = np.asarray(lvlh_dcm(ds.r_eci.values[:-1, 0], ds.v_eci.values[:-1, 0]))  # (periods, 3, 3)
    expected = np.einsum("kji,kj->i", c, impulse) / 4.0
    np.testing.assert_allclose(dv, expected, rtol=0, atol=1e-8)
    assert np.linalg.norm(dv - expected) < 1e-5 * total


def test_impulse_bits_that_do_not_fit_in_the_period_are_refused(tmp_path):
    text = BITS_SCENARIO.replace("thrust_n = 1.0", "thrust_n = 0.001\nmax_bits_per_period = 11")
    path = tmp_path / "s.toml"
    path.write_text(text, encoding="utf-8")
    # 11 bits of 10 ms take 0.11 s > 0.1 s.
    with pytest.raises(ScenarioError, match=r"actuators\.max_bits_per_period"):
        prepare(load_scenario(path))
    built = prepare(load_scenario(path, ["actuators.max_bits_per_period=10"]))
    assert built.design_metrics["impulse_bit_max_force_n"] == pytest.approx(10 * BIT_NS / 0.1)


def test_a_force_actuator_needs_masses(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(BITS_SCENARIO.replace("mass_kg = 4.0", ""), encoding="utf-8")
    with pytest.raises(ScenarioError, match="mass_kg"):
        prepare(load_scenario(path))


# --- proportional thrusters -----------------------------------------------------------------


@pytest.fixture(scope="module")
def proportional_run(tmp_path_factory, run_toml):
    # Three deputies on the chief with k_p = 1 N/m and targets 0.5 mm, 5 cm and 0.5 m ahead:
    # commands 0.5 mN (below the 1 mN minimum), ≈ 50 mN (inside the band), ≈ 0.5 N (above
    # the 0.1 N maximum). 100 kg keeps each deputy within 5 mm of the chief over the 3 s.
    text = _formation(
        4, 100.0,
        """[controller]
kind = "lvlh-pd"
period_s = 0.1
k_p = 1.0
k_d = 0.0
rho_target_lvlh_m = [[0.0, 0.0, 0.0], [5e-4, 0.0, 0.0], [0.05, 0.0, 0.0], [0.5, 0.0, 0.0]]""",
        """[actuators]
kind = "proportional-thrusters"
force_min_n = 0.001
force_max_n = 0.1""",
    )
    return run_toml(tmp_path_factory.mktemp("proportional"), text)


def test_a_command_below_the_minimum_force_gives_no_thrust(proportional_run):
    built, ds = proportional_run
    assert np.all((ds.force_command.values[:, 1, 0] > 4.9e-4) & (ds.force_command.values[:, 1, 0] < 5.1e-4))
    assert np.all(ds.force.values[:, 1] == 0.0)
    # Same orbit, same point, no thrust: exactly the chief's trajectory.
    np.testing.assert_array_equal(ds.r_eci.values[:, 1], ds.r_eci.values[:, 0])
    np.testing.assert_array_equal(ds.v_eci.values[:, 1], ds.v_eci.values[:, 0])
    assert built.design_metrics["thruster_deadband_force_n"] == 0.001


def test_a_command_inside_the_band_is_executed_as_commanded(proportional_run):
    _, ds = proportional_run
    f = ds.force.values[:-1, 2, 0]
    assert np.all((f > 0.045) & (f < 0.0501))
    np.testing.assert_allclose(f, ds.force_command.values[:-1, 2, 0], rtol=1e-13)


def test_a_command_above_the_maximum_force_is_clipped(proportional_run):
    _, ds = proportional_run
    assert np.all(ds.force_command.values[:, 3, 0] > 0.49)
    np.testing.assert_allclose(ds.force.values[:, 3], [[0.1, 0.0, 0.0]] * len(ds.time), rtol=0, atol=1e-15)
    np.testing.assert_allclose(ds.force_impulse.values[-1, 3, 0], 0.1 * 3.0, rtol=1e-13)
    # 0.1 N for 3 s on 100 kg: 3 mm/s, held along the (slowly turning) LVLH x axis.
    dv = np.linalg.norm(ds.v_eci.values[-1, 3] - ds.v_eci.values[-1, 0])
    assert dv == pytest.approx(0.1 * 3.0 / 100.0, rel=1e-5)


def test_proportional_thruster_band_must_be_ordered(tmp_path):
    text = _formation(
        2, 4.0, '[controller]\nkind = "lvlh-pd"\nperiod_s = 0.1\nk_p = 1.0\nk_d = 1.0\nrho_target_lvlh_m = [1.0, 0.0, 0.0]',
        '[actuators]\nkind = "proportional-thrusters"\nforce_min_n = 0.2\nforce_max_n = 0.1',
    )
    path = tmp_path / "s.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ScenarioError, match="force_min_n"):
        load_scenario(path)


# --- reaction wheels ------------------------------------------------------------------------

INERTIA = np.diag([10.0, 12.0, 8.0])
H_WHEELS0 = np.array([0.0, 0.05, 0.02])
WHEEL_INERTIA = 0.01
MAX_SPEED_RAD_S = 6000.0 * 2 * math.pi / 60
Q_TARGET = [math.cos(math.radians(15.0)), 0.0, math.sin(math.radians(15.0)), 0.0]  # 30° about body y
G = np.column_stack([np.eye(3), np.ones(3) / math.sqrt(3)])

WHEELS_SCENARIO = f"""
name = "wheel-slew"
[sim]
t_final_s = 300.0
dt_s = 0.1
record_interval_s = 1.0
[[spacecraft]]
inertia_kgm2 = [10.0, 12.0, 8.0]
omega_b_rad_s = [0.01, -0.005, 0.0]
h_wheels_b_nms = [0.0, 0.05, 0.02]
[controller]
kind = "attitude-pid"
period_s = 0.1
k_p = 2.0
k_d = 8.0
q_target = [{Q_TARGET[0]!r}, 0.0, {Q_TARGET[2]!r}, 0.0]
[actuators]
kind = "reaction-wheels"
inertia_kgm2 = {WHEEL_INERTIA}
max_speed_rpm = 6000.0
torque_max_nm = 0.05
"""


@pytest.fixture(scope="module")
def wheels_run(tmp_path_factory, run_toml):
    return run_toml(tmp_path_factory.mktemp("wheels"), WHEELS_SCENARIO)


def test_wheels_exchange_momentum_with_the_body_and_conserve_the_total(wheels_run):
    _, ds = wheels_run
    h = inertial_angular_momentum_nms(ds.q.values, ds.omega.values, INERTIA[None], ds.h_wheels.values)
    h0 = INERTIA @ [0.01, -0.005, 0.0] + H_WHEELS0  # q = identity at t = 0
    np.testing.assert_allclose(h[0], h0, rtol=0, atol=1e-15)
    # Measured 2e-12 relative: the wheels' reaction is internal, only RK4's error remains.
    assert np.abs(h - h0).max() < 1e-9 * np.linalg.norm(h0)
    body = np.einsum("ij,tj->ti", INERTIA, ds.omega.values[:, 0])
    assert np.abs(body - body[0]).max() > 0.5  # the body's own momentum changed by > 0.5 N·m·s
    # The wheels took it up, and the body came to rest at the target.
    np.testing.assert_allclose(np.abs(ds.q.values[-1, 0]), np.abs(Q_TARGET), rtol=0, atol=1e-9)
    assert np.abs(ds.omega.values[-1, 0]).max() < 1e-9


def test_wheel_counters_track_the_wheel_momentum_and_stay_within_limits(wheels_run):
    _, ds = wheels_run
    # Each wheel's momentum = its initial share G⁺ h_w(0) + its motor impulse; G of that is
    # the plant's integrated h_wheels_b (the part's state and the plant agree).
    h_w = np.linalg.pinv(G) @ H_WHEELS0 + ds.wheel_angular_impulse.values[:, 0]  # (time, 4)
    np.testing.assert_allclose(h_w @ G.T, ds.h_wheels.values[:, 0], rtol=0, atol=1e-13)
    # h_k is the wheel's momentum about its axis in inertial space, I_k (Ω_k + g_k·ω): the
    # recorded speed relative to the body is h_k / I_k − g_k·ω.
    speed = h_w / WHEEL_INERTIA - ds.omega.values[:, 0] @ G
    np.testing.assert_allclose(ds.wheel_speed.values[:, 0], speed, rtol=0, atol=1e-9)
    assert list(ds.wheel.values) == ["w1", "w2", "w3", "w4"]
    assert np.abs(speed).max() < MAX_SPEED_RAD_S
    assert np.abs(speed).max() > 30.0  # the wheels did spin up (measured 38 rad/s)


def test_wheel_torque_is_the_reaction_and_respects_the_motor_limit(wheels_run):
    _, ds = wheels_run
    # Mean body torque = −G τ with |τ_k| ≤ 0.05 N·m: the 0.56 N·m first command saturates.
    tau = np.diff(ds.wheel_angular_impulse.values[:, 0], axis=0) / 1.0  # mean motor torque per record interval
    assert np.abs(tau).max() <= 0.05 + 1e-15
    assert np.abs(tau).max() == pytest.approx(0.05)
    np.testing.assert_allclose(ds.torque.values[:-1, 0], -tau @ G.T, rtol=0, atol=1e-15)
    np.testing.assert_allclose(ds.angular_impulse.values[:, 0], -ds.wheel_angular_impulse.values[:, 0] @ G.T, atol=1e-13)
    first = ds.torque_command.values[0, 0]
    assert first[1] > 0.5 and np.abs(ds.torque.values[0, 0]).max() < 0.1


def _wheel_error(tmp_path, axes):
    path = tmp_path / "s.toml"
    path.write_text(WHEELS_SCENARIO.replace("max_speed_rpm", f"spin_axes_b = {axes}\nmax_speed_rpm"), encoding="utf-8")
    with pytest.raises(ScenarioError) as err:
        prepare(load_scenario(path))
    return str(err.value)


def test_wheels_must_span_the_three_axes(tmp_path):
    msg = _wheel_error(tmp_path, "[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.7071067811865476, 0.7071067811865476, 0.0]]")
    assert "cannot produce torque about every axis" in msg


def test_wheel_spin_axes_must_be_unit_vectors(tmp_path):
    msg = _wheel_error(tmp_path, "[[2.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]")
    assert "spin_axes_b[0]" in msg and "unit vector" in msg


def test_per_wheel_lists_must_match_the_wheels(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(WHEELS_SCENARIO.replace("torque_max_nm = 0.05", "torque_max_nm = [0.05, 0.05]"), encoding="utf-8")
    with pytest.raises(ScenarioError, match=r"actuators\.torque_max_nm: 2 values for 4 wheels"):
        prepare(load_scenario(path))
