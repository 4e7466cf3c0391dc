"""The GNSS receiver (``kind = "gnss"``), the inter-satellite range link (``kind = "isl-range"``) and
the camera bearing (``kind = "camera-bearing"``): closed forms without noise, the stated
statistics of every noise term (white, own and common Gauss–Markov; the camera's rotation across
the line of sight), the common error cancelling between receivers, the camera's field of view
and range, bit-for-bit replay independent of the formation size, and the plug-ins through the
real pipeline with one-line errors."""

import textwrap

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from coopsat.astro.constants import MU_EARTH_M3_S2
from coopsat.astro.kepler import elements_to_rv
from coopsat.dynamics.plant import PlantState
from coopsat.plugins import protocols
from coopsat.scenarios.load import ScenarioError, load_scenario
from coopsat.geometry.quaternion import quat_to_dcm
from coopsat.sensors.navigation_sensors import CameraBearing, Gnss, GnssState, IslRange
from coopsat.workflows.pipeline import prepare, simulate_built

STEP_S = 5.0


def _state(n, seed=0, spread_m=1e3):
    """Spacecraft scattered ``spread_m`` about a 500 km orbit, (3, n) ECI."""
    rng = np.random.default_rng(seed)
    r0, v0 = elements_to_rv(6878137.0, 0.001, 1.7, 0.3, 0.2, 0.1, MU_EARTH_M3_S2)
    r = np.asarray(r0)[:, None] + spread_m * rng.normal(size=(3, n))
    v = np.asarray(v0)[:, None] + rng.normal(size=(3, n))
    zeros = np.zeros((3, n))
    return PlantState(q_bi=np.zeros((4, n)), omega_b=zeros, h_wheels_b=zeros, r_eci=r, v_eci=v, angle_rad=zeros)


def _six(v):
    return jnp.broadcast_to(jnp.asarray(v, dtype=float), (6,))


def _gnss(sigma=0.0, own=0.0, own_tau_s=600.0, common=0.0, common_tau_s=1800.0):
    return Gnss(_six(sigma), _six(own), jnp.asarray(own_tau_s), _six(common), jnp.asarray(common_tau_s), jnp.asarray(STEP_S))


def _isl(sigma=(0.0, 0.0), bias=(0.0, 0.0), target=0, max_range_m=np.inf):
    return IslRange(jnp.asarray(sigma, dtype=float), jnp.asarray(bias, dtype=float), jnp.int32(target), jnp.asarray(max_range_m))


def _calls(sensor, x, calls, seed=7):
    """``calls`` successive readings (calls, k, n) from one truth, each call with its own key."""
    truth = sensor.truth({}, x)
    n = truth.shape[-1]

    def call(state, k):
        value, state = sensor.measure(truth, x, state, jax.random.fold_in(jax.random.key(seed), k))
        return state, value

    _, values = jax.lax.scan(call, sensor.init(truth, n), jnp.arange(calls))
    return np.asarray(values), np.asarray(truth)


def _assert_sigma(errors, sigma, axis):
    """The sample standard deviation along ``axis`` is ``sigma`` within 5 standard errors."""
    m = errors.shape[axis]
    rel = errors.std(axis=axis, ddof=1) / np.asarray(sigma) - 1.0
    assert np.all(np.abs(rel) < 5.0 / np.sqrt(2.0 * m)), rel


# GNSS: closed forms and statistics


def test_gnss_without_noise_reads_the_truth_bit_for_bit():
    x = _state(4)
    values, truth = _calls(_gnss(), x, 5)
    np.testing.assert_array_equal(truth, np.concatenate([x.r_eci, x.v_eci]))
    for value in values:
        np.testing.assert_array_equal(value, truth)


