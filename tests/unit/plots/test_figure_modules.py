"""Every figure module under coopsat.plots draws the data it claims to show.

The three paper families (cartwheel keeping, Earth observation, deep-space formation) each get
one short run of a bundled scenario (the horizons of tests/scenarios/test_bundled.py, so a
warm compilation cache serves both), whose run folder is written *with* its figures; the
figures are then drawn again straight from the run's dataset and checked line by line against
quantities recomputed here from the dataset's raw variables (our own LVLH frame, quaternion
angles, centroid drift, unit conversions). The array-only modules (pair, sweep, campaign, the
formation trade-off figures, the small-angle attitude figure) are drawn from synthetic arrays.
"""

import tomllib
from types import SimpleNamespace

import matplotlib

matplotlib.use("Agg")

import matplotlib.image as mpimg  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
import xarray as xr  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

import coopsat  # noqa: E402
from coopsat.analysis.papers.cartwheel_keeping import ideal_states, truth_errors  # noqa: E402
from coopsat.plots import campaign as campaign_plots  # noqa: E402
from coopsat.plots import cartwheel as cartwheel_plots  # noqa: E402
from coopsat.plots import formation as formation_plots  # noqa: E402
from coopsat.plots import observation as observation_plots  # noqa: E402
from coopsat.plots import pair as pair_plots  # noqa: E402
from coopsat.plots import sweep as sweep_plots  # noqa: E402

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
SAVE_DPI = 120  # Result.save -> save_figures' default


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def _run(name, t_final_s):
    result = coopsat.run(coopsat.Scenario.load(name).set("sim.t_final_s", t_final_s))
    resolved = tomllib.loads(result.dataset.attrs["scenario_toml"])
    return SimpleNamespace(result=result, ds=result.dataset, built=result.built, toml=resolved)


@pytest.fixture(scope="module")
def cartwheel_run():
    return _run("cartwheel-keeping-ground", 200.0)


@pytest.fixture(scope="module")
def observation_run():
    return _run("observation-independent", 5.0)


@pytest.fixture(scope="module")
def deepspace_run():
    return _run("deepspace-square-to-line-lqr", 500.0)


def _lines(ax):
    return ax.get_lines()


def _data_lines(ax):
    """The lines that carry data over time (not axhline/axvline, whose data has 2 points in
    axes coordinates)."""
    return [line for line in ax.get_lines() if line.get_transform() == ax.transData]


def _png_size(path):
    """(width, height) from the IHDR chunk; the file must also decode as an image."""
    raw = path.read_bytes()
    assert raw[:8] == PNG_SIGNATURE and raw[12:16] == b"IHDR"
    size = int.from_bytes(raw[16:20], "big"), int.from_bytes(raw[20:24], "big")
    image = mpimg.imread(path)
    assert image.shape[:2] == (size[1], size[0])
    assert np.ptp(image[..., :3]) > 0  # not a blank canvas
    return size


ATTITUDE_FIGURES = {"attitude", "rates", "sync_error"}


def _check_run_folder(run, tmp_path, paper_stems, attitude=True):
    """Result.save with figures: one valid PNG per figure of Result.figures(), each the size
    of the figure it claims to be, the paper's own among them; the attitude figures exactly
    when the run simulates attitude (a translation-only run has none, issue 29)."""
    figures = run.result.figures()
    assert set(paper_stems) <= set(figures)
    assert ATTITUDE_FIGURES <= set(figures) if attitude else ATTITUDE_FIGURES.isdisjoint(figures)
    folder = run.result.save(tmp_path / "run", figures=True)
    pngs = {p.stem: p for p in folder.glob("*.png")}
    assert set(pngs) == set(figures)
    for stem, fig in figures.items():
        width, height = fig.get_size_inches() * SAVE_DPI
        assert _png_size(pngs[stem]) == (round(width), round(height)), stem


# --------------------------------------------------------------------------------------------
# Cartwheel keeping: plots/cartwheel.py


