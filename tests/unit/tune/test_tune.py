"""``coopsat tune``: gradients through the closed loop, a known optimum, the exact re-run, bad input.

Every reference here is independent of the code under test: central finite differences of
the same loss (gradients), SciPy's discrete-time Riccati solution (the optimal PD gain of a
sampled double integrator), the exact loop's own metrics (constraints), and the CLI contract
(status 2, one line, no traceback).
"""

import math
from dataclasses import replace

import numpy as np
import pytest
import scipy.linalg

from coopsat.core import runtime  # noqa: F401  (64-bit JAX, as the simulator runs it)

import jax
import jax.numpy as jnp

from coopsat.cli import main
from coopsat.workflows.pipeline import prepare
from coopsat.scenarios.load import load_scenario
from coopsat.sim.engine import run_samples
from coopsat.workflows.tune import Spec, constraint_met, loss_function, minimise, resolve_params, tune


def _objective(built, params, metric):
    """``z -> surrogate objective`` on the smoothed loop (what the tuner differentiates)."""
    f = loss_function(built, params, Spec(metric), [], smooth=True)
    return lambda z: f(z)[0]


def _central_difference(fun, z, direction, h):
    return (float(fun(z + h * direction)) - float(fun(z - h * direction))) / (2.0 * h)


# --- 1. reverse-mode gradients agree with central differences ---------------------------------


def test_consensus_gradient_matches_central_differences():
    # 5 s of the saturated scenario (100 ticks, 10 records): rates of up to 5 rad/s drive the
    # 0.05 N·m limit, so the gradient goes through the smoothed saturation.
    built = prepare(load_scenario("consensus-sync-a-saturated", ["sim.t_final_s=5"]))
    params = resolve_params(built, ["controller.alpha", "controller.beta"])
    obj = jax.jit(_objective(built, params, "sync_time_s"))
    z0 = jnp.array([0.1, -0.2])  # away from the scenario's own gains (α·e^0.1, β·e^-0.2)
    grad = np.asarray(jax.jit(jax.grad(_objective(built, params, "sync_time_s")))(z0))
    assert np.all(np.isfinite(grad)) and np.all(np.abs(grad) > 1e-3)  # a slope to check (measured 1.95, −1.99)
    # h = 1e-5: the truncation error (~h²) and the rounding error (~1e-16·|f|/h with |f| ≈ 460)
    # are both far below 1e-5 of the slope (measured relative differences 1.4e-8 and 3.1e-8).
    fd = np.array([_central_difference(obj, z0, e, 1e-5) for e in np.eye(2)])
    np.testing.assert_allclose(grad, fd, rtol=1e-5, atol=0)


# The bundled deep-space formation sits at 1 AU from the origin of ECI, where float64 resolves
# a position only to 2^-15 m ≈ 3e-5 m: a gain perturbation that moves the spacecraft by less
# than that is rounded away in every RK4 step, so central differences of the fuel are noise
# at small h (measured at 1 AU, same direction: 0.93 % off at h = 2e-6, 0.61 % at 1e-5). At
# larger h they cannot resolve the rounded corner of the thrusters' smoothed saturation
# (0.01·force_max = 1 mN wide, while a command moves by ~3 N per unit of z): 5.9e-4 off at
# h = 1e-3, and 5.6e-4 at h = 1e-4 once the noise is gone (at 1 AU that step happens to land
# at 9e-6, the noise cancelling the truncation). No step reaches 1e-5 reliably there. The same formation, same flight software, same gain and
# thrusters, moved to the origin with the Sun's gravity and radiation pressure made negligible
# (the formation frame is inertial; over 500 s they move the square by < 1e-4 m), has
# positions resolved to 1e-14 m, and the two agree to 1e-10 at h = 2e-6. The dead zone of the
# flight software's thruster model (control/formation.py, deadzone_thrust, 1 mN) is never
# reached in these 500 s (every command is above 6 mN), so the default force_min_n is kept:
# force_min_n = 0 gives the same derivative to 12 digits.
AT_ORIGIN = ["orbit.mu_m3_s2=1e-30", "disturbances.0.pressure_1au_n_m2=1e-40"]
for _k, (_x, _y) in enumerate([(-100, -100), (100, -100), (100, 100), (-100, 100)]):
    AT_ORIGIN += [f"spacecraft.{_k}.r_eci_m=[{_x}.0, {_y}.0, 0.0]", f"spacecraft.{_k}.v_eci_m_s=[0.0, 0.0, 0.0]"]


