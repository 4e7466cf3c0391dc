"""The catalogue of a run's time series (coopsat.analysis.series): only what the run has."""

from types import SimpleNamespace

import numpy as np
import pytest
import xarray as xr

from coopsat.analysis.metrics import attitude_moves, run_metrics
from coopsat.analysis.series import formation_mean_quaternion, run_series, series_by_name
from coopsat.geometry.quaternion import quat_from_axis_angle

N_T, N_SAT = 20, 3
VEC = ("time", "spacecraft", "component")
QUAT = ("time", "spacecraft", "q_component")


def _record(**variables):
    coords = {"time": ("time", np.arange(N_T) * 1.0, {"units": "s"}), "spacecraft": [f"sat{k + 1}" for k in range(N_SAT)],
              "component": ["x", "y", "z"], "q_component": ["q0", "q1", "q2", "q3"]}
    return xr.Dataset({k: (dims, np.asarray(v, dtype=float), {"units": u}) for k, (dims, v, u) in variables.items()}, coords)


def _at_rest():
    q = np.zeros((N_T, N_SAT, 4))
    q[..., 0] = 1.0
    return {"q": (QUAT, q, "1"), "omega": (VEC, np.zeros((N_T, N_SAT, 3)), "rad/s")}


def _turning(angles_deg):
    """Spacecraft k turned by angles_deg[k] about z, at every sample."""
    q = np.asarray(quat_from_axis_angle(np.array([0.0, 0.0, 1.0]), np.radians(np.asarray(angles_deg, dtype=float))))
    rates = np.random.default_rng(1).normal(size=(N_T, N_SAT, 3))
    return {"q": (QUAT, np.broadcast_to(q, (N_T, N_SAT, 4)), "1"), "omega": (VEC, rates, "rad/s")}


def test_a_translation_only_run_has_no_attitude_series_and_no_attitude_metrics():
    rng = np.random.default_rng(0)
    ds = _record(**_at_rest(), r_eci=(VEC, rng.normal(size=(N_T, N_SAT, 3)), "m"),
                 v_eci=(VEC, rng.normal(size=(N_T, N_SAT, 3)), "m/s"),
                 force=(VEC, rng.normal(size=(N_T, N_SAT, 3)), "N"),
                 abs_force_impulse=(VEC, np.cumsum(rng.random((N_T, N_SAT, 3)), axis=0), "N s"))
    names = [s.name for s in run_series(ds)]
    assert names == ["distance_to_centroid_m", "speed_to_centroid_m_s", "force_n", "fuel_n_s"]
    assert not attitude_moves(ds)
    metrics = run_metrics(ds, ["a", "b", "c"], np.broadcast_to(np.eye(3), (N_SAT, 3, 3)), attitude=attitude_moves(ds))
    assert "final_rate_max_rad_s" not in metrics and "angular_momentum_final_nms" not in metrics


def test_a_recorded_torque_or_an_initial_rate_means_the_attitude_is_simulated():
    at_rest = _record(**_at_rest())
    assert not attitude_moves(at_rest)
    assert attitude_moves(_record(**_at_rest(), torque=(VEC, np.zeros((N_T, N_SAT, 3)), "N m")))
    assert attitude_moves(at_rest, initial_rate_rad_s=[[0.0, 0.1, 0.0]])


def test_attitude_errors_are_angles_in_degrees_with_the_scenarios_thresholds():
    ds = _record(**_turning([0.0, 10.0, 30.0]), torque=(VEC, np.ones((N_T, N_SAT, 3)), "N m"))
    ds["q_ref"] = (("time", "q_component"), np.tile([1.0, 0.0, 0.0, 0.0], (N_T, 1)), {"units": "1"})
    analysis = SimpleNamespace(sync_attitude_deg=2.0, sync_rate_rad_s=0.05)
    s = series_by_name(run_series(ds, analysis))
    ref = s["attitude_error_reference_deg"]
    assert ref.unit == "deg" and ref.log_scale and ref.values.dims == ("time", "spacecraft")
    np.testing.assert_allclose(ref.values.values, np.tile([0.0, 10.0, 30.0], (N_T, 1)), atol=1e-9)
    np.testing.assert_allclose(s["attitude_spread_deg"].values.values, 30.0)
    assert s["attitude_spread_deg"].threshold == 2.0 and s["rate_spread_rad_s"].threshold == 0.05
    # The formation's mean of 0°, 10°, 30° about one axis lies between them: 40/3° near enough.
    np.testing.assert_allclose(s["attitude_error_formation_deg"].values.values[0], [13.3, 3.3, 16.7], atol=0.1)
    assert "q_component" not in {d for x in s.values() for d in x.values.dims}  # no raw quaternion components


def test_the_mean_attitude_ignores_the_sign_of_each_quaternion():
    q = np.asarray(quat_from_axis_angle(np.array([1.0, 0.0, 0.0]), np.radians([5.0, 15.0])))[None]
    flipped = q * np.array([1.0, -1.0])[None, :, None]
    np.testing.assert_allclose(formation_mean_quaternion(flipped), formation_mean_quaternion(q))


def test_wheels_and_thrusters_appear_only_when_recorded_and_active():
    rng = np.random.default_rng(2)
    base = {**_turning([0.0, 1.0, 2.0]), "torque": (VEC, rng.normal(size=(N_T, N_SAT, 3)), "N m")}
    plain = {s.name for s in run_series(_record(**base))}
    assert not any(n.startswith(("wheel_", "thruster_")) for n in plain)
    ds = _record(**base, h_wheels=(VEC, rng.normal(size=(N_T, N_SAT, 3)), "N m s"))
    ds["wheel_speed"] = (("time", "spacecraft", "wheel"), rng.normal(size=(N_T, N_SAT, 4)), {"units": "rad/s"})
    ds["thruster_firings"] = (("time", "spacecraft", "thruster"), np.zeros((N_T, N_SAT, 6)), {"units": "1"})
    s = series_by_name(run_series(ds))
    assert s["wheel_speed_rad_s"].values.dims == ("time", "spacecraft", "wheel")
    np.testing.assert_allclose(s["wheel_momentum_n_m_s"].values.values, np.linalg.norm(ds["h_wheels"].values, axis=-1))
    assert "thruster_firings" not in s  # recorded, but never fired: a flat line says nothing


@pytest.mark.parametrize("nan", [False, True])
def test_a_series_zero_or_nan_at_every_sample_is_left_out(nan):
    torque = np.full((N_T, N_SAT, 3), np.nan if nan else 0.0)
    names = {s.name for s in run_series(_record(**_turning([0.0, 1.0, 2.0]), torque=(VEC, torque, "N m")))}
    assert "torque_n_m" not in names and "rate_rad_s" in names


def test_the_small_angle_model_gives_angles_in_degrees_and_their_spread():
    angle = np.zeros((N_T, N_SAT, 3))
    angle[:, 1, 0] = np.radians(2.0)
    ds = _record(angle=(VEC, angle, "rad"), omega=(VEC, np.zeros((N_T, N_SAT, 3)), "rad/s"))
    s = series_by_name(run_series(ds))
    np.testing.assert_allclose(s["attitude_angle_deg"].values.sel(spacecraft="sat2", component="x"), 2.0)
    np.testing.assert_allclose(s["attitude_spread_deg"].values, 2.0)
    assert "rate_rad_s" not in s  # zero throughout
