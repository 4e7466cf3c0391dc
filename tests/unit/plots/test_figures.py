"""The standard figures (coopsat.plots.figures): drawn from the run's catalogue of series, only
what the run has, attitude as angles in degrees, the commanded torque inside the axes, one unit
style on every axis."""

import re

import numpy as np
import pytest
import xarray as xr
from matplotlib.figure import Figure

from coopsat.analysis.series import run_series, series_by_name
from coopsat.geometry.quaternion import quat_from_axis_angle
from coopsat.plots.figures import LOG_FLOOR, WINDOWS, figure_makers, save_figures, standard_figures, torque_figure

N_SAT, N_T = 3, 50
NAMES = [f"sat{i + 1}" for i in range(N_SAT)]
VEC = ("time", "spacecraft", "component")


def _unit(x):
    return x / np.linalg.norm(x, axis=-1, keepdims=True)


def make_dataset(tracking=False, thrusters=False, wheels=False, n_t=N_T):
    rng = np.random.default_rng(0)
    data = {
        "q": (("time", "spacecraft", "q_component"), _unit(rng.normal(size=(n_t, N_SAT, 4))), {"units": "1"}),
        "omega": (VEC, rng.normal(size=(n_t, N_SAT, 3)), {"units": "rad/s"}),
        "torque": (VEC, 0.05 * np.sign(rng.normal(size=(n_t, N_SAT, 3))), {"units": "N m"}),
        "torque_command": (VEC, 0.015 * rng.normal(size=(n_t, N_SAT, 3)), {"units": "N m"}),
        "impulse": (VEC, np.cumsum(rng.random((n_t, N_SAT, 3)), axis=0), {"units": "N m s"}),
    }
    coords = {"time": ("time", np.arange(n_t) * 0.5, {"units": "s"}), "spacecraft": NAMES, "component": ["x", "y", "z"],
              "q_component": ["q0", "q1", "q2", "q3"]}
    if tracking:
        data["q_ref"] = (("time", "q_component"), _unit(rng.normal(size=(n_t, 4))), {"units": "1"})
    if thrusters:
        coords["thruster"] = ["+x", "-x", "+y", "-y", "+z", "-z"]
        data["thruster_on_time"] = (("time", "spacecraft", "thruster"), np.cumsum(rng.random((n_t, N_SAT, 6)), axis=0),
                                    {"units": "s"})
        data["thruster_firings"] = (("time", "spacecraft", "thruster"), np.cumsum(rng.integers(0, 2, (n_t, N_SAT, 6)), axis=0),
                                    {"units": "1"})
    if wheels:
        coords["wheel"] = ["w1", "w2", "w3", "w4"]
        data["wheel_speed"] = (("time", "spacecraft", "wheel"), rng.normal(size=(n_t, N_SAT, 4)), {"units": "rad/s"})
        data["h_wheels"] = (VEC, rng.normal(size=(n_t, N_SAT, 3)), {"units": "N m s"})
    return xr.Dataset(data, coords=coords, attrs={"scenario_name": "synthetic"})


def translation_only():
    """A deep-space-like record: attitude at rest and never torqued, positions and forces."""
    rng = np.random.default_rng(1)
    q = np.zeros((N_T, N_SAT, 4))
    q[..., 0] = 1.0
    return xr.Dataset(
        {"q": (("time", "spacecraft", "q_component"), q, {"units": "1"}),
         "omega": (VEC, np.zeros((N_T, N_SAT, 3)), {"units": "rad/s"}),
         "r_eci": (VEC, 1e3 * rng.normal(size=(N_T, N_SAT, 3)), {"units": "m"}),
         "v_eci": (VEC, rng.normal(size=(N_T, N_SAT, 3)), {"units": "m/s"}),
         "force": (VEC, rng.normal(size=(N_T, N_SAT, 3)), {"units": "N"})},
        coords={"time": ("time", np.arange(N_T) * 50.0, {"units": "s"}), "spacecraft": NAMES, "component": ["x", "y", "z"],
                "q_component": ["q0", "q1", "q2", "q3"]})


def axis_labels(figures):
    return [label for fig in figures.values() for ax in fig.axes for label in (ax.get_xlabel(), ax.get_ylabel()) if label]