def _lvlh(r_c, v_c, r_d, v_d):
    """Deputy relative to the chief in the chief's LVLH (docs/conventions.md: x along-track,
    y along the negative orbit normal, z to the Earth's centre; velocity seen in the frame,
    which turns at the Keplerian rate (r × v)/|r|²). Our own, independent of geometry.frames."""
    h = np.cross(r_c, v_c)
    z = -r_c / np.linalg.norm(r_c, axis=-1, keepdims=True)
    y = -h / np.linalg.norm(h, axis=-1, keepdims=True)
    x = np.cross(y, z)
    c = np.stack([x, y, z], axis=-2)  # rows: the LVLH axes in ECI
    omega = h / np.sum(r_c**2, axis=-1, keepdims=True)
    dr = r_d - r_c
    dv = v_d - v_c - np.cross(omega, dr)
    return np.einsum("...ij,...j->...i", c, dr), np.einsum("...ij,...j->...i", c, dv)


def test_cartwheel_run_folder_has_every_figure(cartwheel_run, tmp_path):
    _check_run_folder(cartwheel_run, tmp_path, ["position_error", "velocity_error", "impulse_bits", "relative_motion"],
                      attitude=False)


def test_cartwheel_error_figures_draw_the_truth_error_in_the_chiefs_lvlh(cartwheel_run):
    ds, built, toml = cartwheel_run.ds, cartwheel_run.built, cartwheel_run.toml
    chief_name, deputy_names = toml["controller"]["chief"], toml["controller"]["deputies"]
    names = [str(s) for s in ds["spacecraft"].values]
    chief, deputies = names.index(chief_name), [names.index(d) for d in deputy_names]
    r, v = ds["r_eci"].values, ds["v_eci"].values
    rho, rho_dot = _lvlh(r[:, [chief]], v[:, [chief]], r[:, deputies], v[:, deputies])
    ideal = ideal_states(ds, built, deputies)  # the circle's point: the plug-in's target
    t = ds["time"].values

    figs = cartwheel_plots.figures(ds, built)
    assert list(figs) == ["position_error", "velocity_error", "impulse_bits"]
    for stem, unit, ours in (("position_error", "m", rho - ideal[..., :3]), ("velocity_error", "m/s", rho_dot - ideal[..., 3:])):
        fig = figs[stem]
        assert len(fig.axes) == len(deputy_names)  # one panel per deputy, none for the chief
        assert fig.axes[-1].get_xlabel() == "time (s)"
        for k, (ax, name) in enumerate(zip(fig.axes, deputy_names)):
            assert ax.get_ylabel() == f"{name} ({unit})"
            lines = _lines(ax)
            assert [line.get_label() for line in lines] == ["x (along-track)", "y (−orbit normal)", "z (nadir)"]
            for c, line in enumerate(lines):
                np.testing.assert_array_equal(line.get_xdata(), t)
                atol = 1e-6 if unit == "m" else 1e-8
                np.testing.assert_allclose(line.get_ydata(), ours[:, k, c], rtol=0, atol=atol, err_msg=f"{stem} {name} {c}")
    # And the error the paper module hands the figure is the one drawn.
    pos, vel, err_names = truth_errors(ds, built)
    assert err_names == deputy_names
    np.testing.assert_array_equal(_lines(figs["position_error"].axes[1])[2].get_ydata(), pos[:, 1, 2])
    np.testing.assert_array_equal(_lines(figs["velocity_error"].axes[2])[0].get_ydata(), vel[:, 2, 0])


def test_cartwheel_bits_figure_counts_each_deputys_bits_over_all_axes(cartwheel_run):
    ds, built, toml = cartwheel_run.ds, cartwheel_run.built, cartwheel_run.toml
    names = [str(s) for s in ds["spacecraft"].values]
    fig = cartwheel_plots.bits_figure(ds, built)
    (ax,) = fig.axes
    lines = _lines(ax)
    assert [line.get_label() for line in lines] == toml["controller"]["deputies"]  # the chief fires nothing
    bits = ds["impulse_bits"]
    for line in lines:
        k = names.index(line.get_label())
        np.testing.assert_array_equal(line.get_ydata(), bits.isel(spacecraft=k).sum("component").values)
        assert np.all(np.diff(line.get_ydata()) >= 0)  # a cumulative count
    assert "impulse bits" in ax.get_ylabel() and ax.get_xlabel() == "time (s)"


# --------------------------------------------------------------------------------------------
# Earth observation: plots/observation.py


def _quat_angle(q, p):
    """Angle of q_p* ⊗ q (rad), as 2·atan2(|vec|, |scalar|) of the error quaternion."""
    p_conj = p * np.array([1.0, -1.0, -1.0, -1.0])
    w1, v1 = p_conj[..., :1], p_conj[..., 1:]
    w2, v2 = q[..., :1], q[..., 1:]
    w = w1 * w2 - np.sum(v1 * v2, axis=-1, keepdims=True)
    v = w1 * v2 + w2 * v1 + np.cross(v1, v2)
    return 2.0 * np.arctan2(np.linalg.norm(v, axis=-1), np.abs(w[..., 0]))


