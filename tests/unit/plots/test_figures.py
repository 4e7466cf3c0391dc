import numpy as np
import pytest
import xarray as xr
from matplotlib.figure import Figure

from coopsat.analysis.metrics import pairwise_attitude_error_deg
from coopsat.plots.figures import (
    LOG_FLOOR,
    attitude_figure,
    rate_figure,
    save_figures,
    standard_figures,
    sync_error_figure,
    torque_figure,
)

N_SAT, N_T = 3, 50
NAMES = [f"sat{i + 1}" for i in range(N_SAT)]


def _unit(x):
    return x / np.linalg.norm(x, axis=-1, keepdims=True)


def make_dataset(tracking, thrusters):
    rng = np.random.default_rng(0)
    vec = ("time", "spacecraft", "component")
    q_dims = ("time", "spacecraft", "q_component")
    data = {
        "q": (q_dims, _unit(rng.normal(size=(N_T, N_SAT, 4))), {"units": "1"}),
        "omega": (vec, rng.normal(size=(N_T, N_SAT, 3)), {"units": "rad/s"}),
        "torque": (vec, rng.normal(size=(N_T, N_SAT, 3)), {"units": "N m"}),
        "torque_command": (vec, rng.normal(size=(N_T, N_SAT, 3)), {"units": "N m"}),
        "impulse": (vec, np.cumsum(rng.random((N_T, N_SAT, 3)), axis=0), {"units": "N m s"}),
    }
    coords = {
        "time": ("time", np.arange(N_T) * 0.5, {"units": "s"}),
        "spacecraft": NAMES,
        "component": ["x", "y", "z"],
        "q_component": ["q0", "q1", "q2", "q3"],
    }
    if tracking:
        data["q_ref"] = (("time", "q_component"), _unit(rng.normal(size=(N_T, 4))), {"units": "1"})
    if thrusters:
        coords["thruster"] = ["+x", "-x", "+y", "-y", "+z", "-z"]
        on_time = np.cumsum(rng.random((N_T, N_SAT, 6)), axis=0)
        data["thruster_on_time"] = (("time", "spacecraft", "thruster"), on_time, {"units": "s"})
    for name in data:
        data[name][2]["long_name"] = name
    return xr.Dataset(data, coords=coords, attrs={"scenario_name": "synthetic"})


@pytest.fixture(params=[(False, False), (True, True)], ids=["regulation", "tracking"])
def ds(request):
    return make_dataset(*request.param)


def _line_counts(fig):
    return [len(ax.get_lines()) for ax in fig.axes]


def test_attitude_figure(ds):
    fig = attitude_figure(ds)
    assert isinstance(fig, Figure)
    assert _line_counts(fig) == [N_SAT + ("q_ref" in ds)] * 4
    assert fig.axes[-1].get_xlabel() == "time [s]"


def test_rate_figure(ds):
    fig = rate_figure(ds)
    assert isinstance(fig, Figure)
    assert _line_counts(fig) == [N_SAT] * 3
    omega_z_sat2 = fig.axes[2].get_lines()[1].get_ydata()
    np.testing.assert_array_equal(omega_z_sat2, ds["omega"].values[:, 1, 2])


def test_torque_figure_by_name_or_index(ds):
    by_name, by_index = torque_figure(ds, "sat2"), torque_figure(ds, 1)
    assert _line_counts(by_name) == [2] * 3
    for k, (ax_name, ax_index) in enumerate(zip(by_name.axes, by_index.axes)):
        applied, commanded = ax_name.get_lines()
        assert applied.get_drawstyle() == "steps-post"
        np.testing.assert_array_equal(applied.get_ydata(), ds["torque"].values[:, 1, k])
        np.testing.assert_array_equal(commanded.get_ydata(), ds["torque_command"].values[:, 1, k])
        np.testing.assert_array_equal(ax_index.get_lines()[0].get_ydata(), applied.get_ydata())
    assert "sat2" in by_name.get_suptitle()


def test_sync_error_figure(ds):
    tracking = "q_ref" in ds
    fig = sync_error_figure(ds)
    assert _line_counts(fig) == [1, 1] + ([N_SAT] if tracking else [])
    assert all(ax.get_yscale() == "log" for ax in fig.axes)
    expected = np.maximum(pairwise_attitude_error_deg(ds["q"].values), LOG_FLOOR)
    np.testing.assert_allclose(fig.axes[0].get_lines()[0].get_ydata(), expected)


def test_sync_error_clips_zero_and_draws_thresholds():
    ds = make_dataset(tracking=True, thrusters=False)
    # Identity everywhere: exactly zero error (random equal quaternions leave ~1e-6 deg of
    # round-off in the metric), and equal rates: exactly zero rate difference.
    ds["q"][:] = ds["q_ref"][:] = [1.0, 0.0, 0.0, 0.0]
    ds["omega"][:] = 0.01
    fig = sync_error_figure(ds, attitude_threshold_deg=0.1, rate_threshold_rad_s=1e-3)
    assert _line_counts(fig) == [2, 2, N_SAT + 1]
    for ax in fig.axes:
        assert np.all(ax.get_lines()[0].get_ydata() == LOG_FLOOR)
    assert fig.axes[1].get_lines()[1].get_ydata()[0] == 1e-3


def test_standard_and_save_figures(ds, tmp_path):
    figures = standard_figures(ds, attitude_threshold_deg=1.0)
    assert list(figures) == ["attitude", "rates", "torque_sat1", "sync_error"]
    paths = save_figures(figures, str(tmp_path / "out"), dpi=40)
    assert [p.name for p in paths] == [f"{stem}.png" for stem in figures]
    for path in paths:
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_figures_without_a_commanded_or_any_torque():
    # No controller: no torque_command; force actuators only: no torque at all.
    free = make_dataset(tracking=False, thrusters=False).drop_vars("torque_command")
    assert set(standard_figures(free)) == {"attitude", "rates", "torque_sat1", "sync_error"}
    assert len(torque_figure(free).axes[0].lines) == 1  # the applied torque only
    forces_only = free.drop_vars("torque")
    assert set(standard_figures(forces_only)) == {"attitude", "rates", "sync_error"}


def test_a_long_switching_record_is_drawn_per_window_with_legends_beside_the_data():
    # 2000 samples of bang-bang torque (PWM at the published period): drawn as at most
    # WINDOWS steps of the window mean, with the min–max band, not as a solid block.
    from coopsat.plots.figures import WINDOWS

    n_t = 2000
    t = np.arange(n_t) * 0.5
    sign = np.where(np.arange(n_t) % 2 == 0, 1.0, -1.0)
    torque = 0.05 * np.broadcast_to(sign[:, None, None], (n_t, 1, 3)).copy()
    ds = xr.Dataset(
        {"torque": (("time", "spacecraft", "component"), torque, {"units": "N m"})},
        coords={"time": ("time", t, {"units": "s"}), "spacecraft": ["sat1"], "component": ["x", "y", "z"]},
    )
    fig = torque_figure(ds)
    ax = fig.axes[0]
    mean_line = ax.lines[0]
    assert len(mean_line.get_xdata()) <= WINDOWS
    np.testing.assert_allclose(mean_line.get_ydata(), 0.0, atol=1e-15)  # the mean of ±0.05 is 0
    assert len(ax.collections) == 1  # the min–max band
    assert ax.get_legend() is None and len(fig.legends) == 1  # the legend is outside the axes