def check_unit_style(figures):
    """Every unit in parentheses, none in brackets (docs: one unit style)."""
    labels = axis_labels(figures)
    assert labels and not [label for label in labels if re.search(r"\[[^\]]*\]", label)]
    assert all(label == "time (s)" for label in labels if label.startswith("time"))


def check_command_inside(fig):
    """Every line and band drawn on a torque figure's axes lies within its y-limits."""
    for ax in fig.axes:
        low, high = ax.get_ylim()
        for line in ax.get_lines():
            y = np.asarray(line.get_ydata(), dtype=float)
            assert low <= y.min() and y.max() <= high, ax.get_ylabel()
        for band in ax.collections:
            y = np.concatenate([p.vertices[:, 1] for p in band.get_paths()])
            assert low <= y.min() and y.max() <= high, ax.get_ylabel()


def test_a_consensus_like_run_draws_attitude_errors_in_degrees_not_quaternions():
    ds = make_dataset(thrusters=True)
    figures = standard_figures(ds)
    assert list(figures) == ["attitude", "rates", "torque_sat1", "sync_error", "thrusters"]
    (ax,) = figures["attitude"].axes
    assert ax.get_ylabel() == "attitude error\nto the formation's mean (deg)"
    assert len(ax.get_lines()) == N_SAT
    expected = series_by_name(run_series(ds))["attitude_error_formation_deg"].values.values
    np.testing.assert_allclose(ax.get_lines()[1].get_ydata(), np.maximum(expected[:, 1], LOG_FLOOR))
    assert not any("q0" in label or "q_component" in label for label in axis_labels(figures))
    check_unit_style(figures)


def test_tracking_adds_the_error_to_the_reference_and_thresholds_come_from_the_analysis_table():
    from types import SimpleNamespace

    ds = make_dataset(tracking=True)
    figures = standard_figures(ds, SimpleNamespace(sync_attitude_deg=0.5, sync_rate_rad_s=2e-3))
    assert [ax.get_ylabel() for ax in figures["attitude"].axes] == [
        "attitude error\nto the reference (deg)", "attitude error\nto the formation's mean (deg)"]
    spread, rate = figures["sync_error"].axes
    assert [line.get_ydata()[0] for line in spread.get_lines()[1:]] == [0.5]  # the dotted threshold
    assert rate.get_lines()[1].get_ydata()[0] == 2e-3
    assert spread.get_yscale() == "log" or np.ptp(spread.get_lines()[0].get_ydata()) < 180.0


def test_a_translation_only_run_has_no_attitude_rate_or_sync_figure():
    figures = standard_figures(translation_only())
    assert list(figures) == ["relative_motion"]
    check_unit_style(figures)


def test_wheels_get_their_figure_only_when_the_run_has_wheels():
    assert "wheels" not in figure_makers(make_dataset())
    fig = standard_figures(make_dataset(wheels=True))["wheels"]
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert labels == [f"{n}\nwheel speed (rad/s)" for n in NAMES] + ["wheel\nmomentum ‖h‖ (N m s)"]
    assert len(fig.axes[0].get_lines()) == 4  # one line per wheel


def test_the_commanded_torque_stays_inside_the_axes():
    ds = make_dataset()
    fig = standard_figures(ds)["torque_sat1"]
    assert len(fig.axes) == 3 and len(fig.axes[0].get_lines()) == 2  # overlaid: the command is within 2x
    check_command_inside(fig)
    # A command 100 times the applied torque (a saturated, unstable loop) gets its own panels.
    wild = ds.assign(torque_command=ds["torque_command"] * 100.0)
    fig = standard_figures(wild)["torque_sat1"]
    assert len(fig.axes) == 6
    check_command_inside(fig)
    assert fig.axes[3].get_ylim()[1] > 50 * fig.axes[0].get_ylim()[1]


def test_a_long_switching_record_is_drawn_per_window_with_legends_beside_the_data():
    n_t = 2000
    ds = make_dataset(n_t=n_t)
    sign = np.where(np.arange(n_t) % 2 == 0, 1.0, -1.0)
    ds["torque"][:] = 0.05 * sign[:, None, None]
    fig = torque_figure(ds, series_by_name(run_series(ds)), "sat2")
    ax = fig.axes[0]
    mean_line = ax.lines[0]
    assert len(mean_line.get_xdata()) <= WINDOWS
    np.testing.assert_allclose(mean_line.get_ydata(), 0.0, atol=1e-15)  # the mean of ±0.05 is 0
    assert len(ax.collections) == 2  # the min–max bands of the applied torque and of the command
    assert ax.get_legend() is None and len(fig.legends) == 1  # the legend is outside the axes
    assert "sat2" in fig.get_suptitle()
    check_command_inside(fig)