def _body_z_in_eci(q):
    """Camera axis (+z body) in ECI: the third column of C_ib of a scalar-first Hamilton q_bi."""
    q0, q1, q2, q3 = np.moveaxis(q / np.linalg.norm(q, axis=-1, keepdims=True), -1, 0)
    return np.stack([2 * (q1 * q3 + q0 * q2), 2 * (q2 * q3 - q0 * q1), q0**2 - q1**2 - q2**2 + q3**2], axis=-1)


def test_observation_run_folder_has_every_figure(observation_run, tmp_path):
    _check_run_folder(observation_run, tmp_path,
                      ["attitude_error", "control_torque", "actuators", "target_elevation", "relative_error"])


def test_observation_error_figure_draws_attitude_and_pointing_error_in_degrees(observation_run):
    ds, built = observation_run.ds, observation_run.built
    names = [str(s) for s in ds["spacecraft"].values]
    t = ds["time"].values
    q = ds["q"].values
    attitude = np.degrees(_quat_angle(q, ds["q_desired"].values))
    los = ds["target_los"].values
    cos = np.sum(_body_z_in_eci(q) * los, axis=-1) / np.linalg.norm(los, axis=-1)
    pointing = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    fig = observation_plots.error_figure(ds, built)
    assert len(fig.axes) == len(names)
    for k, (ax, name) in enumerate(zip(fig.axes, names)):
        assert ax.get_yscale() == "log" and ax.get_ylabel() == f"{name} (deg)"
        att, point = _data_lines(ax)
        np.testing.assert_array_equal(att.get_xdata(), t)
        np.testing.assert_allclose(att.get_ydata(), attitude[:, k], rtol=1e-6, atol=1e-9)
        np.testing.assert_allclose(point.get_ydata(), pointing[:, k], rtol=1e-6, atol=1e-6)
        assert not any(line.get_linestyle() == "--" for line in ax.get_lines())  # nobody stares in 5 s
    assert np.all(ds["staring"].values < 0.5)


def test_observation_error_figure_marks_where_staring_starts(observation_run):
    ds = observation_run.ds.copy(deep=True)
    staring = np.zeros_like(ds["staring"].values)
    staring[3:, 0] = 1.0  # the reference stares from the fourth sample, the follower never
    ds["staring"].values[:] = staring
    fig = observation_plots.error_figure(ds, observation_run.built)
    stare_lines = [[line for line in ax.get_lines() if line.get_linestyle() == "--"] for ax in fig.axes]
    assert [len(lines) for lines in stare_lines] == [1, 0]
    np.testing.assert_array_equal(stare_lines[0][0].get_xdata(), [ds["time"].values[3]] * 2)


def test_observation_figures_shade_where_a_drive_held_a_wheel_at_its_limit(observation_run):
    """Where the counter ``wheel_speed_limited_time`` grows between two samples, that record
    interval is shaded on the error and wheel figures; consecutive ones make one span."""
    ds = observation_run.ds.copy(deep=True)
    t = ds["time"].values
    counter = np.zeros_like(ds["wheel_speed_limited_time"].values)  # (time, spacecraft, wheel)
    counter[2:, 1, 0] = 0.1  # the follower's wheel 1 held during [t1, t2) ...
    counter[3, 1, 3], counter[4:, 1, 3] = 0.1, 0.2  # ... and its wheel 4 during [t2, t4)
    ds["wheel_speed_limited_time"].values[:] = counter
    assert observation_plots.limited_spans(ds, 0) == [] and observation_plots.limited_spans(ds, 1) == [(t[1], t[4])]
    error = observation_plots.error_figure(ds, observation_run.built)
    wheels = np.array(observation_plots.actuator_figure(ds, observation_run.built).axes).reshape(2, 2)[:, 0]
    for ax in (error.axes[1], wheels[1]):
        (span,) = ax.patches
        np.testing.assert_allclose([span.get_x(), span.get_x() + span.get_width()], [t[1], t[4]])
    assert not error.axes[0].patches and not wheels[0].patches


