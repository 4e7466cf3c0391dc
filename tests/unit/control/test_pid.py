"""Attitude PID and LVLH station keeping, through real scenarios."""

import math

import numpy as np
import pytest

from coopsat.astro.kepler import elements_to_rv
from coopsat.control.pid import attitude_error_vector
from coopsat.geometry.frames import eci_to_lvlh, lvlh_to_eci
from coopsat.workflows.pipeline import prepare
from coopsat.scenarios.load import ScenarioError, load_scenario

MU = 3.986004418e14
A_M = 6878137.0


def _vec(a):
    return "[" + ", ".join(repr(float(x)) for x in a) + "]"


# --- the integral state ---------------------------------------------------------------------

HALF = 0.3  # half the rotation angle from the target
AXIS = np.array([0.6, 0.0, 0.8])
Q_HELD = np.concatenate([[math.cos(HALF)], math.sin(HALF) * AXIS])

HELD_SCENARIO = f"""
name = "pid-held"
[sim]
t_final_s = 2.0
dt_s = 0.1
[[spacecraft]]
inertia_kgm2 = [1.0, 1.0, 1.0]
q_bi = {_vec(Q_HELD)}
[[spacecraft]]
inertia_kgm2 = [1.0, 1.0, 1.0]
q_bi = {_vec(-Q_HELD)}
[controller]
kind = "attitude-pid"
period_s = 0.1
k_p = 2.0
k_d = 3.0
k_i = 0.5
[actuators]
# A torque limit of 1e-20 N·m holds the bodies where they are (they turn by < 1e-19 rad in
# 2 s), so the attitude error stays constant and the integral can be checked by hand.
kind = "ideal-torque"
torque_max_nm = 1e-20
"""


def test_the_integral_after_m_periods_is_m_periods_times_the_error(tmp_path, run_toml):
    _, ds = run_toml(tmp_path, HELD_SCENARIO)
    e = math.sin(HALF) * AXIS  # vec(q_t* ⊗ q) with q_t = identity; −q is the same attitude
    np.testing.assert_allclose(np.asarray(attitude_error_vector(Q_HELD, np.array([1.0, 0, 0, 0]))), e, atol=1e-16)
    m = np.arange(len(ds.time))  # sample m is after m periods of 0.1 s
    expected = m[:, None, None] * 0.1 * e[None, None, :]
    np.testing.assert_allclose(ds.attitude_error_integral.values, np.broadcast_to(expected, (len(m), 2, 3)), rtol=0, atol=1e-12)
    # u = −K_p e − K_d ω − K_i ∫e, ω = 0 (to 1e-19).
    u = -2.0 * e[None, None, :] - 0.5 * expected
    np.testing.assert_allclose(ds.torque_command.values, np.broadcast_to(u, (len(m), 2, 3)), rtol=0, atol=1e-12)


def test_the_integral_is_clamped_by_integral_max(tmp_path, run_toml):
    _, ds = run_toml(tmp_path, HELD_SCENARIO.replace("k_i = 0.5", "k_i = 0.5\nintegral_max = 0.05"))
    e = math.sin(HALF) * AXIS
    m = np.arange(len(ds.time))
    expected = np.clip(m[:, None] * 0.1 * e[None, :], -0.05, 0.05)
    np.testing.assert_allclose(ds.attitude_error_integral.values[:, 0], expected, rtol=0, atol=1e-12)
    assert ds.attitude_error_integral.values[-1, 0, 2] == 0.05  # the z component hit the clamp (0.47 unclamped)


# --- PID removes the steady error that a PD leaves --------------------------------------------

# A spacecraft on an equatorial circular orbit held at a fixed inertial attitude (identity) feels
# the gravity-gradient torque L_z = 1.5 n² (I_y − I_x) sin 2φ about z (φ: its argument of
# latitude). Over the run φ goes from 0 to 45°, where L_z peaks at 1.84e-5 N·m and is stationary
# (dL/dt = 0): a nearly constant disturbance at the end. A PD settles where its proportional term
# balances it, e = L/K_p; the PID's integral takes the load and drives e to ~0.
GG_SCENARIO = f"""
name = "pid-gravity-gradient"
[sim]
t_final_s = 710.0
dt_s = 1.0
record_interval_s = 10.0
[orbit]
gravity = "two-body"
[[spacecraft]]
inertia_kgm2 = [10.0, 20.0, 25.0]
elements = {{ a_m = {A_M} }}
[controller]
kind = "attitude-pid"
period_s = 1.0
k_p = 0.05
k_d = 1.6
k_i = 0.001
[[disturbances]]
kind = "gravity-gradient"
"""


@pytest.fixture(scope="module")
def gg_runs(tmp_path_factory, run_toml):
    tmp = tmp_path_factory.mktemp("gg")
    return run_toml(tmp, GG_SCENARIO, ["controller.k_i=0.0"]), run_toml(tmp, GG_SCENARIO)


def test_a_pd_leaves_the_steady_error_l_over_kp(gg_runs):
    (built, ds), _ = gg_runs
    assert not built.warnings
    n2 = MU / A_M**3
    l_z = ds.gravity_gradient_torque.values[-1, 0, 2]
    assert l_z == pytest.approx(1.5 * n2 * 10.0 * math.sin(2 * math.radians(45.0)), rel=1e-3)
    e = np.asarray(attitude_error_vector(ds.q.values[-1, 0], np.array([1.0, 0, 0, 0])))
    assert e[2] == pytest.approx(l_z / 0.05, rel=0.03)  # measured 1.5 % (the torque still drifts)
    assert np.abs(e[:2]).max() < 1e-12