@pytest.mark.slow  # long: runs in CI's second pytest pass (README)
def test_formation_gain_gradient_matches_central_differences():
    built = prepare(load_scenario("deepspace-square-to-line-lqr", ["sim.t_final_s=500", *AT_ORIGIN]))
    params = resolve_params(built, ["controller.gain"])
    assert params[0].size == 96  # the 8 × 12 gain
    obj = jax.jit(_objective(built, params, "fuel_l1_ns"))
    z0 = jnp.zeros(96)
    # The move to the origin leaves the problem as it was: the fuel agrees with the bundled
    # scenario at 1 AU (measured 265.28950 vs 265.29027).
    at_1au = prepare(load_scenario("deepspace-square-to-line-lqr", ["sim.t_final_s=500"]))
    fuel_1au = float(jax.jit(_objective(at_1au, resolve_params(at_1au, ["controller.gain"]), "fuel_l1_ns"))(z0))
    assert float(obj(z0)) == pytest.approx(fuel_1au, rel=1e-5)
    rng = np.random.default_rng(1)
    direction = rng.standard_normal(96)
    direction /= np.linalg.norm(direction)
    grad = np.asarray(jax.jit(jax.grad(_objective(built, params, "fuel_l1_ns")))(z0))
    slope = float(grad @ direction)
    assert abs(slope) > 10.0  # measured ≈ 38 N·s per unit of z (entries scaled by their size, floored per column)
    # h = 2e-6: a command moves by ≈ 6e-6 N, well inside the 1 mN corner (truncation ~1e-10
    # measured); rounding: 1e-16·265/2e-6 ≈ 1e-8 of the slope.
    fd = _central_difference(obj, z0, jnp.asarray(direction), 2e-6)
    assert slope == pytest.approx(fd, rel=1e-5)
    # One entry on its own too: the largest of the gain (measured 23.56 against 23.56 to 3e-9).
    k = int(np.argmax(np.abs(np.asarray(params[0].tunable.value)).reshape(-1)))
    fd_k = _central_difference(obj, z0, jnp.asarray(np.eye(96)[k]), 2e-6)
    assert abs(fd_k) > 1.0
    assert grad[k] == pytest.approx(fd_k, rel=1e-5)


# --- 2. a known optimum: the discrete-time LQR gain of a sampled double integrator ------------

T_S = 0.5  # control period = tick = record interval, s
INERTIA = 1.0  # kg·m², the same about every axis: no gyroscopic coupling
THETA0 = 1e-3  # initial rotation about body x, rad: sin(θ/2) = θ/2·(1 − 4e-8)
Q_THETA, Q_OMEGA, R_U = 1.0, 1.0, 1.0  # per-step weights on θ², ω², u²
N_RECORDS = 300  # 150 s: at the starting gains (spectral radius ≈ 0.74) θ ends at ~1e-40 of θ0

LQR_SCENARIO = f"""
name = "pid-lqr"
[sim]
t_final_s = {N_RECORDS * T_S}
dt_s = {T_S}
record_interval_s = {T_S}
[[spacecraft]]
inertia_kgm2 = [{INERTIA}, {INERTIA}, {INERTIA}]
q_bi = [{math.cos(THETA0 / 2)!r}, {math.sin(THETA0 / 2)!r}, 0.0, 0.0]
omega_b_rad_s = [0.0, 0.0, 0.0]
[controller]
kind = "attitude-pid"
period_s = {T_S}
k_p = 3.0
k_d = 3.0
k_i = 0.0
[actuators]
kind = "ideal-torque"
"""


def _riccati():
    """ZOH double integrator θ̈ = u/I sampled at T: (P, K) of Σ x'Qx + u'Ru, u = −Kx."""
    a = np.array([[1.0, T_S], [0.0, 1.0]])
    b = np.array([[T_S**2 / (2 * INERTIA)], [T_S / INERTIA]])
    q, r = np.diag([Q_THETA, Q_OMEGA]), np.array([[R_U]])
    p = scipy.linalg.solve_discrete_are(a, b, q, r)
    k = np.linalg.solve(r + b.T @ p @ b, b.T @ p @ a)
    return a, b, q, r, p, k.ravel()


