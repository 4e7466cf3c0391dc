"""Magnetorquers: ``L = sat(m) × B`` with each coil saturated on its own, the part's plan and
counters, and, in a short run of observation-cooperative with every other external torque
removed, the inertial angular momentum of bodies and wheels changing by exactly the magnetic
impulse."""

import re

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from coopsat.actuators.magnetorquers import Magnetorquers, magnetorquer_torque_b
from coopsat.analysis.metrics import inertial_angular_momentum_nms
from coopsat.astro.earth_orientation import z_rotation
from coopsat.astro.earth import OMEGA_EARTH_RAD_S, gmst_rad, julian_date_utc
from coopsat.dynamics.plant import PlantState
from coopsat.workflows.pipeline import prepare, simulate_built
from coopsat.scenarios.load import bundled_text, load_scenario
from earth_reference import hand_dipole_eci, to_body

COOP = "observation-cooperative"
GMST0 = gmst_rad(julian_date_utc("2018-07-12T03:00:00"))
EARTH = z_rotation(GMST0, 86400.0)  # the papers' Earth: θ = GMST0 + ω_E t


def test_torque_is_the_clipped_dipole_cross_the_field_per_axis():
    rng = np.random.default_rng(1)
    m = rng.normal(scale=3.0, size=(3, 200))
    b = rng.normal(scale=3e-5, size=(3, 200))
    limit = np.array([[1.0], [2.0], [4.0]])
    torque, applied = (np.asarray(a) for a in magnetorquer_torque_b(m, b, limit))
    expected_m = np.minimum(np.maximum(m, -limit), limit)
    np.testing.assert_array_equal(applied, expected_m)
    assert (np.abs(m) > limit).any(axis=1).all()  # every coil saturates somewhere in the sample
    np.testing.assert_allclose(torque, np.cross(expected_m.T, b.T).T, rtol=1e-12, atol=1e-22)
    # Never along the field.
    cos = np.sum(torque * b, axis=0) / (np.linalg.norm(torque, axis=0) * np.linalg.norm(b, axis=0))
    assert np.abs(cos).max() < 1e-12


def test_a_dipole_along_the_field_gives_no_torque_unless_clipping_turns_it():
    b = np.array([[2e-5], [-1e-5], [3e-5]])
    along = 0.5 * b / np.linalg.norm(b)  # 0.5 A·m², within the 1 A·m² limit
    torque, _ = magnetorquer_torque_b(along, b, 1.0)
    assert np.abs(np.asarray(torque)).max() < 1e-22
    # 3 A·m² along B: each coil clipped at 1 A·m² separately turns the dipole off B (a clip of
    # the norm would keep it along B, and give no torque).
    torque, applied = (np.asarray(a) for a in magnetorquer_torque_b(6.0 * along, b, 1.0))
    np.testing.assert_allclose(applied[:, 0], np.clip(6.0 * along[:, 0], -1.0, 1.0))
    assert np.linalg.norm(torque) > 1e-6


def _state(q, r):
    q, r = np.atleast_2d(q), np.atleast_2d(r)
    zeros = jnp.zeros((3, q.shape[0]))
    return PlantState(jnp.asarray(q.T), zeros, zeros, jnp.asarray(r.T), zeros, zeros)


