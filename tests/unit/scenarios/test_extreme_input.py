"""Extreme and misspelt input (issue 26): overflow is detected, not computed (no NumPy
RuntimeWarning, no "norm inf"), and a misspelt name is answered with the closest valid ones."""

import warnings

import numpy as np
import pytest

import coopsat
from coopsat.plugins.earth_environment import AerodynamicTorqueTable, facet_arrays
from coopsat.plugins.tables import arithmetic_message, extreme_values, vector_norm
from coopsat.scenarios import hints
from coopsat.scenarios.build import build
from coopsat.scenarios.load import ScenarioError, load_scenario
from coopsat.scenarios.schema import Scenario
from coopsat.sim.engine import NonFiniteStateError, _check_finite


@pytest.fixture
def no_warnings():
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a RuntimeWarning fails the test
        yield


def _error(overrides, name="consensus-sync-a-stable"):
    with pytest.raises(ScenarioError) as err:
        load_scenario(name, overrides)
    return str(err.value)


# --------------------------------------------------------------------------- numbers


@pytest.mark.parametrize(
    "v, expected",
    [([3.0, 4.0, 0.0], 5.0), ([1e308, 0.0, 0.0], 1e308), ([-1e308, 1e308, 0.0], 1e308 * 2**0.5), ([0.0] * 3, 0.0),
     ([5e-324, 5e-324, 0.0], 5e-324 * 2**0.5)],
)
def test_vector_norm_is_scaled_and_never_warns(no_warnings, v, expected):
    assert vector_norm(v) == pytest.approx(expected, rel=1e-15)


def test_a_norm_beyond_the_float_range_is_inf_without_a_warning(no_warnings):
    assert vector_norm([1.7e308, 1.7e308, 0.0]) == float("inf")


def test_extreme_values_name_the_numbers_far_from_any_physical_size():
    data = {"alpha": 1e-300, "beta": 2.0, "zero": 0.0, "q": [1.0, 1e150], "inner": {"k": -1e200}, "flag": True}
    assert extreme_values(data) == ["alpha = 1e-300", "q[1] = 1e+150", "inner.k = -1e+200"]


@pytest.mark.parametrize(
    "err, expected",
    [
        (FloatingPointError("overflow encountered in scalar divide"), "overflows float64 arithmetic"),
        (FloatingPointError("divide by zero encountered in divide"), "divides by zero in float64 arithmetic"),
        (FloatingPointError("invalid value encountered in subtract"), "gives an undefined result"),
        (OverflowError("math range error"), "overflows float64 arithmetic"),
    ],
)
def test_arithmetic_messages_name_the_cause(err, expected):
    assert arithmetic_message(err).startswith(expected)
    assert arithmetic_message(err, {"gain": 1e300}).endswith(": gain = 1e+300 is too extreme to compute with")


@pytest.mark.parametrize(
    "override, expected",
    [
        ("spacecraft.0.omega_b_rad_s=[1e308, 0, 0]",
         "spacecraft[0].omega_b_rad_s: norm 1e+308 rad/s is above 1000 rad/s: not a physical value"),
        ("spacecraft.0.omega_b_rad_s=[1.7e308, 1.7e308, 0]",
         "spacecraft[0].omega_b_rad_s: norm overflows float64 (above 1.8e+308 rad/s); at most 1000 rad/s is physical"),
        ("spacecraft.0.q_bi=[1.7e308, 1.7e308, 0, 0]", "spacecraft[0].q_bi: norm is above 1.8e+308 (overflows float64)"),
        ("spacecraft.1.omega_b_rad_s=[1e400, 0, 0]",
         "spacecraft[1].omega_b_rad_s[0]: Input should be a finite number, got inf (a value beyond 1.8e+308"),
        ("controller.alpha=" + "1" * 400,
         "controller.alpha: Input should be a valid number, got an integer that overflows float64"),
    ],
)
def test_overflowing_input_says_so_in_one_line(no_warnings, override, expected):
    message = _error([override])
    assert message.startswith(expected), message
    assert "\n" not in message and "norm inf" not in message


def test_a_build_that_would_overflow_names_the_table_and_the_extreme_number(no_warnings):
    scenario = load_scenario("deepspace-square-to-line-lqr", ["controller.position_scale_m=1e-300"])
    with pytest.raises(ScenarioError, match=r"^controller: divides by zero in float64 arithmetic \(.*\): "
                       r"position_scale_m = 1e-300 is too extreme to compute with$"):
        build(scenario)