def test_observation_torque_actuator_elevation_and_relative_figures(observation_run):
    ds, built, toml = observation_run.ds, observation_run.built, observation_run.toml
    names = [str(s) for s in ds["spacecraft"].values]
    figs = observation_plots.figures(ds, built)
    assert list(figs) == ["attitude_error", "control_torque", "actuators", "target_elevation", "relative_error"]

    torque = figs["control_torque"]
    for k, ax in enumerate(torque.axes):
        assert ax.get_ylabel() == f"{names[k]} (mN·m)"
        for c, line in enumerate(_lines(ax)):
            np.testing.assert_allclose(line.get_ydata(), 1000.0 * ds["torque_command"].values[:, k, c], rtol=1e-12)

    actuators = figs["actuators"]
    assert len(actuators.axes) == 2 * len(names)  # wheels | dipole, one row per spacecraft
    rows = np.array(actuators.axes).reshape(len(names), 2)
    wheel_rpm = ds["wheel_speed"].values * 60.0 / (2.0 * np.pi)
    for k, (wheels, dipole) in enumerate(rows):
        assert wheels.get_ylabel() == f"{names[k]} wheels (rpm)" and dipole.get_ylabel() == "dipole (A·m²)"
        assert [line.get_label() for line in _data_lines(wheels)] == [str(w) for w in ds["wheel"].values]
        for w, line in enumerate(_data_lines(wheels)):
            np.testing.assert_allclose(line.get_ydata(), wheel_rpm[:, k, w], rtol=1e-12)
        # The rated speeds, both signs, dashed: SPEC §5's 1000 rpm and the skewed wheel's 1732.
        limits = sorted(line.get_ydata()[0] for line in wheels.get_lines() if line.get_linestyle() == "--")
        assert limits == [-1732.0, -1000.0, 1000.0, 1732.0] == sorted(
            s * v for s in (-1, 1) for v in set(toml["actuators"][0]["max_speed_rpm"]))
        assert not wheels.patches  # no wheel reaches its limit in 5 s: nothing shaded
        for c, line in enumerate(_lines(dipole)):
            np.testing.assert_array_equal(line.get_ydata(), ds["dipole_command"].values[:, k, c])

    (elevation,) = figs["target_elevation"].axes
    assert elevation.get_ylabel() == "elevation (deg)"
    data = _data_lines(elevation)
    assert [line.get_label() for line in data] == names
    for k, line in enumerate(data):
        np.testing.assert_allclose(line.get_ydata(), np.degrees(ds["target_elevation"].values[:, k]), rtol=1e-12)
    (threshold,) = [line for line in elevation.get_lines() if line not in data]
    assert threshold.get_ydata()[0] == toml["controller"]["min_elevation_deg"] == 10.0

    (relative,) = figs["relative_error"].axes
    reference = toml["controller"]["reference"]
    followers = [n for n in names if n != reference]
    assert relative.get_yscale() == "log" and relative.get_ylabel() == "error to the reference (deg)"
    assert reference in relative.get_title()
    lines = _lines(relative)
    assert len(lines) == 2 * len(followers)  # nothing drawn against the reference itself
    k = names.index(followers[0])
    np.testing.assert_array_equal(lines[0].get_ydata(), np.degrees(ds["relative_attitude_error"].values[:, k]))
    np.testing.assert_array_equal(lines[1].get_ydata(), np.degrees(ds["image_mismatch"].values[:, k]))


def test_observation_figures_of_a_lone_spacecraft_leave_out_the_relative_error(observation_run):
    ds, built = observation_run.ds, observation_run.built
    lone = ds.isel(spacecraft=[0])
    lone_built = SimpleNamespace(names=built.names[:1], system=built.system, scenario=built.scenario)
    figs = observation_plots.figures(lone, lone_built)
    assert "relative_error" not in figs
    assert len(figs["attitude_error"].axes) == 1 and len(figs["actuators"].axes) == 2


# --------------------------------------------------------------------------------------------
# Deep-space formation: plots/formation.py

PLANE_AXES = {"xy": (0, 1), "xyz": (0, 1, 2)}


def test_deepspace_run_folder_has_every_figure(deepspace_run, tmp_path):
    _check_run_folder(deepspace_run, tmp_path, ["trajectories", "fuel", "formation_error", "relative_motion"],
                      attitude=False)


