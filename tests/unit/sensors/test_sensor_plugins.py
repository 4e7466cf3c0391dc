"""Sensor plug-ins (``[[sensors]]``) through the real pipeline: load → prepare → simulate.

Short runs of consensus-sync-a-stable (law (3), PWM, 0.01 s control period) with a star tracker
and a gyro: the seed replays a run bit for bit, a batch equals its separate runs, the
controller acts on the measured (not the true) state, a slow sensor holds its reading, and bad
input is one ScenarioError line naming the field.
"""

import textwrap

import jax
import numpy as np
import pytest

from coopsat.geometry.quaternion import quat_error, quat_vector
from coopsat.workflows.pipeline import prepare, simulate_built
from coopsat.scenarios.load import ScenarioError, load_scenario
from coopsat.sensors.noise import ARCSEC_RAD, star_tracker_measure
from coopsat.sensors.parts import Gyro
from coopsat.sim import engine, layout, period
from coopsat.sim.system import stack_systems

SIGMA_ARCSEC = 10.0
SIGMA_GYRO = 1e-4  # rad/s
ALPHA, BETA = 1.0, 2.0  # the gains of consensus-sync-a


def _sensors(sigma_arcsec=SIGMA_ARCSEC, sigma_gyro=SIGMA_GYRO, rw=1e-5, bias0="[1e-5, -2e-5, 0.0]", st_period="",
             gyro_period=""):
    return f"""
        [[sensors]]
        kind = "star-tracker"
        sigma_arcsec = {sigma_arcsec}
        {st_period}

        [[sensors]]
        kind = "gyro"
        sigma_rad_s = {sigma_gyro}
        bias_rw_rad_s_sqrt_s = {rw}
        bias0_rad_s = {bias0}
        {gyro_period}
    """


def _scenario(tmp_path, sensors="", seed=3, base="consensus-sync-a-stable", sim=None):
    sim = sim or "t_final_s = 0.2\nrecord_interval_s = 0.05"
    text = f'extends = "{base}"\nseed = {seed}\n\n[sim]\n{sim}\n' + textwrap.dedent(sensors)
    path = tmp_path / f"s{abs(hash(text))}.toml"
    path.write_text(text, encoding="utf-8")
    return load_scenario(path)


def _run(tmp_path, sensors="", seed=3):
    ds, _ = simulate_built(prepare(_scenario(tmp_path, sensors, seed)))
    return ds


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Runs of one structure (star tracker + gyro), and the sensor-free run."""
    tmp = tmp_path_factory.mktemp("sensors")
    return {
        "noisy": _run(tmp, _sensors()),
        "noisy_again": _run(tmp, _sensors()),
        "noisy_seed4": _run(tmp, _sensors(), seed=4),
        "perfect": _run(tmp, _sensors(0, 0, 0, bias0="[0, 0, 0]")),
        "star_only": _run(tmp, _sensors(SIGMA_ARCSEC, 0, 0)),
        "gyro_only": _run(tmp, _sensors(0, SIGMA_GYRO, 0)),
        "free": _run(tmp, ""),
    }


def test_same_seed_replays_bit_for_bit(runs):
    a, b = runs["noisy"], runs["noisy_again"]
    assert set(a.data_vars) == set(b.data_vars)
    for name in a.data_vars:
        assert np.array_equal(a[name].values, b[name].values), name


def test_another_seed_gives_other_noise(runs):
    a, b = runs["noisy"], runs["noisy_seed4"]
    assert not np.array_equal(a.torque_command.values[0], b.torque_command.values[0])
    assert not np.array_equal(a.q.values[-1], b.q.values[-1])
    assert not np.array_equal(a.omega.values[-1], b.omega.values[-1])


def test_batch_equals_separate_runs(tmp_path, runs):
    built = [prepare(_scenario(tmp_path, _sensors(), seed)) for seed in (3, 4)]
    out = engine.simulate(stack_systems([b.system for b in built]), built[0].n_records, built[0].record_interval_s,
                          batched=True)
    for k, name in enumerate(("noisy", "noisy_seed4")):
        for var in ("q", "omega", "torque_command", "torque"):
            np.testing.assert_allclose(out.samples[var][k], runs[name][var].values, rtol=0, atol=1e-13, err_msg=var)
    assert not np.array_equal(out.samples["torque_command"][0], out.samples["torque_command"][1])


def test_perfect_sensors_equal_the_sensor_free_run(runs):
    a, b = runs["perfect"], runs["free"]
    # The sensed run also records each sensor's reading; perfect readings are the truth.
    assert set(a.data_vars) == set(b.data_vars) | {"measured_q", "measured_omega"}
    for name in b.data_vars:
        assert np.array_equal(a[name].values, b[name].values), name
    assert np.array_equal(a.measured_q.values, a.q.values)
    assert np.array_equal(a.measured_omega.values, a.omega.values)


def test_controller_acts_on_the_star_tracker_reading(tmp_path, runs):
    """The first command is law (3) evaluated at the measured attitudes (the network carries the
    measured ones too), which differ from the truth by the star tracker's draw at t = 0."""
    ds, free = runs["star_only"], runs["free"]
    q_true = ds.q.values[0]  # (n, 4), the recorded true state at t = 0
    omega = ds.omega.values[0]
    np.testing.assert_array_equal(q_true, free.q.values[0])
    period_key = jax.random.fold_in(jax.random.PRNGKey(3), 0)
    sigma = SIGMA_ARCSEC * ARCSEC_RAD
    q_meas = np.asarray(star_tracker_measure(q_true.T, jax.random.fold_in(period_key, period._KEY_SENSORS + 0), sigma)).T
    adjacency = prepare(_scenario(tmp_path, _sensors(SIGMA_ARCSEC, 0, 0))).adjacency
    u = np.zeros_like(omega)
    for i in range(len(q_true)):
        for j in range(len(q_true)):
            if adjacency[i, j]:
                e = np.asarray(quat_vector(quat_error(q_meas[i], q_meas[j])))
                u[i] -= adjacency[i, j] * (ALPHA * e + BETA * (omega[i] - omega[j]))
    np.testing.assert_allclose(ds.torque_command.values[0], u, rtol=0, atol=1e-12)
    # Of the order of α σ: each term moves by about α·a_ij·σ/2 per axis.
    du = ds.torque_command.values[0] - free.torque_command.values[0]
    assert np.all(du != 0.0)
    rms = np.sqrt(np.mean(du**2)) / (ALPHA * sigma)
    assert 0.1 < rms < 10.0, rms


