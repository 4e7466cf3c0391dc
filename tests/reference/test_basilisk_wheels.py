"""Reaction-wheel momentum in the rigid-body equation against Basilisk 2.12.1
(tests/data/README.md, ``basilisk_wheels.csv``): four wheels (three on the body axes, one along
(1, 1, 1)/√3) driven by fixed motor torques for 20 s, then free, for 60 s at 1 ms.

Basilisk's hub inertia includes the wheels' spin-axis inertia (wheels locked) and its wheel
speeds are relative to the body; our plant carries the wheels' inertial momentum about their
axes, ``h_k = J (Ω_k + g_k·ω)``, with the body inertia without them. The test drives our
engine with the same motor torques through the ``wheel_torque_b`` channel (a schedule part
defined here: the reaction-wheel actuator takes body-torque commands, not motor torques).
"""

import dataclasses
from pathlib import Path

import jax.numpy as jnp
import numpy as np
import pytest

from coopsat.core.parts import OutputSpec, part
from coopsat.actuators.pulses import Pulse
from coopsat.workflows.pipeline import prepare
from coopsat.scenarios.load import load_scenario
from coopsat.sim.engine import simulate
from coopsat.sim.system import as_arrays

REFERENCE = Path(__file__).resolve().parents[1] / "data" / "basilisk_wheels.csv"
J_WHEEL = 1.1318e-4
G = np.column_stack([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0], np.ones(3) / np.sqrt(3)])
U_MOTOR = np.array([1e-4, -5e-5, 2e-5, -1e-4])
OMEGA_WHEEL0 = np.array([10.471975511965976, -5.235987755982988, 3.141592653589793, 2.0943951023931953])
OMEGA0 = np.array([0.01, -0.02, 0.015])
I_LOCKED = np.diag([0.28, 0.33, 0.35])


@part()
class MotorTorqueSchedule:
    """Fixed motor torques ``u`` on wheels with axes ``G`` for the first ``periods_on`` periods."""

    level_nm: jnp.ndarray
    periods_on: jnp.ndarray

    channel = "wheel_torque_b"
    pulsed = False
    mean_output = ("wheel_torque_mean", "wheel_impulse")
    command = "unused"

    def init(self, n):
        return jnp.zeros((), jnp.int64)

    def plan(self, command, x, state, period_s, key, t):
        level = jnp.where(state < self.periods_on, self.level_nm, 0.0)
        return Pulse(level, jnp.full_like(level, period_s)), state + 1

    def record(self, x, state):
        return {}

    def account(self, pulse):
        return {"wheel_impulse": pulse.level_nm * pulse.t_off_s}

    def output_specs(self):
        spec = OutputSpec(("component",), "N m s", "body", "wheel momentum change")
        return {"wheel_impulse": spec, "wheel_torque_mean": spec._replace(units="N m")}


@pytest.fixture(scope="module")
def runs():
    ref = np.loadtxt(REFERENCE, delimiter=",", skiprows=1)
    i_body = I_LOCKED - J_WHEEL * G @ G.T
    h0 = G @ (J_WHEEL * (OMEGA_WHEEL0 + G.T @ OMEGA0))
    overrides = [
        f"spacecraft.0.inertia_kgm2={i_body.tolist()}", f"spacecraft.0.h_wheels_b_nms={h0.tolist()}",
        f"spacecraft.0.omega_b_rad_s={OMEGA0.tolist()}", "spacecraft.0.q_bi=[1.0, 0.0, 0.0, 0.0]",
        "sim.t_final_s=60.0", "sim.dt_s=0.001", "sim.record_interval_s=0.1",
    ]
    built = prepare(load_scenario("rigid-body-free", overrides))
    drive = MotorTorqueSchedule(*as_arrays(((G @ U_MOTOR)[:, None], 20_000)))
    system = dataclasses.replace(built.system, actuators=(drive,))
    out = simulate(system, built.n_records, built.record_interval_s)
    return ref, out.samples


@pytest.mark.slow
def test_attitude_rate_and_wheel_speeds_match_basilisk(runs):
    ref, s = runs
    q, omega = s["q"][:, 0], s["omega"][:, 0]
    aligned = q * np.sign(np.sum(q * ref[:, 1:5], axis=1))[:, None]
    assert np.abs(aligned - ref[:, 1:5]).max() <= 1e-9
    assert np.abs(omega - ref[:, 5:8]).max() <= 1e-11  # |ω| ≈ 0.03 rad/s
    # Wheel speeds relative to the body from the wheels' inertial momenta.
    t = ref[:, 0]
    h_k = J_WHEEL * (OMEGA_WHEEL0 + G.T @ OMEGA0) + np.minimum(t, 20.0)[:, None] * U_MOTOR
    np.testing.assert_allclose(h_k @ G.T, s["h_wheels"][:, 0], rtol=0, atol=1e-15)
    speed = h_k / J_WHEEL - omega @ G
    assert np.abs(speed - ref[:, 8:12]).max() <= 1e-7  # wheel speeds up to ~30 rad/s


@pytest.mark.slow
def test_total_angular_momentum_is_conserved(runs):
    from coopsat.analysis.metrics import inertial_angular_momentum_nms

    _, s = runs
    i_body = (I_LOCKED - J_WHEEL * G @ G.T)[None]
    h = inertial_angular_momentum_nms(s["q"], s["omega"], i_body, s["h_wheels"])
    # RK4's truncation error is negligible here ((|ω| h)^5 ≈ 1e-23 per step): what is left is
    # rounding, at most about one ulp per step over 60 000 steps.
    assert np.abs(h - h[0]).max() <= 60_000 * np.finfo(float).eps * np.linalg.norm(h[0])
    assert np.linalg.norm(h[0]) == pytest.approx(0.0099875, rel=1e-4)  # Basilisk's |H|