def test_deepspace_fuel_figure_sums_the_thrusters_counters(deepspace_run):
    ds, built = deepspace_run.ds, deepspace_run.built
    (ax,) = formation_plots.fuel_figure(ds, built).axes
    assert ax.get_ylabel() == "fuel (N s)" and ax.get_xlabel() == "time (s)"
    by_label = {line.get_label(): line for line in _lines(ax)}
    per_axis = ds["abs_force_impulse"].sum("spacecraft").values  # (T, 3), N s
    np.testing.assert_allclose(by_label["L1 total"].get_ydata(), per_axis.sum(axis=1), rtol=1e-12)
    assert per_axis[-1].sum() > 0  # the run did thrust: the check above is not 0 == 0
    for c, comp in enumerate("xyz"):
        label = f"Σ∫|u_{comp}| dt"
        if np.any(per_axis[:, c] > 0):
            np.testing.assert_allclose(by_label[label].get_ydata(), per_axis[:, c], rtol=1e-12)
        else:
            assert label not in by_label  # an axis that never fired is not drawn
    if "norm_force_impulse" in ds:
        np.testing.assert_allclose(by_label["Σ∫‖u‖₂ dt"].get_ydata(), ds["norm_force_impulse"].sum("spacecraft").values)


def test_deepspace_error_figure_draws_the_largest_slot_error(deepspace_run):
    ds, built, toml = deepspace_run.ds, deepspace_run.built, deepspace_run.toml
    axes = PLANE_AXES[toml["controller"].get("plane", "xy")]
    target = np.asarray(toml["controller"]["target_m"], dtype=float)
    r = ds["r_eci"].values
    rel = r - r.mean(axis=1, keepdims=True)
    slots = np.zeros(r.shape[1:])
    slots[:, list(axes)] = target - target.mean(axis=0)
    ours = np.linalg.norm(rel - slots, axis=-1).max(axis=-1)
    (ax,) = formation_plots.error_figure(ds, built).axes
    assert ax.get_yscale() == "log" and ax.get_ylabel() == "largest slot error (m)"
    (error,) = _data_lines(ax)
    np.testing.assert_allclose(error.get_ydata(), np.maximum(ours, 1e-6), rtol=1e-9)
    assert ours[0] > 100.0  # it starts as a square, far from the line
    (tolerance,) = [line for line in ax.get_lines() if line is not error]
    assert tolerance.get_ydata()[0] == toml["analysis"]["formation_tolerance_m"]


def _trajectory_reference(ds, toml):
    """Each spacecraft's path relative to the centroid's unforced orbit, in the design plane:
    the centroid less the displacement ∫∫ ΣF/(n m) dt² the thrust gave it."""
    t = ds["time"].values
    r, impulse = ds["r_eci"].values, ds["force_impulse"].values
    mass = float(toml["spacecraft"][0].get("mass_kg", toml.get("spacecraft_defaults", {}).get("mass_kg")))
    dv = impulse.sum(axis=1) / (impulse.shape[1] * mass)  # (T, 3) velocity the thrust gave the centroid
    drift = np.concatenate([np.zeros((1, 3)), np.cumsum(0.5 * (dv[1:] + dv[:-1]) * np.diff(t)[:, None], axis=0)])
    return r - (r.mean(axis=1) - drift)[:, None, :], drift


def test_deepspace_trajectory_figure_draws_paths_about_the_unforced_centroid(deepspace_run):
    ds, built, toml = deepspace_run.ds, deepspace_run.built, deepspace_run.toml
    i, j = PLANE_AXES[toml["controller"].get("plane", "xy")][:2]
    rel, drift = _trajectory_reference(ds, toml)
    target = np.asarray(toml["controller"]["target_m"], dtype=float)
    (ax,) = formation_plots.trajectory_figure(ds, built).axes
    assert ax.get_xlabel().startswith(f"{'xyz'[i]} (m") and ax.get_ylabel() == f"{'xyz'[j]} (m)"
    lines = _lines(ax)
    names = [str(s) for s in ds["spacecraft"].values]
    paths = [line for line in lines if line.get_label() in names]
    assert [p.get_label() for p in paths] == names
    for k, path in enumerate(paths):
        np.testing.assert_allclose(path.get_xdata(), rel[:, k, i], rtol=0, atol=1e-6)
        np.testing.assert_allclose(path.get_ydata(), rel[:, k, j], rtol=0, atol=1e-6)
        start, end, slot = lines[lines.index(path) + 1: lines.index(path) + 4]
        assert (start.get_marker(), end.get_marker(), slot.get_marker()) == ("x", "o", "+")
        np.testing.assert_allclose([start.get_xdata()[0], start.get_ydata()[0]], rel[0, k, [i, j]], atol=1e-6)
        np.testing.assert_allclose([end.get_xdata()[0], end.get_ydata()[0]], rel[-1, k, [i, j]], atol=1e-6)
        np.testing.assert_allclose([slot.get_xdata()[0], slot.get_ydata()[0]], target[k] - target.mean(axis=0))
    (centroid,) = [line for line in lines if line.get_label() == "centroid at the end"]
    np.testing.assert_allclose([centroid.get_xdata()[0], centroid.get_ydata()[0]], drift[-1, [i, j]], atol=1e-9)
    assert np.abs(drift[-1]).max() > 0  # the thrust did move the centroid