def test_ragged_targets_are_a_design_error_not_a_numpy_one():
    scenario = load_scenario("deepspace-square-to-line-lqr", ["controller.target_m.0=[1.0]"])
    with pytest.raises(ScenarioError, match=r"controller.target_m: .* got 4 rows of lengths \[1, 2, 2, 2\]"):
        build(scenario)


def test_facet_normals_of_any_size_are_normalised_without_overflow(no_warnings):
    table = AerodynamicTorqueTable.model_validate(
        {"kind": "aerodynamic-torque", "facets": [[1e308, 1e308, 0.0, 0.1, 0.0, 0.0, 0.0], [0.0, 5e-324, 0.0, 0.1, 0.0, 0.0, 0.0]]}
    )
    normals, _, _ = facet_arrays(table)
    np.testing.assert_allclose(normals.T, [[2**-0.5, 2**-0.5, 0.0], [0.0, 1.0, 0.0]], rtol=1e-15)


def test_a_diverged_state_stops_the_run_before_the_analysis_squares_it():
    omega = np.zeros((3, 3, 2))  # (record, component, spacecraft)
    omega[2, 1, 1] = 1e150
    with pytest.raises(NonFiniteStateError, match=r"state diverged past 1e\+100 \(on its way to non-finite\): .* of b at t = 2 s"):
        _check_finite({"omega": omega}, np.arange(3.0), 0, False, ["a", "b"])


# --------------------------------------------------------------------------- misspelt names


def test_fields_at_follow_tables_lists_and_plugin_kinds():
    assert hints.fields_at(Scenario, ("controller", "consensus-sync"))[:3] == ["kind", "period_s", "alpha"]
    assert "a_m" in hints.fields_at(Scenario, ("spacecraft", 0, "elements"))
    assert "sigma_rad_s" in hints.fields_at(Scenario, ("sensors", 0, "gyro"))
    assert "t_s" in hints.fields_at(Scenario, ("network", "switches", 0))


@pytest.mark.parametrize(
    "override, expected",
    [
        ("controller.alpah=1", "controller.alpah: unknown field; did you mean `alpha`?"),
        ("contrller.alpha=1", "contrller: unknown field; did you mean `controller`?"),
        ("spacecraft_default.mass_kg=1", "spacecraft_default: unknown field; did you mean `spacecraft_defaults`"),
        ("spacecraft_defaults.mas_kg=1", "spacecraft_defaults.mas_kg: unknown field; did you mean `mass_kg`?"),
        ("controller.zzzz=1", "controller.zzzz: unknown field (none of this table's fields is close: kind, period_s, alpha, beta"),
        ("controller.kind=consensus-snyc", "controller: unknown kind 'consensus-snyc'; did you mean `consensus-sync`"),
        ("network.kind=rign", "network.kind: Input should be 'none', 'ring'"),
        ("sim.attitude=rigid", "sim.attitude: Input should be 'rigid-body' or 'small-angle'; did you mean `rigid-body`?"),
    ],
)
def test_misspelt_names_get_the_closest_valid_ones(override, expected):
    message = _error([override])
    assert message.startswith(expected), message


def test_a_misspelt_required_field_is_reported_before_its_absence():
    message = _error_without("sim", "t_final_s", "t_finl_s")
    assert message.startswith("sim.t_finl_s: unknown field; did you mean `t_final_s`?; sim.t_final_s: Field required"), message


def _error_without(table, key, wrong):
    document = coopsat.Scenario.load("consensus-sync-a-stable").to_dict()
    document[table][wrong] = document[table].pop(key)
    with pytest.raises(ScenarioError) as err:
        coopsat.Scenario.from_dict(document)
    return str(err.value)


def test_a_misspelt_bundled_name_gets_the_closest():
    with pytest.raises(ScenarioError, match=r"no bundled scenario named 'consensus-snyc-a'; did you mean `consensus-sync-a`"):
        load_scenario("consensus-snyc-a")


def test_a_controller_that_sends_nothing_on_a_delayed_network_builds_and_runs():
    scenario = coopsat.Scenario.load("delay-designed").update(
        {"controller": {"kind": "none"}, "published": [], "sim.t_final_s": 0.2}
    )
    result = coopsat.run(scenario)
    assert np.isfinite(result.dataset["omega"].values).all()


def test_a_plugin_table_without_a_kind_lists_the_kinds():
    assert _error(["network.delivery={delay_s=1}"]) == "network.delivery: needs a kind (one of: ideal, delayed)"
    assert _error(["sensors=[{sigma=1}]"]).startswith("sensors[0]: needs a kind (one of: star-tracker, gyro, ")