def test_controller_acts_on_the_gyro_reading(runs):
    """Law (3)'s rate term: the first command moves by about β σ_gyro (a bias common to every
    spacecraft cancels in ω_i − ω_j)."""
    du = runs["gyro_only"].torque_command.values[0] - runs["free"].torque_command.values[0]
    assert np.all(du != 0.0)
    rms = np.sqrt(np.mean(du**2)) / (BETA * SIGMA_GYRO)
    assert 0.1 < rms < 10.0, rms


def _sense_frames(system, frames):
    """The measurements of the first ``frames`` control periods, the true state held at x(0)."""
    carry = engine._initial_carry(system)
    x, st = carry[0], carry[1]
    view = layout._engine_view(system)
    readings = []
    for frame in range(frames):
        y, st = period._sense(view, x, st, frame, jax.random.fold_in(system.key, frame), frame * view.period_s)
        readings.append(jax.tree_util.tree_map(np.asarray, y))
    return x, readings


def test_slow_sensor_holds_its_reading(tmp_path):
    sc = _scenario(tmp_path, _sensors(st_period="period_s = 0.03"))  # 3 control periods; the gyro every period
    built = prepare(sc)
    assert built.system.sensors[0].every == 3 and built.system.sensors[1].every == 1
    _, y = _sense_frames(built.system, 9)
    for frame in range(1, 9):
        same_q = np.array_equal(y[frame]["q"], y[frame - 1]["q"])
        assert same_q == (frame % 3 != 0), frame
        assert not np.array_equal(y[frame]["omega"], y[frame - 1]["omega"]), frame


def test_period_must_be_a_whole_multiple_of_the_control_period(tmp_path):
    sc = _scenario(tmp_path, _sensors(gyro_period="period_s = 0.015"))
    with pytest.raises(ScenarioError) as info:
        prepare(sc)
    msg = str(info.value)
    assert "\n" not in msg
    assert msg == "sensors[1].period_s (0.015 s) must be a whole multiple of the control period (0.01 s)"


def test_unknown_kind_lists_the_installed_kinds(tmp_path):
    with pytest.raises(ScenarioError) as info:
        _scenario(tmp_path, '[[sensors]]\nkind = "lidar"\n')
    msg = str(info.value)
    assert msg.startswith("sensors[0]") and "lidar" in msg
    for kind in ("star-tracker", "gyro", "position-noise", "velocity-noise", "sun-sensor", "magnetometer"):
        assert f"'{kind}'" in msg


