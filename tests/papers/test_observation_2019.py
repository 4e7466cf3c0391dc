"""Cooperative Earth observation (SPEC §5): what the bundled scenarios and `coopsat pair` must do.

Independent references: conservation of the inertial angular momentum of bodies and wheels,
the pairing invariant (the reference flies the same law on the same noise in both runs, so its
record is bit-identical), the linearised jitter of law 8 under a white torque
(:func:`coopsat.plugins.observation.check_disturbance_budget` against a simulation), exact
tracking of the staring geometry without noise or disturbances, and the linear analysis of
:mod:`coopsat.design.observation` (law 23 with the reference's commanded acceleration equals
law 8), which the full paired runs must bear out.
"""

import re

import numpy as np
import pytest

from coopsat.astro.constants import J2_EARTH, MU_EARTH_M3_S2, R_EARTH_M
from coopsat.cli import EXIT_BAD_INPUT, main
from coopsat.workflows.pair import PairError, run_pair
from coopsat.workflows.analyse import analyse
from coopsat.workflows.pipeline import prepare, simulate_built
from coopsat.scenarios.load import ScenarioError
from coopsat.scenarios.load import bundled_text, load_scenario

COOP, INDEP, LITERAL = "observation-cooperative", "observation-independent", "observation-literal-disturbance"


def _early_target():
    """A target under the reference's ground track 60 s after the start: visible (above 10°) to
    both spacecraft from t = 0, so short runs stare."""
    from coopsat.design.observation_geometry import ground_track_point
    from coopsat.plugins.earth_environment import run_clock

    sc = load_scenario(COOP)
    built = prepare(sc)
    r0, v0 = built.context.r_eci_m[0], built.context.v_eci_m_s[0]
    earth = run_clock(sc.orbit, sc.sim.t_final_s).earth
    lat, lon = ground_track_point(r0, v0, 60.0, earth, MU_EARTH_M3_S2, J2_EARTH, R_EARTH_M, 10e3)
    return [f"controller.target_lat_deg={float(np.degrees(lat))!r}", f"controller.target_lon_deg={float(np.degrees(lon))!r}"]


def _without(text, kinds):
    """Scenario text with the array-of-tables entries of the given kinds removed."""
    blocks = re.split(r"\n(?=\[\[)", text)
    return "\n".join(b for b in blocks if not any(f'kind = "{k}"' in b.split("\n", 2)[1] for k in kinds))


def _variant(tmp_path, name, drop=(), replace=()):
    text = bundled_text(COOP)
    text = _without(text, drop).replace('name = "observation-cooperative"', f'name = "{name}"')
    for old, new in replace:
        assert old in text
        text = text.replace(old, new)
    path = tmp_path / f"{name}.toml"
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.slow  # long: runs in CI's second pytest pass (README)
def test_paired_runs_share_the_reference_bit_for_bit():
    """The reference flies law 8 in both scenarios on the same seed, so everything it does is
    identical; the follower, cooperating in one and not in the other, differs."""
    result = run_pair(INDEP, COOP, n_seeds=1, overrides=[*_early_target(), "sim.t_final_s=60"])
    error_a, error_b = (np.asarray(s.values) for s in result.series["attitude_error"])
    names = list(result.series["attitude_error"][0].spacecraft.values)
    ref, fol = names.index("reference"), names.index("follower")
    np.testing.assert_array_equal(error_a[..., ref], error_b[..., ref])
    assert not np.array_equal(error_a[..., fol], error_b[..., fol])
    metrics_a, metrics_b = result.metrics[0]
    assert metrics_a["stare_start_s_reference"] == 0.0 and metrics_b["stare_start_s_follower"] == 0.0
    rel_a, rel_b = (np.asarray(s.values) for s in result.series["relative_attitude_error"])
    assert np.isfinite(rel_a).any() and not np.array_equal(rel_a, rel_b)


def test_pair_refuses_scenarios_that_would_not_share_noise():
    with pytest.raises(PairError, match="at least 1"):
        run_pair(COOP, INDEP, n_seeds=0)
    with pytest.raises(PairError, match=r"differ in \[disturbances\]"):
        run_pair(COOP, LITERAL, n_seeds=1)