def test_deepspace_trajectory_figure_draws_the_slots_about_the_centroid_whatever_their_origin(deepspace_run):
    # target_m is "any origin" (analysis.papers.deep_space_2008.formation_error_m): shifting
    # every slot by the same vector is the same formation, and the same figure.
    ds, built = deepspace_run.ds, deepspace_run.built
    table = built.scenario.controller
    shifted = np.asarray(table.target_m, dtype=float) + np.array([250.0, -40.0])
    moved = SimpleNamespace(scenario=SimpleNamespace(
        controller=SimpleNamespace(plane=table.plane, target_m=shifted.tolist()), spacecraft=built.scenario.spacecraft))

    def slots(b):
        lines = _lines(formation_plots.trajectory_figure(ds, b).axes[0])
        return [(line.get_xdata()[0], line.get_ydata()[0]) for line in lines if line.get_marker() == "+" and line.get_markersize() == 12]

    assert len(slots(built)) == ds.sizes["spacecraft"]
    np.testing.assert_allclose(slots(moved), slots(built), atol=1e-9)


def test_tradeoff_figure_draws_each_series_and_its_pareto_front():
    rows = [
        {"design": "lqr", "coordinates": "hub", "scenario": "s", "settling_time_s": s, "fuel_l1_ns": f}
        for s, f in [(100.0, 5.0), (200.0, 3.0), (150.0, 6.0), (300.0, 3.5), (None, 1.0), (400.0, 1.0)]
    ] + [
        {"design": "lmi", "coordinates": "orthonormal", "scenario": "s", "settling_time_s": s, "fuel_l1_ns": f}
        for s, f in [(120.0, 4.0), (110.0, 4.5)]
    ]
    comparisons = [{"settle_s": [150.0, 250.0]}]
    fig = formation_plots.tradeoff_figure(rows, comparisons, bound=([100.0, 400.0], [2.0, 0.5]))
    (ax,) = fig.axes
    lines = _lines(ax)
    points = [line for line in lines if line.get_marker() in ("o", "s", "^")]
    assert [p.get_label() for p in points] == ["LQR hub (s)", "LMI orthonormal (s)"]
    assert points[0].get_marker() == "s" and points[1].get_marker() == "o"
    # Brute force: a finite point is on the front iff no other is at least as good on both
    # and better on one; drawn in order of increasing settling time.
    for p in points:
        s, f = np.asarray(p.get_xdata(), float), np.asarray(p.get_ydata(), float)
        ok = np.isfinite(s)
        front = [k for k in np.flatnonzero(ok) if not any(
            s[m] <= s[k] and f[m] <= f[k] and (s[m] < s[k] or f[m] < f[k]) for m in np.flatnonzero(ok))]
        front.sort(key=lambda k: s[k])
        front_line = lines[lines.index(p) + 1]
        np.testing.assert_array_equal(front_line.get_xdata(), s[front])
        np.testing.assert_array_equal(front_line.get_ydata(), f[front])
    np.testing.assert_array_equal(lines[lines.index(points[0]) + 1].get_xdata(), [100.0, 200.0, 400.0])
    ticks = [line for line in lines if line.get_transform() != ax.transData]
    assert sorted(line.get_xdata()[0] for line in ticks) == [150.0, 250.0]
    (bound,) = [line for line in lines if line.get_linestyle() == ":"]
    np.testing.assert_array_equal(bound.get_ydata(), [2.0, 0.5])
    assert ax.get_xlabel() == "settling time (s)" and "(N s)" in ax.get_ylabel()