def _lqr_cost_of_gain(gain):
    """Σ_k x'Qx + u'Ru of u = −Kx from x0 = (θ0, 0): x0' S x0 with S the discrete Lyapunov
    solution of the closed loop (independent of the simulator)."""
    a, b, q, r, _, _ = _riccati()
    k = np.asarray(gain, dtype=float)[None, :]
    acl = a - b @ k
    s = scipy.linalg.solve_discrete_lyapunov(acl.T, q + k.T @ r @ k)
    x0 = np.array([THETA0, 0.0])
    return float(x0 @ s @ x0)


def test_tuning_the_pid_gains_finds_the_riccati_optimum(tmp_path):
    path = tmp_path / "pid-lqr.toml"
    path.write_text(LQR_SCENARIO, encoding="utf-8")
    built = prepare(load_scenario(path))
    assert built.n_records == N_RECORDS and built.record_interval_s == T_S
    system = built.system
    kp0, kd0 = float(system.controller.k_p), float(system.controller.k_d)

    # attitude-pid offers no tunables, so the parameter map is built here (as the tuner's
    # positive scalars: θ0·e^z).
    def cost(z):
        ctrl = replace(system.controller, k_p=kp0 * jnp.exp(z[0]), k_d=kd0 * jnp.exp(z[1]))
        s = run_samples(replace(system, controller=ctrl), built.n_records)
        q = s["q"][:, 0, :]
        theta = 2.0 * jnp.arctan2(q[:, 1], q[:, 0])  # rotation about body x (exact for one axis)
        omega = s["omega"][:, 0, 0]
        u = s["torque"][:, 0, 0]  # the torque held over the period that starts at the sample
        return jnp.sum(Q_THETA * theta**2 + Q_OMEGA * omega**2 + R_U * u**2)

    _, _, _, _, p, k_star = _riccati()
    j_star = float(np.array([THETA0, 0.0]) @ p @ np.array([THETA0, 0.0]))
    cost_jit = jax.jit(cost)

    # The loop is the linear model to ~θ²: at the starting gains the simulated cost equals the
    # Lyapunov cost of K = (k_p/2, k_d) (measured 4.9e-8 apart), and it is well above J*.
    j_start = float(cost_jit(jnp.zeros(2)))
    assert j_start == pytest.approx(_lqr_cost_of_gain([kp0 / 2, kd0]), rel=1e-6)
    assert j_start > 1.3 * j_star  # measured 1.63

    opt = minimise(lambda z: cost(z)[None], np.zeros((1, 2)), 0, [(-3.0, 3.0)] * 2, max_iter=100, ftol=1e-12)
    z = opt.z[opt.best]
    j_tuned = float(cost_jit(jnp.asarray(z)))
    gain = np.array([kp0 * math.exp(z[0]) / 2, kd0 * math.exp(z[1])])
    assert j_tuned == pytest.approx(j_star, rel=1e-6)  # measured 7e-12
    np.testing.assert_allclose(gain, k_star, rtol=1e-4)  # measured 4.4e-6, 2.0e-6


# --- 3. the exact loop meets the constraint after tuning --------------------------------------


@pytest.mark.slow  # long: runs in CI's second pytest pass (README)
def test_tuned_consensus_gains_meet_the_constraint_on_the_exact_loop():
    # The scenario's own gains synchronise at 342.5 s on the exact loop: over the bound. Four
    # SLSQP steps reach α ≈ 0.67, β ≈ 3.14, which synchronise at 202.5 s (measured).
    spec = Spec("sync_time_s", 300.0)
    result = tune(
        "consensus-sync-a-saturated", "sync_time_s", {"sync_time_s": 300.0}, ["controller.alpha", "controller.beta"],
        overrides=["sim.t_final_s=400"], max_iter=4, report=lambda line: None,
    )
    assert result.constraints == [spec]
    assert not constraint_met(spec, result.exact_before["sync_time_s"])
    assert result.surrogate_after["constraints"][0] <= 0.0
    assert constraint_met(spec, result.exact_after["sync_time_s"])
    # The tuned values are those the re-run used (written as --set overrides).
    assert {o.split("=")[0] for o in result.overrides} == {"controller.alpha", "controller.beta"}
    for o in result.overrides:
        key, value = o.split("=")
        assert float(value) == pytest.approx(result.values[key], rel=1e-12)