def test_small_angle_runs_draw_angles_in_degrees():
    rng = np.random.default_rng(3)
    ds = xr.Dataset(
        {"angle": (VEC, rng.normal(size=(20, N_SAT, 3)) * 1e-2, {"units": "rad"}),
         "omega": (VEC, rng.normal(size=(20, N_SAT, 3)) * 1e-3, {"units": "rad/s"}),
         "torque": (VEC, rng.normal(size=(20, N_SAT, 3)) * 1e-4, {"units": "N m"})},
        coords={"time": ("time", np.arange(20) * 0.1, {"units": "s"}), "spacecraft": NAMES, "component": ["x", "y", "z"]})
    figures = standard_figures(ds.assign(angle=ds["angle"].transpose("spacecraft", "component", "time")))
    assert list(figures) == ["attitude", "rates", "torque_sat1", "sync_error"]
    axes = figures["attitude"].axes
    assert [ax.get_ylabel() for ax in axes] == ["θ_x (deg)", "θ_y (deg)", "θ_z (deg)"]
    np.testing.assert_allclose(axes[1].get_lines()[2].get_ydata(), np.degrees(ds["angle"].values[:, 2, 1]))
    check_unit_style(figures)


def test_a_quaternion_run_without_a_torque_has_no_torque_figure():
    q = np.asarray(quat_from_axis_angle(np.array([0.0, 0.0, 1.0]), np.linspace(0.0, 1.0, N_T)))
    ds = make_dataset().drop_vars(["torque", "torque_command", "impulse"])
    ds["q"][:] = np.broadcast_to(q[:, None, :], (N_T, N_SAT, 4))
    assert list(standard_figures(ds)) == ["attitude", "rates", "sync_error"]


def test_save_figures_writes_pngs(tmp_path):
    figures = standard_figures(make_dataset())
    paths = save_figures(figures, str(tmp_path / "out"), dpi=40)
    assert [p.name for p in paths] == [f"{stem}.png" for stem in figures]
    assert all(isinstance(f, Figure) for f in figures.values())
    for path in paths:
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("stem", ["attitude", "torque_sat1"])
def test_figure_makers_draw_only_when_called(stem):
    makers = figure_makers(make_dataset())
    assert isinstance(makers[stem](), Figure)


# Every bundled scenario at a short horizon (those of tests/scenarios/test_bundled.py): its
# figures, the standard ones and its papers', show only what it has, in one unit style.
def _short_s(name):
    if name.startswith("deepspace-"):
        return 500.0
    return {"orbit-two-body": 100.0, "rigid-body-free": 2.0, "leo-iss-tle-roe": 120.0, "leo-swarm-100": 40.0}.get(
        name, 200.0 if name.startswith("cartwheel-") else 5.0)


def _bundled():
    from coopsat.scenarios.load import bundled_names

    return bundled_names()


@pytest.mark.slow
@pytest.mark.parametrize("name", _bundled())
def test_every_bundled_scenarios_figures_show_only_what_it_has(name, release_after):
    import coopsat
    from coopsat.analysis.metrics import attitude_moves

    result = coopsat.run(coopsat.Scenario.load(name).set("sim.t_final_s", _short_s(name)))
    ds, figures = result.dataset, result.figures()
    attitude = {"attitude", "rates", "sync_error"} & set(figures)
    moves = attitude_moves(ds)
    assert bool(attitude) == moves, name  # deep space, cartwheel: no attitude figure
    assert ("final_rate_max_rad_s" in result.metrics) == moves  # nor attitude metrics
    assert ("wheels" in figures) == ("wheel_speed" in ds)  # the observation runs have wheels
    assert ("thrusters" in figures) == ("thruster_firings" in ds and bool(ds["thruster_firings"].any()))
    if "attitude" in figures:
        assert all(ax.get_ylabel().endswith("(deg)") for ax in figures["attitude"].axes)
    torque = f"torque_{ds['spacecraft'].values[0]}"
    if torque in figures:
        check_command_inside(figures[torque])
    check_unit_style(figures)