def test_gnss_state_is_the_two_gauss_markov_errors_and_a_started_flag():
    x = _state(3)
    sensor = _gnss(own=1.0, common=2.0)
    state = sensor.init(sensor.truth({}, x), 3)
    assert isinstance(state, GnssState) and GnssState._fields == ("common", "own", "started")
    assert state.common.shape == (6,) and state.own.shape == (6, 3) and not bool(state.started)
    _, state = sensor.measure(sensor.truth({}, x), x, state, jax.random.key(0))
    assert bool(state.started)


def test_gnss_white_noise_has_the_stated_deviation_per_component():
    n = 2000
    sigma = np.array([1.0, 2.0, 3.0, 0.01, 0.02, 0.03])
    x = _state(n)
    values, truth = _calls(_gnss(sigma=sigma), x, 1)
    errors = values[0] - truth
    _assert_sigma(errors, sigma, axis=1)
    assert np.all(np.abs(errors.mean(axis=1)) < 5.0 * sigma / np.sqrt(n))


def test_gnss_own_error_is_stationary_gauss_markov_per_receiver():
    """Across 2000 receivers: the variance is σ² from the first call on, the lag-1 correlation
    is φ = exp(−T/τ), and different receivers' errors are uncorrelated."""
    n, tau_s = 2000, STEP_S / np.log(1.0 / 0.6)  # φ = 0.6
    sigma = np.array([2.0, 2.0, 2.0, 0.02, 0.02, 0.02])
    x = _state(n)
    values, truth = _calls(_gnss(own=sigma, own_tau_s=tau_s), x, 3)
    errors = values - truth  # (calls, 6, n)
    for call in range(3):
        _assert_sigma(errors[call], sigma, axis=1)
    z = errors / sigma[None, :, None]
    phi = (z[1] * z[2]).mean(axis=1) / np.sqrt((z[1] ** 2).mean(axis=1) * (z[2] ** 2).mean(axis=1))
    assert np.all(np.abs(phi - 0.6) < 5.0 * (1.0 - 0.6**2) / np.sqrt(n)), phi
    across = (z[0, :, : n // 2] * z[0, :, n // 2 :]).mean(axis=1)
    assert np.all(np.abs(across) < 5.0 / np.sqrt(n // 2)), across


def test_gnss_common_error_is_the_same_for_every_receiver_and_gauss_markov_in_time():
    """A long series of calls: spacecraft 0's error has variance σ² and lag-1 correlation φ, and
    every receiver's error is the same, so the difference of two readings is the truth's."""
    calls, tau_s = 20000, STEP_S / np.log(2.0)  # φ = 0.5
    sigma = np.array([3.0, 3.0, 3.0, 0.03, 0.03, 0.03])
    x = _state(3)
    values, truth = _calls(_gnss(common=sigma, common_tau_s=tau_s), x, calls)
    errors = values[:, :, 0] - truth[:, 0]  # (calls, 6)
    # An AR(1) series of N samples: var(s²)/σ⁴ ≈ (2/N)(1 + φ²)/(1 − φ²).
    rel = errors.var(axis=0) / sigma**2 - 1.0
    assert np.all(np.abs(rel) < 5.0 * np.sqrt(2.0 / calls * 1.25 / 0.75)), rel
    z = errors / sigma
    phi = (z[1:] * z[:-1]).mean(axis=0) / (z**2).mean(axis=0)
    assert np.all(np.abs(phi - 0.5) < 5.0 * np.sqrt((1.0 - 0.25) / calls)), phi
    truth_difference = truth[:, 1] - truth[:, 0]
    np.testing.assert_allclose(values[:, :, 1] - values[:, :, 0], np.broadcast_to(truth_difference, (calls, 6)), rtol=1e-9)
    np.testing.assert_allclose(values[:, :, 2] - truth[:, 2], errors, atol=1e-8)


def test_gnss_replays_and_a_spacecraft_draws_the_same_whatever_the_formation_size():
    sensor = _gnss(sigma=1.0, own=2.0, own_tau_s=100.0, common=3.0, common_tau_s=50.0)
    x5 = _state(5)
    x2 = PlantState(*(np.asarray(a)[:, :2] for a in x5))
    a, truth5 = _calls(sensor, x5, 4)
    b, _ = _calls(sensor, x5, 4)
    c, truth2 = _calls(sensor, x2, 4)
    other, _ = _calls(sensor, x5, 4, seed=8)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(a[:, :, :2] - truth5[:, :2], c - truth2)
    assert not np.any(a == other)


# Inter-satellite range: closed forms and statistics


def test_isl_range_and_rate_are_the_closed_forms():
    n, target = 6, 2
    x = _state(n, seed=3)
    truth = np.asarray(_isl(target=target).truth({}, x))
    rho = x.r_eci[:, target][:, None] - x.r_eci
    rho_dot = x.v_eci[:, target][:, None] - x.v_eci
    others = np.arange(n) != target
    distance = np.linalg.norm(rho, axis=0)[others]
    rate = np.einsum("kn,kn->n", rho, rho_dot)[others] / distance
    np.testing.assert_allclose(truth[0, others], distance, rtol=1e-12)
    np.testing.assert_allclose(truth[1, others], rate, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(truth[2], others.astype(float))
    value, _ = _isl(sigma=(1.0, 0.1), bias=(-5.0, -0.5), target=target).measure(truth, x, (), jax.random.key(0))
    np.testing.assert_array_equal(np.asarray(value)[:, target], 0.0)
    assert not np.any(np.signbit(np.asarray(value)[:, target]))


def test_isl_beyond_max_range_is_invalid_and_zero():
    n, target = 6, 0
    x = _state(n, seed=4)
    distance = np.asarray(_isl(target=target).truth({}, x))[0]
    limit = np.median(distance[1:])
    sensor = _isl(sigma=(1.0, 0.1), bias=(2.0, 0.2), target=target, max_range_m=limit)
    truth = np.asarray(sensor.truth({}, x))
    value = np.asarray(sensor.measure(truth, x, (), jax.random.key(1))[0])
    inside = (np.arange(n) != target) & (distance <= limit)
    assert 0 < inside.sum() < n - 1
    np.testing.assert_array_equal(value[2], inside.astype(float))
    np.testing.assert_array_equal(value[:2, ~inside], 0.0)
    assert np.all(value[0, inside] != 0.0)


def test_isl_noise_and_bias_have_the_stated_values():
    n = 2000
    sigma, bias = np.array([0.05, 1e-3]), np.array([0.3, -2e-3])
    x = _state(n)
    values, truth = _calls(_isl(sigma=sigma, bias=bias, target=0), x, 1)
    errors = (values[0] - truth)[:2, 1:]
    _assert_sigma(errors, sigma, axis=1)
    assert np.all(np.abs(errors.mean(axis=1) - bias) < 5.0 * sigma / np.sqrt(n - 1))


def test_isl_replays_and_a_spacecraft_draws_the_same_whatever_the_formation_size():
    sensor = _isl(sigma=(0.1, 0.01), target=0)
    x5 = _state(5)
    x2 = PlantState(*(np.asarray(a)[:, :2] for a in x5))
    a, _ = _calls(sensor, x5, 3)
    np.testing.assert_array_equal(a, _calls(sensor, x5, 3)[0])
    np.testing.assert_array_equal(a[:, :, :2], _calls(sensor, x2, 3)[0])


def test_both_follow_the_sensor_protocol():
    for part in (_gnss(), _isl()):
        assert isinstance(part, protocols.Sensor)
        assert protocols.protocol_problems(part, "sensor") == []


# Through the pipeline


SENSORS = """
    [[sensors]]
    kind = "gnss"
    common_sigma_m = 3.0
    common_sigma_m_s = 0.03
    {gnss}

    [[sensors]]
    kind = "isl-range"
    to = "{to}"
    bias_m = 0.5
    {isl}
"""


def _scenario(tmp_path, gnss="", isl="", to="chief", base="leo-pair-differential-drag-free"):
    text = (
        f'extends = "{base}"\nseed = 2\ndisturbances = []\n\n[sim]\nt_final_s = 30.0\nrecord_interval_s = 5.0\n'
        + textwrap.dedent(SENSORS.format(gnss=gnss, isl=isl, to=to))
    )
    path = tmp_path / f"s{abs(hash(text))}.toml"
    path.write_text(text, encoding="utf-8")
    return load_scenario(path)


def test_both_sensors_are_recorded_through_the_pipeline(tmp_path):
    """A LEO pair (control period 5 s): the GNSS fixes differ from the truth by the common
    error only, which the deputy's and chief's difference cancels; the range to the chief is
    the true range plus its bias; a 10 s receiver holds its fix for two periods."""
    ds, _ = simulate_built(prepare(_scenario(tmp_path, gnss="period_s = 10.0")))
    gnss, isl = ds.measured_gnss, ds.measured_isl
    assert gnss.dims == ("time", "spacecraft", "gnss_component") and isl.dims == ("time", "spacecraft", "isl_component")
    assert list(gnss.gnss_component.values) == ["x", "y", "z", "vx", "vy", "vz"]
    assert list(isl.isl_component.values) == ["range", "range_rate", "valid"]
    assert (gnss.attrs["units"], gnss.attrs["frame"], isl.attrs["units"]) == ("m, m/s", "ECI", "m, m/s, 1")
    g = gnss.values  # (time, spacecraft, 6)
    np.testing.assert_array_equal(g[1], g[0])
    assert not np.array_equal(g[2], g[1])
    true_state = np.concatenate([ds.r_eci.values, ds.v_eci.values], axis=-1)
    assert np.all(np.abs((g - true_state)[::2, 0, :3]) > 0.0)
    np.testing.assert_allclose((g[:, 1] - g[:, 0])[::2], (true_state[:, 1] - true_state[:, 0])[::2], rtol=1e-9, atol=1e-9)
    distance = np.linalg.norm(ds.r_eci.values[:, 0] - ds.r_eci.values[:, 1], axis=-1)
    np.testing.assert_allclose(isl.values[:, 1, 0], distance + 0.5, rtol=1e-12)
    np.testing.assert_array_equal(isl.values[:, :, 2], np.broadcast_to([0.0, 1.0], (ds.sizes["time"], 2)))
    np.testing.assert_array_equal(isl.values[:, 0], 0.0)


@pytest.mark.parametrize(
    ("gnss", "isl", "to", "expected"),
    [
        ("period_s = 7.0", "", "chief", "sensors[0].period_s (7 s) must be a whole multiple of the control period (5 s)"),
        ("", "", "nobody", "sensors[1].to: unknown spacecraft 'nobody' (known: chief, deputy)"),
    ],
)
def test_bad_design_is_one_line_naming_the_field(tmp_path, gnss, isl, to, expected):
    with pytest.raises(ScenarioError) as info:
        prepare(_scenario(tmp_path, gnss, isl, to))
    assert str(info.value) == expected


@pytest.mark.parametrize(
    ("gnss", "isl", "expected"),
    [
        ("sigma_m = -1.0", "", "sensors[0].sigma_m: must be finite and ≥ 0"),
        ("own_sigma_m_s = [0.1, 0.1]", "", "sensors[0].own_sigma_m_s: must be one number, or one per axis"),
        ("own_tau_s = 0.0", "", "sensors[0].own_tau_s: Input should be greater than 0"),
        ("common_tau_s = -5.0", "", "sensors[0].common_tau_s: Input should be greater than 0"),
        ("", "sigma_m_s = -0.1", "sensors[1].sigma_m_s: Input should be greater than or equal to 0"),
        ("", "max_range_m = 0.0", "sensors[1].max_range_m: Input should be greater than 0"),
    ],
)
def test_bad_table_is_one_line_naming_the_field(tmp_path, gnss, isl, expected):
    with pytest.raises(ScenarioError) as info:
        _scenario(tmp_path, gnss, isl)
    assert str(info.value).startswith(expected) and "\n" not in str(info.value)


def test_both_need_an_orbit(tmp_path):
    with pytest.raises(ScenarioError, match=r'^sensors\[0\]: kind = "gnss" measures gnss, which needs an \[orbit\]'):
        prepare(_scenario(tmp_path, to="sc1", base="consensus-sync-a-stable"))


# Camera bearing: closed forms, field of view, statistics


def _attitudes(n, seed=0):
    """Random unit quaternions (4, n), scalar first."""
    q = np.random.default_rng(seed + 100).normal(size=(4, n))
    return q / np.linalg.norm(q, axis=0)


def _with_attitude(x, q):
    return x._replace(q_bi=q)


def _camera(sigma=0.0, boresight=(1.0, 0.0, 0.0), half_fov_deg=180.0, target=0, max_range_m=np.inf):
    b = np.asarray(boresight, dtype=float)
    return CameraBearing(jnp.asarray(sigma, dtype=float), jnp.asarray(b / np.linalg.norm(b)),
                         jnp.asarray(np.cos(np.radians(half_fov_deg))), jnp.int32(target), jnp.asarray(max_range_m))


def _body_los(x, target):
    """NumPy closed form: C(q_bi)ᵀ (r_t − r_i)/|r_t − r_i| per spacecraft (3, n), the DCM of
    q_bi written out (body to inertial)."""
    q0, q1, q2, q3 = np.asarray(x.q_bi)
    c = np.array([
        [q0**2 + q1**2 - q2**2 - q3**2, 2 * (q1 * q2 - q0 * q3), 2 * (q1 * q3 + q0 * q2)],
        [2 * (q1 * q2 + q0 * q3), q0**2 - q1**2 + q2**2 - q3**2, 2 * (q2 * q3 - q0 * q1)],
        [2 * (q1 * q3 - q0 * q2), 2 * (q2 * q3 + q0 * q1), q0**2 - q1**2 - q2**2 + q3**2],
    ])  # (3, 3, n): C_ib
    rho = np.asarray(x.r_eci)[:, [target]] - np.asarray(x.r_eci)
    with np.errstate(invalid="ignore"):
        u = rho / np.linalg.norm(rho, axis=0)
    return np.einsum("jin,jn->in", c, u), np.linalg.norm(rho, axis=0)


def test_camera_bearing_is_the_line_of_sight_in_body_axes():
    """Random positions and attitudes, the whole sky in view: the reading's vector is
    ``C_ibᵀ ρ̂`` to 1e-12, unit, valid but for the target's own column (all zeros); with
    ``sigma_rad = 0`` the reading is the truth bit for bit."""
    n, target = 8, 3
    x = _with_attitude(_state(n, seed=5), _attitudes(n))
    sensor = _camera(target=target)
    truth = np.asarray(sensor.truth({}, x))
    expected, _ = _body_los(x, target)
    others = np.arange(n) != target
    assert truth.dtype == np.float64
    np.testing.assert_allclose(truth[:3, others], expected[:, others], rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(truth[:3, others], axis=0), 1.0, rtol=0, atol=1e-14)
    np.testing.assert_array_equal(truth[3], others.astype(float))
    np.testing.assert_array_equal(truth[:, target], 0.0)
    values, _ = _calls(sensor, x, 2)
    for value in values:
        np.testing.assert_array_equal(value, truth)


def test_camera_outside_its_field_of_view_or_range_reads_zeros():
    """The target is valid only within ``fov_half_angle`` of the boresight and ``max_range_m``:
    the flags are the closed form's, and an invalid column reads zeros, noise or not."""
    n, target = 40, 0
    x = _with_attitude(_state(n, seed=6), _attitudes(n, seed=6))
    boresight = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    los, distance = _body_los(x, target)
    with np.errstate(invalid="ignore"):
        angle = np.degrees(np.arccos(np.clip(boresight @ los, -1.0, 1.0)))
    others = np.arange(n) != target
    half_fov, limit = np.median(angle[others]), np.median(distance[others])
    sensor = _camera(sigma=1e-3, boresight=boresight, half_fov_deg=half_fov, target=target, max_range_m=limit)
    truth = np.asarray(sensor.truth({}, x))
    value = np.asarray(sensor.measure(truth, x, (), jax.random.key(3))[0])
    seen = others & (angle <= half_fov) & (distance <= limit)
    assert 0 < seen.sum() < (others & (angle <= half_fov)).sum() < n - 1
    for reading in (truth, value):
        np.testing.assert_array_equal(reading[3], seen.astype(float))
        np.testing.assert_array_equal(reading[:, ~seen], 0.0)
        assert not np.any(np.signbit(reading[:, ~seen]))
    assert np.all(value[:3, seen] != truth[:3, seen])


def test_camera_noise_is_a_rotation_across_the_line_of_sight_with_the_stated_sigma():
    """4000 spacecraft: the reading is unit; its error has no first-order part along the line of
    sight (``e·u = −|e|²/2`` exactly for two unit vectors); across it, on two orthonormal axes,
    the errors have standard deviation σ (within 5 standard errors), zero mean, no correlation."""
    n, sigma = 4000, 2e-3
    x = _with_attitude(_state(n, seed=7, spread_m=5e4), _attitudes(n, seed=7))
    values, truth = _calls(_camera(sigma=sigma), x, 1)
    u, measured = truth[:3, 1:], values[0, :3, 1:]
    np.testing.assert_allclose(np.linalg.norm(measured, axis=0), 1.0, rtol=0, atol=1e-14)
    e = measured - u
    along = np.einsum("kn,kn->n", e, u)
    np.testing.assert_allclose(along, -0.5 * np.einsum("kn,kn->n", e, e), rtol=0, atol=1e-14)
    assert np.max(np.abs(along)) < 20.0 * sigma**2
    # Two axes across each line of sight.
    a = np.where(np.abs(u[0]) < 0.9, np.array([1.0, 0.0, 0.0])[:, None], np.array([0.0, 1.0, 0.0])[:, None])
    e1 = np.cross(u, a, axis=0)
    e1 /= np.linalg.norm(e1, axis=0)
    e2 = np.cross(u, e1, axis=0)
    across = np.stack([np.einsum("kn,kn->n", e, e1), np.einsum("kn,kn->n", e, e2)])
    _assert_sigma(across, np.array([sigma, sigma]), axis=1)
    assert np.all(np.abs(across.mean(axis=1)) < 5.0 * sigma / np.sqrt(n - 1))
    assert abs(np.corrcoef(across)[0, 1]) < 5.0 / np.sqrt(n - 1)


def test_camera_replays_and_a_spacecraft_draws_the_same_whatever_the_formation_size():
    sensor = _camera(sigma=1e-3, target=1)
    x5 = _with_attitude(_state(5), _attitudes(5))
    x2 = PlantState(*(np.asarray(a)[:, :2] for a in x5))
    a, _ = _calls(sensor, x5, 3)
    np.testing.assert_array_equal(a, _calls(sensor, x5, 3)[0])
    np.testing.assert_array_equal(a[:, :, :2], _calls(sensor, x2, 3)[0])
    other, _ = _calls(sensor, x5, 3, seed=8)
    assert not np.any(a[:, :3, [0, 2, 3, 4]] == other[:, :3, [0, 2, 3, 4]])


def test_camera_follows_the_sensor_protocol():
    part = _camera()
    assert isinstance(part, protocols.Sensor)
    assert protocols.protocol_problems(part, "sensor") == []


CAMERA = """
    [[sensors]]
    kind = "camera-bearing"
    to = "{to}"
    {camera}
"""


def _camera_scenario(tmp_path, camera="sigma_rad = 1e-4\nfov_half_angle_deg = 180.0", to="chief", base="leo-pair-differential-drag-free"):
    text = (
        f'extends = "{base}"\nseed = 2\ndisturbances = []\n\n[sim]\nt_final_s = 30.0\nrecord_interval_s = 5.0\n'
        + textwrap.dedent(CAMERA.format(camera=camera, to=to))
    )
    path = tmp_path / f"c{abs(hash(text))}.toml"
    path.write_text(text, encoding="utf-8")
    return load_scenario(path)


def test_camera_is_recorded_through_the_pipeline(tmp_path):
    """The deputy's camera sees the chief (whole sky), within a few σ of the true line of sight
    in its body axes; the chief's column is zeros; a boresight away from the chief sees nothing."""
    ds, _ = simulate_built(prepare(_camera_scenario(tmp_path)))
    bearing = ds.measured_bearing
    assert bearing.dims == ("time", "spacecraft", "bearing_component")
    assert list(bearing.bearing_component.values) == ["x", "y", "z", "valid"]
    assert (bearing.attrs["units"], bearing.attrs["frame"]) == ("1", "body")
    rho = ds.r_eci.values[:, 0] - ds.r_eci.values[:, 1]
    truth_b = np.einsum("tji,tj->ti", np.asarray(quat_to_dcm(ds.q.values[:, 1])), rho / np.linalg.norm(rho, axis=-1)[:, None])
    assert np.max(np.linalg.norm(bearing.values[:, 1, :3] - truth_b, axis=-1)) < 5e-4
    np.testing.assert_array_equal(bearing.values[:, 1, 3], 1.0)
    np.testing.assert_array_equal(bearing.values[:, 0], 0.0)
    # The chief is along-track ahead: a camera looking the other way, 30° wide, sees nothing.
    away = [float(c) for c in -truth_b[0]]
    ds, _ = simulate_built(prepare(_camera_scenario(
        tmp_path, f"sigma_rad = 1e-4\nfov_half_angle_deg = 30.0\nboresight_b = [{away[0]!r}, {away[1]!r}, {away[2]!r}]")))
    np.testing.assert_array_equal(ds.measured_bearing.values, 0.0)


@pytest.mark.parametrize(("camera", "to", "expected"), [
    ("fov_half_angle_deg = 0.0", "chief", "sensors[0].fov_half_angle_deg: Input should be greater than 0"),
    ("fov_half_angle_deg = 200.0", "chief", "sensors[0].fov_half_angle_deg: Input should be less than or equal to 180"),
    ("", "chief", "sensors[0].fov_half_angle_deg: Field required"),
    ("fov_half_angle_deg = 10.0\nboresight_b = [0.0, 0.0, 2.0]", "chief", "sensors[0].boresight_b: norm is 2; expected a unit vector"),
    ("fov_half_angle_deg = 10.0\nsigma_rad = -1e-3", "chief", "sensors[0].sigma_rad: Input should be greater than or equal to 0"),
])
def test_bad_camera_table_is_one_line_naming_the_field(tmp_path, camera, to, expected):
    with pytest.raises(ScenarioError) as info:
        _camera_scenario(tmp_path, camera, to)
    assert str(info.value).startswith(expected) and "\n" not in str(info.value)


def test_bad_camera_design_is_one_line(tmp_path):
    with pytest.raises(ScenarioError) as info:
        prepare(_camera_scenario(tmp_path, to="nobody"))
    assert str(info.value) == "sensors[0].to: unknown spacecraft 'nobody' (known: chief, deputy)"
    with pytest.raises(ScenarioError, match=r'^sensors\[0\]: kind = "camera-bearing" measures bearing, which needs an \[orbit\]'):
        prepare(_camera_scenario(tmp_path, to="sc1", base="consensus-sync-a-stable"))