# --- 4. the CLI's bad input: status 2, one line, no traceback ---------------------------------

SHORT = ["--set", "sim.t_final_s=1"]


def _bad(capsys, argv):
    status = main(["tune", "consensus-sync-a-saturated", *argv, *SHORT, "--quiet"])
    err = capsys.readouterr().err
    assert status == 2
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    return lines[0]


def test_cli_unknown_param_names_the_field_and_the_tunable_ones(capsys):
    line = _bad(capsys, ["--objective", "sync_time_s", "--params", "controller.gamma"])
    assert "controller.gamma" in line
    assert "controller.alpha" in line and "controller.beta" in line


@pytest.mark.parametrize("bound", [float("inf"), "300", True])
def test_a_constraint_bound_must_be_a_finite_number(bound):
    from coopsat.workflows.tune import TuneError, constraint_specs

    with pytest.raises(TuneError, match="^constraint sync_time_s <= .*: the bound must be a finite number$"):
        constraint_specs({"sync_time_s": bound})
    assert constraint_specs({"sync_time_s": 300}) == [Spec("sync_time_s", 300.0)]


def test_cli_constraint_without_le(capsys):
    line = _bad(capsys, ["--objective", "sync_time_s", "--constraint", "sync_time_s300", "--params", "controller.alpha"])
    assert "sync_time_s300" in line and "<=" in line


def test_cli_objective_without_surrogate(capsys):
    line = _bad(capsys, ["--objective", "final_attitude_spread_deg", "--params", "controller.alpha"])
    assert "final_attitude_spread_deg" in line
    assert "sync_time_s" in line  # what can be tuned on here


def test_cli_writes_a_replayable_tuned_scenario(capsys, tmp_path):
    """The tuned file is the scenario with the tuned value in place: loading it and running it
    gives the exact figure the tuner reported."""
    import json

    out = tmp_path / "tuned"
    status = main(["tune", "consensus-sync-a-saturated", "--objective", "sync_time_s", "--params", "controller.alpha",
                   "--set", "sim.t_final_s=20", "--max-iter", "2", "--out", str(out), "-q"])
    assert status == 0, capsys.readouterr().err
    assert sorted(p.name for p in out.iterdir()) == ["tune.json", "tune.md", "tuned.toml"]
    summary = json.loads((out / "tune.json").read_text())
    scenario = load_scenario(out / "tuned.toml")
    assert scenario.controller.alpha == pytest.approx(summary["values"]["controller.alpha"], rel=1e-12)
    assert scenario.sim.t_final_s == 20.0  # the --set overrides are in the file too
    # A second tuning into a folder that is not a tune folder is refused before any work.
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "keep.txt").write_text("x")
    status = main(["tune", "consensus-sync-a-saturated", "--objective", "sync_time_s", "--params", "controller.alpha",
                   "--out", str(tmp_path / "other"), "-q"])
    assert status == 2 and "not a tune folder" in capsys.readouterr().err


def test_graph_weights_enter_the_links_as_the_builder_puts_them():
    """network.edges: the tunable's traced weights equal those the scenario builder makes from
    the same edge list (an independent path: adjacency, then links), and the tuned file sets
    them where the graph is."""
    from coopsat.workflows.tune import _overrides, with_params

    built = prepare(load_scenario("consensus-sync-a-saturated", ["sim.t_final_s=1"]))
    (p,) = resolve_params(built, ["network.edges"])
    w0 = np.asarray(p.tunable.value)
    np.testing.assert_array_equal(w0, [1.0, 0.5, 0.5, 0.5, 0.5])  # SPEC §1 topology (a)
    w = np.array([0.3, 1.7, 0.9, 2.2, 0.4])
    traced = with_params(built.system, [p], [jnp.asarray(w)]).network.weight
    rebuilt = prepare(load_scenario("consensus-sync-a-saturated", ["sim.t_final_s=1", *_overrides([p], [w])]))
    np.testing.assert_allclose(np.asarray(traced), np.asarray(rebuilt.system.network.weight), rtol=0, atol=1e-15)
    assert not np.allclose(np.asarray(traced), np.asarray(built.system.network.weight))
    assert [e[2] for e in rebuilt.scenario.network.edges] == pytest.approx(w.tolist())
