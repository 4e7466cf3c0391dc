"""A law flying on each spacecraft's navigation filter: the same in the compiled loop and in
software in the loop, what the filter does with late, held and lost fixes, and one line for
bad input."""

import numpy as np
import pytest

import coopsat
from coopsat.scenarios.load import ScenarioError


def _nav(t_final_s=60.0):
    return coopsat.Scenario.load("leo-pair-navigation").set("sim.t_final_s", t_final_s)


def _error(scenario, change=()):
    """The error's lines, whether the change is refused when it is made or when it is built."""
    with pytest.raises((ScenarioError, ValueError)) as err:
        for key, value in change:
            scenario = scenario.set(key, value)
        coopsat.validate(scenario)
    return str(err.value).splitlines()


def test_sil_equals_the_compiled_loop_on_estimates():
    """One process per spacecraft, each running the filter and the law: every recorded variable
    (truth, estimates, covariances, innovations, commands) equal to coopsat run's to 1e-12."""
    from coopsat.workflows.sil.run import sil

    s = _nav(60.0)
    ours, ref = sil(s), coopsat.run(s)
    assert set(ours.dataset.data_vars) == set(ref.dataset.data_vars)
    assert {"nav_estimate_lvlh", "nav_covariance_lvlh", "nav_nis"} <= set(ref.dataset.data_vars)
    for v in ref.dataset.data_vars:
        np.testing.assert_allclose(ours.dataset[v].values, ref.dataset[v].values, rtol=0, atol=1e-12, err_msg=v)
    # The filter ran: fixes and ranges used at every period by the deputy, not by the chief.
    used = ref.dataset["nav_updated"].values
    assert np.all(used[:, 1, :2] == 1.0) and np.all(used[:, 0, 1] == 0.0)


def test_the_law_reads_the_estimate_not_the_truth():
    """lvlh-pd's recorded relative state is the filter's estimate, and it differs from the
    truth by the estimate's error (millimetres to centimetres), not by zero."""
    ds = coopsat.run(_nav(60.0)).dataset
    np.testing.assert_array_equal(ds["rho_lvlh"].values[:, 1], ds["nav_estimate_lvlh"].values[:, 1, :3])
    error = np.abs(ds["nav_error"].values[:, 1, :3])
    assert 1e-4 < error.max() < 1.0
    assert np.all(ds["nav_estimate_lvlh"].values[:, 0] == 0.0)  # the chief's own estimate


def test_a_delayed_fix_is_processed_at_its_time_stamp_once():
    """A constant two-period delay: with max_age_s covering it, every later fix is used once, two
    periods late; the t = 0 fix is used at once, because the network's history before t = 0 is
    the first outbox (its convention for delay lines), and not again when it arrives "late" at
    t = 10 s. With max_age_s = 0 none is used and the filter flies on range alone."""
    delayed = _nav(60.0).update({"network": {"kind": "complete", "delivery": {"kind": "delayed", "delay_s": 10.0}}})
    kept = coopsat.run(delayed.set("navigation.max_age_s", 10.0)).dataset["nav_updated"].values[:, 1, 0]
    np.testing.assert_array_equal(kept, ((np.arange(kept.size) >= 3) | (np.arange(kept.size) == 0)).astype(float))
    dropped = coopsat.run(delayed).dataset["nav_updated"].values[:, 1, 0]
    np.testing.assert_array_equal(dropped, (np.arange(dropped.size) == 0).astype(float))


def test_a_slower_gnss_is_used_only_when_it_reads():
    """A fix every 15 s (three periods): the filter uses it in one period of three, not the held
    reading in between."""
    s = _nav(60.0)
    sensors = s["sensors"]
    sensors[0] = {**sensors[0], "period_s": 15.0}
    used = coopsat.run(s.set("sensors", sensors)).dataset["nav_updated"].values[:, 1, 0]
    np.testing.assert_array_equal(used, (np.arange(used.size) % 3 == 0).astype(float))


@pytest.mark.parametrize("change, message", [
    ({"navigation.accel_psd_m2_s3": [1e-10, 0.0, 1e-10]},
     "navigation.accel_psd_m2_s3: the filter needs accel_psd_m2_s3 (Q) positive definite"),
    ({"navigation.initial_sigma_m": 0.0}, "navigation.initial_sigma_m: the filter needs initial_sigma_m (P0) positive definite"),
    ({"navigation.measurements": ["gnss", "lidar"]}, "navigation.measurements[1]: Input should be 'gnss', 'isl-range' or 'camera-bearing'"),
    ({"navigation.max_age_s": 7.0}, "navigation.max_age_s (7 s) must be a whole multiple of the control period (5 s)"),
    ({"navigation.chief": "moon"}, "navigation.chief: unknown spacecraft 'moon'"),
])
def test_bad_navigation_tables_give_one_line(change, message):
    lines = _error(_nav(), change.items())
    assert any(message in line for line in lines), lines