def test_fuel_time_figure_draws_each_runs_totals_and_used_axes():
    t = np.linspace(0.0, 10.0, 11)
    l1 = np.stack([0.1 * t, 0.2 * t, 0.0 * t], axis=1)
    series = [
        ({"design": "lqr", "coordinates": "hub", "force_scale_n": 0.5}, {"t_s": t, "fuel_l1_ns": l1, "fuel_l2_ns": 0.25 * t}),
        ({"design": "lmi", "coordinates": "hub", "force_scale_n": 1.0}, {"t_s": t, "fuel_l1_ns": 2 * l1, "fuel_l2_ns": None}),
    ]
    (ax,) = formation_plots.fuel_time_figure(series).axes
    lines = _lines(ax)
    assert len(lines) == (1 + 2 + 1) + (1 + 2)  # L1, the two axes that fired, the 2-norm when known
    by_label = {line.get_label(): line for line in lines}
    np.testing.assert_allclose(by_label["LQR hub (0.5 N): L1"].get_ydata(), 0.3 * t)
    np.testing.assert_allclose(by_label["LQR hub (0.5 N): 2-norm"].get_ydata(), 0.25 * t)
    np.testing.assert_allclose(by_label["LMI hub (1 N): L1"].get_ydata(), 0.6 * t)
    assert "LMI hub (1 N): 2-norm" not in by_label


# --------------------------------------------------------------------------------------------
# plots/pair.py


def _paired(values_a, values_b, units):
    seeds, n_t, n_sc = values_a.shape
    coords = {"seed": np.arange(seeds) + 7, "time": np.arange(n_t) * 2.0, "spacecraft": ["ref", "f1", "f2"][:n_sc]}
    make = lambda v: xr.DataArray(v, dims=("seed", "time", "spacecraft"), coords=coords, attrs={"units": units})  # noqa: E731
    return make(values_a), make(values_b)


def test_pair_figure_draws_a_and_b_and_their_difference_per_seed():
    rng = np.random.default_rng(0)
    a = rng.random((2, 6, 3)) + 0.1
    b = rng.random((2, 6, 3)) + 0.1
    a[:, :, 0] = b[:, :, 0] = np.nan  # the reference of a relative error: left out
    series = {"relative_attitude_error": _paired(a, b, "rad"), "image_mismatch": _paired(2 * a, 3 * b, "1")}
    fig = pair_plots.pair_figure(("A", "B"), series)
    axes = np.array(fig.axes).reshape(2, 2)
    # rad is drawn in degrees, a dimensionless series as it is
    assert axes[0, 0].get_ylabel() == "relative_attitude_error (deg)" and axes[0, 1].get_ylabel() == "B − A (deg)"
    assert axes[1, 0].get_ylabel() == "image_mismatch (1)"
    assert axes[0, 0].get_yscale() == "log"
    for row, (scale, fa, fb) in enumerate([(np.degrees(1.0), 1, 1), (1.0, 2, 3)]):
        left, right = axes[row]
        assert len(_lines(left)) == 2 * 2 * 2 and len(_lines(right)) == 2 * 2  # 2 followers x 2 seeds
        assert [line.get_label() for line in _lines(right)] == ["f1, seed 7", "f1, seed 8", "f2, seed 7", "f2, seed 8"]
        for n, (k, s) in enumerate([(1, 0), (1, 1), (2, 0), (2, 1)]):
            np.testing.assert_allclose(_lines(left)[2 * n].get_ydata(), scale * fa * a[s, :, k])
            np.testing.assert_allclose(_lines(left)[2 * n + 1].get_ydata(), scale * fb * b[s, :, k])
            np.testing.assert_allclose(_lines(right)[n].get_ydata(), scale * (fb * b[s, :, k] - fa * a[s, :, k]))
    assert "B = B against A = A" in fig.get_suptitle()
    only = pair_plots.pair_figure(("A", "B"), series, spacecraft="f2")
    assert [line.get_label() for line in _lines(only.axes[1])] == ["f2, seed 7", "f2, seed 8"]


# --------------------------------------------------------------------------------------------
# plots/sweep.py


