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
    assert np.all(used[:, 1] == 1.0) and np.all(used[:, 0, 1] == 0.0)


def test_the_law_reads_the_estimate_not_the_truth():
    """lvlh-pd's recorded relative state is the filter's estimate, and it differs from the
    truth by the estimate's error (millimetres to centimetres), not by zero."""
    ds = coopsat.run(_nav(60.0)).dataset
    np.testing.assert_array_equal(ds["rho_lvlh"].values[:, 1], ds["nav_estimate_lvlh"].values[:, 1, :3])
    error = np.abs(ds["nav_error_lvlh"].values[:, 1, :3])
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
    ({"navigation.measurements": ["gnss", "lidar"]}, "navigation.measurements[1]: Input should be 'gnss' or 'isl-range'"),
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