def test_a_sensor_without_noise_or_absent_is_refused():
    s = _nav()
    sensors = s["sensors"]
    quiet = [{"kind": "gnss"}, sensors[1]]
    assert "is not positive definite" in _error(s.set("sensors", quiet))[0]
    assert 'navigation.measurements: "isl-range" needs a [[sensors]] table kind = "isl-range"' in _error(
        s.set("sensors", sensors[:1]))[0]
    rate = [{**sensors[0], "period_s": 7.5}, sensors[1]]
    assert "period_s (7.5 s) must be a whole multiple of the control period (5 s)" in _error(s.set("sensors", rate))[0]


def test_a_law_without_a_per_spacecraft_form_on_x_lvlh_is_refused():
    s = _nav().update({"controller": {"kind": "lvlh-consensus", "period_s": 5.0, "k_p": 1e-3, "k_d": 0.1,
                                      "slot_lvlh_m": [[0.0, 0.0, 0.0], [-100.0, 0.0, 0.0]]}}).set("actuators.frame", "inertial")
    lines = _error(s)
    assert any("navigation: controller kind 'lvlh-consensus' does not read x_lvlh" in line for line in lines), lines


def test_cartwheel_keeping_flies_on_the_relative_filter_over_a_relayed_delayed_ring():
    """cartwheel-keeping reads x_lvlh: on the filter, each deputy uses the chief's fixes
    relayed over the ring (1 s a hop, processed at their time stamps: max_age_s = 3 s) from
    its first delay on, and its thrusters fire on the estimate's millimetres where the truth's
    30 µm navigation fires none."""
    base = coopsat.Scenario.load("cartwheel-keeping-ground").set("sim.t_final_s", 100.0).set("published", [])
    nav = base.set("sensors", base["sensors"] + [{"kind": "gnss", "sigma_m": 0.003, "sigma_m_s": 3e-5}]).set(
        "navigation", {"kind": "relative-ekf", "chief": "chief", "measurements": ["gnss"], "accel_psd_m2_s3": 1e-12,
                       "initial_sigma_m": 0.01, "initial_sigma_m_s": 1e-4, "max_age_s": 3.0})
    flown, truth = coopsat.run(nav), coopsat.run(base)
    used = flown.dataset["nav_updated"].values[:, :, 0]
    assert not used[:, 0].any() and used[3:, 1:].all()  # the chief has no fix to difference
    error = flown.dataset["nav_error"].values[:, 1:, :3]
    assert 1e-4 < np.sqrt(np.mean(error**2)) < 0.01
    bits = lambda r: sum(r.metrics[f"impulse_bits_{d}"] for d in ("dep1", "dep2", "dep3"))  # noqa: E731
    assert bits(truth) == 0 < bits(flown)


def _observation_on_orbit_filter(t_final_s):
    base = coopsat.Scenario.load("observation-cooperative").set("sim.t_final_s", t_final_s).set("published", [])
    return base, base.set("sensors", list(base["sensors"] or []) + [{"kind": "gnss", "sigma_m": 0.5, "sigma_m_s": 0.005}]).set(
        "navigation", {"kind": "orbit-ekf", "accel_psd_m2_s3": 1e-8, "initial_sigma_m": 5.0, "initial_sigma_m_s": 0.05})


def test_the_observation_law_flies_on_each_spacecrafts_orbit_filter():
    """orbit-ekf: every spacecraft estimates its own orbit from its fixes (no messages), to
    about the fixes' half metre; the law computes the target's elevation from the estimate, so
    it differs from the truth run's by about 0.5 m / 2000 km = 2.5e-7 rad, not by zero."""
    base, nav = _observation_on_orbit_filter(30.0)
    flown, truth = coopsat.run(nav), coopsat.run(base)
    ds = flown.dataset
    assert ds["nav_updated"].values.all() and "nav_estimate_eci" in ds
    rms = flown.metrics["nav_position_error_rms_m"]
    assert 0.05 < rms < 3.0, rms
    elevation, elevation_truth = ds["target_elevation"].values, truth.dataset["target_elevation"].values
    assert 1e-9 < np.abs(elevation - elevation_truth).max() < 1e-5


@pytest.mark.slow
def test_sil_equals_the_compiled_loop_on_orbit_estimates():
    """The observation law on each spacecraft's orbit filter, one process each: equal to
    coopsat run's to 1e-12."""
    from coopsat.workflows.sil.run import sil

    _, nav = _observation_on_orbit_filter(20.0)
    ours, ref = sil(nav), coopsat.run(nav)
    for v in ref.dataset.data_vars:
        np.testing.assert_allclose(ours.dataset[v].values, ref.dataset[v].values, rtol=0, atol=1e-12, err_msg=v)