@pytest.mark.slow  # long: runs in CI's second pytest pass (README)
def test_bodies_and_wheels_conserve_angular_momentum(tmp_path):
    """No external torque (no disturbances, no magnetorquers): the wheels' speed error and the
    control only move momentum between wheels and bodies; |Σ C(q)(Iω + h)| stays 0."""
    path = _variant(tmp_path, "closed", drop=("gravity-gradient", "aerodynamic-torque", "solar-pressure-torque",
                                               "residual-dipole", "random-torque", "magnetorquers", "magnetometer"),
                    replace=[("dump_gain_1_s = 0.002", "dump_gain_1_s = 0.0")])
    built = prepare(load_scenario(path, [*_early_target(), "sim.t_final_s=60"]))
    ds, _ = simulate_built(built)
    metrics, _ = analyse(built, ds, compare=False)
    assert np.max(np.abs(ds["h_wheels"].values)) > 1e-3  # the slew did store momentum in the wheels
    assert metrics["angular_momentum_initial_nms"] < 1e-15
    assert metrics["angular_momentum_final_nms"] < 1e-12


def test_wheel_drives_stop_the_wheels_at_their_rated_speed():
    """Staring from t = 0, the switch runs wheels into their rated speed within 6 s (issue 26:
    they ran 2 % past it, the limit tested only at the sample). Every period is recorded. The
    drive cuts each wheel's torque so that its momentum at the end of the hold, less
    ``I_k g_k·ω`` at the hold's start, is within ``±I_k Ω_max`` to rounding (checked from the
    motor-impulse counters); the recorded speed relative to the body can then exceed the limit
    only by the body's own rate change over the hold, ``|g_k·Δω|`` (from the recorded ω)."""
    from coopsat.actuators.wheels import THREE_AXIS_PLUS_SKEW_B as G

    built = prepare(load_scenario(COOP, [*_early_target(), "sim.t_final_s=20", "sim.record_interval_s=0.1"]))
    ds, _ = simulate_built(built)
    metrics, _ = analyse(built, ds, compare=False)
    wheels = next(a for a in built.scenario.actuator_list if a.kind == "reaction-wheels")
    limit = np.asarray(wheels.max_speed_rpm) * np.pi / 30.0  # (4,) rad/s
    h_max = wheels.inertia_kgm2 * limit
    g_omega = ds["omega"].values @ G  # (time, spacecraft, wheel): g_k·ω, rad/s
    h = ds["wheel_angular_impulse"].values  # the wheels start at rest: the momentum is the impulse
    planned = (h[1:] - wheels.inertia_kgm2 * g_omega[:-1]) / h_max
    assert np.abs(planned).max() <= 1.0 + 1e-12
    fraction = np.abs(ds["wheel_speed"].values) / limit
    slack = np.abs(np.diff(g_omega, axis=0)) / limit
    assert np.all(fraction[1:] <= 1.0 + slack + 1e-12)
    limited = np.diff(ds["wheel_speed_limited_time"].values, axis=0) > 0.0
    assert np.abs(fraction[1:][limited] - 1.0).max() <= slack[limited].max() + 1e-12  # held at the limit
    for name in built.names:
        assert metrics[f"wheel_speed_limited_time_s_{name}"] > 1.0  # the limit was reached and held
        assert 1.0 <= metrics[f"wheel_speed_max_fraction_{name}"] < 1.0 + 1e-5  # against 1.02 before


@pytest.mark.slow  # long: runs in CI's second pytest pass (README)
def test_linearised_jitter_predicts_the_simulated_one():
    """check_disturbance-budget's σ_θ = σ √(T/(2 (k1/2) k2)) per axis against 300 s of the
    literal 1e-3 N·m torque while sun-pointing (the star tracker's 10″ adds < 1 %)."""
    built = prepare(load_scenario(LITERAL, ["sim.t_final_s=400"]))
    predicted = built.checks["disturbance-budget"].metrics["random_torque_jitter_deg"]
    ds, _ = simulate_built(built)
    t = ds["time"].values
    angle = np.degrees(ds["attitude_error"].values[t >= 100.0])  # (time, spacecraft), transient gone
    rms = np.sqrt(np.mean(angle**2))
    # The angle of a small 3-axis error is the norm of three axes of σ_θ each: RMS √3 σ_θ.
    # 300 s holds about 300 / (2 J / k2 ≈ 7 s) ≈ 45 correlation times per axis and spacecraft:
    # a relative standard error of about 1/√(2·45·3·2) ≈ 4 %; 20 % is five of those.
    assert rms == pytest.approx(np.sqrt(3.0) * predicted, rel=0.2)