def test_a_pid_removes_it(gg_runs):
    (_, pd), (built, pid) = gg_runs
    assert not built.warnings  # the sampled-data check finds the loop stable
    e_pd = np.asarray(attitude_error_vector(pd.q.values[-1, 0], np.array([1.0, 0, 0, 0])))[2]
    e_pid = np.asarray(attitude_error_vector(pid.q.values[-1, 0], np.array([1.0, 0, 0, 0])))[2]
    assert abs(e_pid) < 0.02 * abs(e_pd)  # measured 0.010
    # At rest the torques balance: K_i ∫e = L − K_p e (measured within 1.5 %: the slow pole).
    l_z = pid.gravity_gradient_torque.values[-1, 0, 2]
    assert 0.001 * pid.attitude_error_integral.values[-1, 0, 2] == pytest.approx(l_z - 0.05 * e_pid, rel=0.03)


# --- LVLH station keeping -------------------------------------------------------------------


def _lvlh_scenario(rho0, rho_target, force_min_n=0.001):
    r0, v0 = elements_to_rv(A_M, 0.0, math.radians(97.4), math.radians(30.0), 0.0, 0.0, MU)
    r1, v1 = lvlh_to_eci(r0, v0, np.asarray(rho0, dtype=float), np.zeros(3))
    return f"""
name = "lvlh-keeping"
[sim]
t_final_s = 600.0
dt_s = 1.0
record_interval_s = 5.0
[orbit]
gravity = "two-body"
[spacecraft_defaults]
inertia_kgm2 = [1.0, 1.0, 1.0]
mass_kg = 4.0
[[spacecraft]]
name = "chief"
r_eci_m = {_vec(r0)}
v_eci_m_s = {_vec(v0)}
[[spacecraft]]
name = "deputy"
r_eci_m = {_vec(r1)}
v_eci_m_s = {_vec(v1)}
[controller]
kind = "lvlh-pd"
period_s = 1.0
k_p = 0.01
k_d = 0.4
rho_target_lvlh_m = {_vec(rho_target)}
[actuators]
kind = "proportional-thrusters"
force_min_n = {force_min_n}
force_max_n = 0.1
"""


def test_a_deputy_10_m_off_its_target_converges_to_it(tmp_path, run_toml):
    # Target 10 m ahead of the chief (an equilibrium of the circular orbit); start 6 m further
    # along track and 8 m lower: 10 m off.
    built, ds = run_toml(tmp_path, _lvlh_scenario([16.0, 0.0, 8.0], [10.0, 0.0, 0.0]))
    assert not built.warnings
    rho = ds.rho_lvlh.values[:, 1]
    np.testing.assert_allclose(rho[0], [16.0, 0.0, 8.0], atol=1e-8)
    # What the law saw is the true relative state (ideal sensors).
    rho_true, _ = eci_to_lvlh(ds.r_eci.values[:, 0], ds.v_eci.values[:, 0], ds.r_eci.values[:, 1], ds.v_eci.values[:, 1])
    np.testing.assert_allclose(rho, np.asarray(rho_true), rtol=0, atol=1e-9)
    err = np.linalg.norm(rho - [10.0, 0.0, 0.0], axis=1)
    late = ds.time.values >= 300.0
    # Inside the 1 mN dead band the thrusters stop: |k_p δ| < 1 mN per axis allows δ < 0.1 m
    # per axis, where the deputy drifts (measured ≤ 0.133 m).
    assert err.max() == pytest.approx(10.0) and err[late].max() < 0.2
    assert np.all(ds.force_command.values[:, 0] == 0.0) and np.all(ds.force_impulse.values[:, 0] == 0.0)
    # The saturated start: |f| ≤ 0.1 N per axis.
    assert np.abs(ds.force.values[:, 1]).max() <= 0.1


def test_without_a_dead_band_the_deputy_settles_on_the_target(tmp_path, run_toml):
    _, ds = run_toml(tmp_path, _lvlh_scenario([16.0, 0.0, 8.0], [10.0, 0.0, 0.0], force_min_n=0.0))
    err = np.linalg.norm(ds.rho_lvlh.values[:, 1] - [10.0, 0.0, 0.0], axis=1)
    assert err[-1] < 1e-3 * err[0]


def test_lvlh_pd_needs_an_orbit_and_consistent_targets(tmp_path):
    path = tmp_path / "s.toml"
    text = _lvlh_scenario([16.0, 0.0, 8.0], [10.0, 0.0, 0.0])
    path.write_text(text.replace("rho_target_lvlh_m = [10.0, 0.0, 0.0]", "rho_target_lvlh_m = [[1.0, 0.0, 0.0], [10.0, 0.0, 0.0]]"))
    with pytest.raises(ScenarioError, match="chief"):
        prepare(load_scenario(path))
    path.write_text(text.replace("rho_target_lvlh_m = [10.0, 0.0, 0.0]", "rho_target_lvlh_m = [[0.0, 0.0, 0.0]]"))
    with pytest.raises(ScenarioError, match="1 offsets for 2 spacecraft"):
        prepare(load_scenario(path))
    path.write_text(
        '[sim]\nt_final_s = 1.0\ndt_s = 0.1\n[[spacecraft]]\ninertia_kgm2 = [1.0, 1.0, 1.0]\n'
        '[controller]\nkind = "lvlh-pd"\nperiod_s = 0.1\nk_p = 1.0\nk_d = 1.0\nrho_target_lvlh_m = [1.0, 0.0, 0.0]\n'
    )
    with pytest.raises(ScenarioError, match=r"\[orbit\]"):
        prepare(load_scenario(path))