@pytest.mark.parametrize(
    ("sensors", "expected"),
    [
        ('[[sensors]]\nkind = "star-tracker"\nsigma_arcsec = -1.0\n', "sensors[0].sigma_arcsec: must be finite and ≥ 0"),
        ('[[sensors]]\nkind = "gyro"\nsigma_rad_s = [1e-4, 1e-4]\n', "sensors[0].sigma_rad_s: must be one number, or one per axis"),
        ('[[sensors]]\nkind = "star-tracker"\nsigma_arcsec = 5\nperiod_s = 0.0\n', "sensors[0].period_s: Input should be greater than 0"),
    ],
)
def test_bad_table_is_one_line_naming_the_field(tmp_path, sensors, expected):
    with pytest.raises(ScenarioError) as info:
        _scenario(tmp_path, sensors)
    assert str(info.value).startswith(expected)


def test_navigation_sensor_needs_an_orbit(tmp_path):
    sc = _scenario(tmp_path, '[[sensors]]\nkind = "position-noise"\nsigma_m = 3e-5\n')
    with pytest.raises(ScenarioError, match=r'^sensors\[0\]: kind = "position-noise" measures r_eci, which needs an \[orbit\]'):
        prepare(sc)


def test_one_sensor_per_quantity(tmp_path):
    sensors = _sensors() + '\n[[sensors]]\nkind = "star-tracker"\nsigma_arcsec = 1.0\n'
    with pytest.raises(ScenarioError, match=r"^sensors\[2\]: measures q like sensors\[0\]"):
        prepare(_scenario(tmp_path, sensors))


def test_navigation_noise_on_an_orbit(tmp_path):
    """Position (0.03 mm, SPEC §2) and velocity noise replace r_eci and v_eci with the stated
    standard deviation; the run compiles and stays finite."""
    sigma_r, sigma_v = 3e-5, 1e-6
    sensors = f"""
        [[sensors]]
        kind = "position-noise"
        sigma_m = {sigma_r}

        [[sensors]]
        kind = "velocity-noise"
        sigma_m_s = [{sigma_v}, {sigma_v}, {2 * sigma_v}]
        period_s = 2.0
    """
    sc = _scenario(tmp_path, sensors, base="orbit-two-body", sim="t_final_s = 20.0\nrecord_interval_s = 10.0")
    built = prepare(sc)
    assert [s.quantity for s in built.system.sensors] == ["r_eci", "v_eci"]
    frames = 400
    x, y = _sense_frames(built.system, frames)
    dr = np.stack([v["r_eci"] for v in y]) - np.asarray(x.r_eci)  # (frames, 3, 1)
    dv = np.stack([v["v_eci"] for v in y[::2]]) - np.asarray(x.v_eci)  # one per update (every 2 periods)
    assert np.array_equal(y[1]["v_eci"], y[0]["v_eci"]) and not np.array_equal(y[2]["v_eci"], y[1]["v_eci"])
    for d, sigma in ((dr, [sigma_r] * 3), (dv, [sigma_v, sigma_v, 2 * sigma_v])):
        n = d.shape[0]
        rel = d[:, :, 0].std(axis=0, ddof=1) / np.asarray(sigma) - 1.0
        assert np.all(np.abs(rel) < 5.0 / np.sqrt(2.0 * n)), rel
    ds, _ = simulate_built(built)
    assert np.all(np.isfinite(ds.r_eci.values)) and ds.sizes["time"] == 3


def test_gyro_bias_walks_sigma_rw_sqrt_t():
    """The bias spreads σ_rw √t per axis (one step per call of measure, Δt = step_s)."""
    n, calls, step_s = 20_000, 50, 0.02
    rw = np.array([1e-4, 2e-4, 0.0])
    gyro = Gyro(*map(jax.numpy.asarray, (np.zeros(3), rw, np.array([1e-3, 0.0, 0.0]), step_s)))
    omega = jax.numpy.zeros((3, n))
    bias = gyro.init(omega, n)

    def call(b, k):
        value, b = gyro.measure(omega, None, b, jax.random.fold_in(jax.random.key(7), k))
        return b, value

    bias, values = jax.lax.scan(call, bias, np.arange(calls))
    np.testing.assert_array_equal(values[0], np.broadcast_to([[1e-3], [0.0], [0.0]], (3, n)))
    spread = np.asarray(values[-1]).std(axis=1, ddof=1)  # the reading of the last call: (calls - 1) steps
    expected = rw * np.sqrt((calls - 1) * step_s)
    assert np.all(np.abs(spread[:2] / expected[:2] - 1.0) < 5.0 / np.sqrt(2.0 * n))
    assert spread[2] == 0.0