def test_disturbance_budget_verdicts():
    default = prepare(load_scenario(COOP)).checks["disturbance-budget"]
    literal = prepare(load_scenario(LITERAL)).checks["disturbance-budget"]
    assert default.ok and not literal.ok
    assert literal.metrics["random_torque_wheel_fill_s"] < 1200.0 < default.metrics["random_torque_wheel_fill_s"]
    assert 0.04 < literal.metrics["random_torque_saturating_fraction"] < 0.05  # P(|N| > 2)


@pytest.mark.parametrize(
    ("override", "message"),
    [
        ("spacecraft.0.elements.a_m=6000000.0", "spacecraft reference: "),
        ("orbit.mu_m3_s2=1.32712440e20", "not the Earth's"),
        ("controller.reference=nobody", "controller.reference"),
    ],
)
def test_bad_designs_are_one_line_errors(override, message):
    with pytest.raises(ScenarioError, match=re.escape(message)):
        prepare(load_scenario(COOP, [override]))


def test_dumping_without_magnetorquers_is_an_error(tmp_path):
    path = _variant(tmp_path, "no-torquers", drop=("magnetorquers",))
    with pytest.raises(ScenarioError, match="needs a magnetorquers actuator"):
        prepare(load_scenario(path))


@pytest.mark.slow  # long: runs in CI's second pytest pass (README)
def test_a_target_that_never_rises_is_a_warning_not_a_stare():
    built = prepare(load_scenario(COOP, ["controller.target_lat_deg=60.0", "sim.t_final_s=20"]))
    check = built.checks["target-visibility"]
    assert not check.ok and "keep pointing at the Sun" in check.note
    ds, _ = simulate_built(built)
    metrics, _ = analyse(built, ds, compare=False)
    assert not ds["staring"].values.any()
    assert metrics["stare_start_s_reference"] is None and metrics["switch_convergence_s_reference"] is None


def test_cli_exit_2_on_an_orbit_inside_the_earth(tmp_path, capsys):
    out = tmp_path / "run"
    code = main(["run", COOP, "--out", str(out), "--set", "spacecraft.1.elements.a_m=6300000.0", "-q"])
    err = capsys.readouterr().err
    assert code == EXIT_BAD_INPUT
    assert err.count("\n") == 1 and "follower" in err and "Traceback" not in err
    assert not out.exists()


@pytest.mark.slow
def test_without_noise_or_disturbances_the_stare_tracks_the_geometry(tmp_path):
    """Law 8's feed-forward of the desired motion (exact derivatives of the line of sight) and
    the dumping torque fed forward to the wheels leave only the sampling: steady errors far
    below the paper's 0.02°."""
    path = _variant(tmp_path, "ideal", drop=("gravity-gradient", "aerodynamic-torque", "solar-pressure-torque",
                                              "residual-dipole", "random-torque", "star-tracker", "gyro", "sun-sensor"),
                    replace=[("speed_error_rpm_3sigma = 5.0", "speed_error_rpm_3sigma = 0.0")])
    built = prepare(load_scenario(path))
    ds, _ = simulate_built(built)
    m, _ = analyse(built, ds, compare=False)
    for name in ("reference", "follower"):
        assert m[f"switch_convergence_s_{name}"] < 250.0
        assert m[f"steady_attitude_error_max_deg_{name}"] < 0.002
    assert m["relative_attitude_error_max_deg"] < 0.002


@pytest.mark.slow
def test_cooperation_changes_the_relative_error_by_little():
    """design.observation: with the reference's commanded acceleration fed forward, law 23 is
    law 8 in the linear model, so on paired seeds the relative error moves by a few percent at
    most (the nonlinear and saturated parts are all that differ)."""
    result = run_pair(INDEP, COOP, n_seeds=2)
    for metrics_a, metrics_b in result.metrics:
        a, b = metrics_a["relative_attitude_error_rms_deg"], metrics_b["relative_attitude_error_rms_deg"]
        assert b == pytest.approx(a, rel=0.05)