def test_sweep_figure_draws_the_mean_over_seeds_with_min_max_bars():
    x = np.array([[1.0, 3.0], [10.0, 14.0], [200.0, 220.0]])  # spans > 100: log axis
    y = np.array([[5.0, 7.0], [4.0, 4.0], [np.nan, 3.0]])  # a run without a value: point left out
    fig = sweep_plots.sweep_figure(x, y, "fuel (N s)", "error (m)", title="sweep of k")
    (ax,) = fig.axes
    (bars,) = ax.containers  # errorbar's: (data line, caps, bar collections)
    data, caps, collections = bars.lines
    np.testing.assert_array_equal(data.get_xdata(), [2.0, 12.0, 210.0])
    np.testing.assert_array_equal(data.get_ydata(), [6.0, 4.0, np.nan])
    assert ax.get_xscale() == "log" and ax.get_yscale() == "linear"  # y spans 6/4 < 100
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("fuel (N s)", "error (m)")
    assert ax.get_title().splitlines() == ["sweep of k", "mean of 2 seeds, bars from min to max"]
    # The bars: x from 1 to 3 around 2, y from 5 to 7 around 6 for the first point.
    segments = [c.get_segments() for c in collections]
    assert len(segments) == 2 and len(caps) == 4  # x and y bars, a cap at each end
    spans = sorted(tuple(np.round(seg[0].ravel(), 12)) for seg in segments)
    assert spans == sorted([(1.0, 6.0, 3.0, 6.0), (2.0, 5.0, 2.0, 7.0)])


def test_sweep_figure_of_one_seed_has_no_bars_and_linear_axes():
    fig = sweep_plots.sweep_figure([[1.0], [2.0], [3.0]], [[9.0], [8.0], [1.0]], "a", "b")
    (ax,) = fig.axes
    assert not ax.collections and ax.get_xscale() == ax.get_yscale() == "linear"
    (bars,) = ax.containers
    assert not bars.has_xerr and not bars.has_yerr
    np.testing.assert_array_equal(bars.lines[0].get_ydata(), [9.0, 8.0, 1.0])
    assert ax.get_title() == ""


# --------------------------------------------------------------------------------------------
# plots/campaign.py


def test_histogram_figure_counts_every_run_and_marks_the_percentiles():
    values = np.random.default_rng(1).normal(size=400)
    (ax,) = campaign_plots.histogram_figure(values, "spread (deg)").axes
    bars = ax.patches
    assert len(bars) == 20  # sqrt(400) bins
    assert sum(bar.get_height() for bar in bars) == 400
    marks = sorted(line.get_xdata()[0] for line in ax.get_lines())
    np.testing.assert_allclose(marks, np.percentile(values, [1, 50, 99]))
    assert [t.get_text() for t in ax.texts] == ["P1", "P50", "P99"]
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("spread (deg)", "runs")
    few = campaign_plots.histogram_figure(np.arange(4.0), "x", percentiles=(50.0,)).axes[0]
    assert len(few.patches) == 5 and len(few.get_lines()) == 1  # at least 5 bins


def test_scatter_and_envelope_figures():
    x, y = np.arange(5.0), np.array([3.0, 1.0, 4.0, 1.0, 5.0])
    (ax,) = campaign_plots.scatter_figure(x, y, "inertia", "sync time (s)", -0.25).axes
    np.testing.assert_array_equal(_lines(ax)[0].get_ydata(), y)
    assert ax.get_title() == "Spearman ρ = -0.25" and ax.get_xlabel() == "inertia"

    t = np.linspace(0.0, 1.0, 4)
    runs = np.array([[1.0, 2.0, 3.0, 4.0], [3.0, 2.0, np.nan, 0.0], [2.0, 2.0, 1.0, 2.0]])
    (ax,) = campaign_plots.envelope_figure(t, runs, "|e| (m)").axes
    mean, upper, lower = _lines(ax)
    expected_mean = [2.0, 2.0, 2.0, 2.0]
    expected_std = [np.sqrt(2.0 / 3.0), 0.0, 1.0, np.sqrt(8.0 / 3.0)]
    np.testing.assert_allclose(mean.get_ydata(), expected_mean)
    np.testing.assert_allclose(upper.get_ydata(), np.add(expected_mean, 3 * np.array(expected_std)))
    np.testing.assert_allclose(lower.get_ydata(), np.subtract(expected_mean, 3 * np.array(expected_std)))
    (band,) = ax.collections
    vertices = band.get_paths()[0].vertices
    assert vertices[:, 1].min() == 0.0 and vertices[:, 1].max() == 4.0  # min–max over the runs
    assert ax.get_ylabel() == "|e| (m)"


def test_every_figure_is_a_matplotlib_figure_with_no_pyplot_state():
    fig = campaign_plots.histogram_figure(np.arange(10.0), "x")
    assert isinstance(fig, Figure) and plt.get_fignums() == []