def test_plan_holds_m_cross_the_body_field_for_the_whole_period_and_counts_its_impulse():
    part = Magnetorquers(jnp.asarray(2.5), EARTH)
    rng = np.random.default_rng(2)
    q = rng.normal(size=(2, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    r = np.array([[6.9e6, 0.0, 0.0], [-2.6e6, -4.0e6, -4.9e6]])
    command = np.array([[1.0, -4.0], [3.0, 0.5], [-0.2, 2.6]])  # (3, n): saturates y of 1, x and z of 2
    t, period = 600.0, 0.1
    state = part.init(2)
    np.testing.assert_array_equal(np.asarray(state), np.zeros((3, 2)))
    pulse, state = part.plan(jnp.asarray(command), _state(q, r), state, period, jax.random.PRNGKey(0), t)
    applied = np.clip(command, -2.5, 2.5)
    np.testing.assert_array_equal(np.asarray(state), applied)
    np.testing.assert_array_equal(np.asarray(part.record(None, state)["magnetorquer_dipole"]), applied)
    theta = GMST0 + OMEGA_EARTH_RAD_S * t
    for i in range(2):
        b_b = to_body(q[i], hand_dipole_eci(r[i], theta))
        np.testing.assert_allclose(np.asarray(pulse.level_nm)[:, i], np.cross(applied[:, i], b_b), rtol=1e-10)
        # The field of t = 0 (the Earth 2.5° less turned) would give another torque.
        b_0 = to_body(q[i], hand_dipole_eci(r[i], GMST0))
        assert np.linalg.norm(np.asarray(pulse.level_nm)[:, i] - np.cross(applied[:, i], b_0)) > 1e-3 * np.linalg.norm(b_b)
    np.testing.assert_array_equal(np.asarray(pulse.t_off_s), np.full((3, 2), period))  # on for the whole period
    impulse = np.asarray(part.account(pulse)["magnetic_angular_impulse"])
    np.testing.assert_allclose(impulse, np.asarray(pulse.level_nm) * period, rtol=1e-15)
    # Traced under jit, the same plan.
    jitted, jstate = jax.jit(part.plan, static_argnums=3)(jnp.asarray(command), _state(q, r), part.init(2), period,
                                                         jax.random.PRNGKey(0), t)
    np.testing.assert_allclose(np.asarray(jitted.level_nm), np.asarray(pulse.level_nm), rtol=1e-12, atol=1e-22)
    np.testing.assert_array_equal(np.asarray(jstate), applied)


# --- in a run --------------------------------------------------------------------------------


def _without(text, kinds):
    """Scenario text with the array-of-tables entries of the given kinds removed."""
    blocks = re.split(r"\n(?=\[\[)", text)
    return "\n".join(b for b in blocks if not any(f'kind = "{k}"' in b.split("\n", 2)[1] for k in kinds))


@pytest.fixture(scope="module")
def magnetic_only_run(tmp_path_factory):
    """observation-cooperative for 3 s with no external torque but the magnetorquers' (a strong
    dumping gain, so that they push), recorded every control period."""
    text = _without(bundled_text(COOP), ("gravity-gradient", "aerodynamic-torque", "solar-pressure-torque",
                                         "residual-dipole", "random-torque"))
    path = tmp_path_factory.mktemp("magnetic") / "magnetic-only.toml"
    path.write_text(text.replace('name = "observation-cooperative"', 'name = "magnetic-only"'), encoding="utf-8")
    # The papers' Earth (a z turn by GMST), which the hand-written field below follows.
    built = prepare(load_scenario(path, ["sim.t_final_s=3", "sim.record_interval_s=0.1", "controller.dump_gain_1_s=1.0",
                                         "orbit.earth_orientation=gmst82"]))
    ds, _ = simulate_built(built)
    return built, ds


def test_recorded_counters_are_the_torque_of_the_recorded_dipole_over_each_period(magnetic_only_run):
    built, ds = magnetic_only_run
    period = built.scenario.control_period_s
    assert ds.attrs["scenario_name"] == "magnetic-only" and period == 0.1
    torque = ds.magnetic_torque.values  # (T, n, 3): mean over the period starting at the sample
    impulse = ds.magnetic_angular_impulse.values  # cumulative from t = 0
    assert np.abs(torque).max() > 1e-6
    np.testing.assert_array_equal(impulse[0], 0.0)
    np.testing.assert_allclose(np.diff(impulse, axis=0), torque[:-1] * period, rtol=1e-12, atol=1e-24)
    # The dipole recorded at t_{k+1} was applied over [t_k, t_{k+1}], in the field at t_k.
    q, r, t = ds.q.values, ds.r_eci.values, ds.time.values
    dipole = ds.magnetorquer_dipole.values
    assert np.abs(dipole).max() <= 2.5
    for k in range(len(t) - 1):
        for i in range(q.shape[1]):
            b_b = to_body(q[k, i], hand_dipole_eci(r[k, i], GMST0 + OMEGA_EARTH_RAD_S * t[k]))
            np.testing.assert_allclose(torque[k, i], np.cross(dipole[k + 1, i], b_b), rtol=1e-9, atol=1e-12 * np.linalg.norm(b_b))


def test_bodies_and_wheels_gain_exactly_the_magnetic_impulse(magnetic_only_run):
    """Wheels only move momentum around inside each spacecraft; the coils' body-fixed torque over
    each period, turned to inertial axes (trapezoid over the period's ends: the bodies turn by
    ωT ≈ 1e-5 rad in it), is the whole change of Σ C(q)(Iω + h_w)."""
    built, ds = magnetic_only_run
    period = built.scenario.control_period_s
    q, torque = ds.q.values, ds.magnetic_torque.values
    h = inertial_angular_momentum_nms(q, ds.omega.values, built.context.inertia_kgm2, ds.h_wheels.values)
    c = np.stack([Rotation.from_quat(q[:, i], scalar_first=True).as_matrix() for i in range(q.shape[1])], axis=1)
    turned = 0.5 * (np.einsum("tnij,tnj->tni", c[:-1], torque[:-1]) + np.einsum("tnij,tnj->tni", c[1:], torque[:-1]))
    gained = np.concatenate([np.zeros((1, 3)), np.cumsum(turned.sum(axis=1) * period, axis=0)])
    change = h - h[0]
    assert np.linalg.norm(change[-1]) > 1e-6
    # RK4 at 0.1 s keeps |H| to about 1e-12 N·m·s here; leaving the turn out (C(q_k) alone)
    # would miss by 2e-10.
    np.testing.assert_allclose(change, gained, rtol=0, atol=1e-11)
