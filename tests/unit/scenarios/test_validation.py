"""Scenario validation: every bad input is one ScenarioError line naming the field and the cause.

Each case starts from a small valid scenario (two spacecraft, a ring, law (3) at 0.01 s),
breaks one thing, and checks the message: one line, the field path, what is expected.
"""

import copy
import warnings

import pytest
import tomli_w

from coopsat.scenarios.build import DesignWarning, build
from coopsat.scenarios.load import ScenarioError, bundled_names, load_scenario, resolved_toml
from coopsat.plugins.torque_actuators import IdealTorque
from coopsat.scenarios.schema import Scenario

BASE = {
    "name": "base",
    "sim": {"t_final_s": 1.0, "dt_s": 0.01},
    "spacecraft": [
        {"inertia_kgm2": [1.0, 0.9, 1.1], "q_bi": [1.0, 0.0, 0.0, 0.0], "omega_b_rad_s": [0.1, 0.0, 0.0]},
        {"inertia_kgm2": [1.0, 1.2, 0.8]},
    ],
    "network": {"kind": "ring"},
    "controller": {"kind": "consensus-sync", "period_s": 0.01, "alpha": 1.0, "beta": 2.0},
}


def _assign(raw, path, value):
    """Set ``raw[a][b]...`` from a dotted path (integers index lists)."""
    *parents, last = path.split(".")
    node = raw
    for part in parents:
        node = node[int(part)] if isinstance(node, list) else node.setdefault(part, {})
    if isinstance(node, list):
        node[int(last)] = value
    else:
        node[last] = value


def scenario_file(tmp_path, changes=None, n_spacecraft=2, stem="case"):
    """Write BASE (with ``changes``: dotted path -> value) to ``tmp_path/<stem>.toml``."""
    raw = copy.deepcopy(BASE)
    while len(raw["spacecraft"]) < n_spacecraft:
        raw["spacecraft"].append({"inertia_kgm2": [1.0, 1.1, 0.9]})
    for path, value in (changes or {}).items():
        _assign(raw, path, value)
    path = tmp_path / f"{stem}.toml"
    path.write_text(tomli_w.dumps(raw), encoding="utf-8")
    return path


def load_error(path, overrides=()):
    """The one-line ScenarioError message of loading ``path``."""
    with pytest.raises(ScenarioError) as info:
        load_scenario(path, overrides)
    msg = str(info.value)
    assert "\n" not in msg, msg
    assert msg.strip(), "empty message"
    return msg


def build_error(path, overrides=()):
    """The one-line ScenarioError message of building ``path`` (loading succeeds)."""
    with pytest.raises(ScenarioError) as info:
        build_quietly(load_scenario(path, overrides))
    msg = str(info.value)
    assert "\n" not in msg, msg
    return msg


def build_quietly(scenario):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DesignWarning)
        return build(scenario)


# --------------------------------------------------------------------------------------- base


def test_base_scenario_is_valid_and_builds(tmp_path):
    scenario = load_scenario(scenario_file(tmp_path))
    built = build_quietly(scenario)
    assert built.names == ["sat1", "sat2"]
    assert built.n_records == 100
    assert built.checks["sampled-data"].ok
    assert built.warnings == []


# ------------------------------------------------------------------------------ unknown fields


def test_misspelt_top_level_key(tmp_path):
    msg = load_error(scenario_file(tmp_path, {"nmae": "typo"}))
    assert msg.startswith("nmae:")
    assert "unknown field" in msg


def test_misspelt_key_inside_a_table_written_by_hand(tmp_path):
    path = tmp_path / "alpah.toml"
    path.write_text(
        'name = "alpah"\n'
        "[sim]\nt_final_s = 1.0\ndt_s = 0.01\n"
        "[[spacecraft]]\ninertia_kgm2 = [1.0, 0.9, 1.1]\n"
        "[[spacecraft]]\ninertia_kgm2 = [1.0, 1.2, 0.8]\n"
        '[network]\nkind = "ring"\n'
        '[controller]\nkind = "consensus-sync"\nperiod_s = 0.01\nalpha = 1.0\nbeta = 2.0\nalpah = 1\n',
        encoding="utf-8",
    )
    msg = load_error(path)
    assert "controller.alpah" in msg
    assert "unknown field" in msg


@pytest.mark.parametrize(
    "path_in_file, expected",
    [
        ("sim.t_finl_s", "sim.t_finl_s"),
        ("network.wieght", "network.wieght"),
        ("spacecraft.1.omega_b", "spacecraft[1].omega_b"),
    ],
)
def test_misspelt_key_names_its_path(tmp_path, path_in_file, expected):
    msg = load_error(scenario_file(tmp_path, {path_in_file: 1.0}))
    assert expected in msg
    assert "unknown field" in msg


# --------------------------------------------------------------------------- types and ranges


def test_wrong_type(tmp_path):
    msg = load_error(scenario_file(tmp_path, {"controller.alpha": "big"}))
    assert msg.startswith("controller.alpha:")
    assert "number" in msg


@pytest.mark.parametrize("field", ["alpha", "beta", "period_s"])
def test_negative_gain_or_period(tmp_path, field):
    msg = load_error(scenario_file(tmp_path, {f"controller.{field}": -1.0}))
    assert msg.startswith(f"controller.{field}:")
    assert "greater than 0" in msg


def test_negative_time_step(tmp_path):
    msg = load_error(scenario_file(tmp_path, {"sim.dt_s": -0.01}))
    assert msg.startswith("sim.dt_s:")
    assert "greater than or equal to 0.000000001" in msg  # the smallest tick is 1e-9 s (docs: Ranges)


# ------------------------------------------------------------------------------------ inertia


def test_inertia_with_a_negative_moment(tmp_path):
    msg = load_error(scenario_file(tmp_path, {"spacecraft.0.inertia_kgm2": [1.0, -0.5, 1.0]}))
    assert msg.startswith("spacecraft[0].inertia_kgm2:")
    assert "positive definite" in msg


def test_inertia_matrix_with_a_negative_eigenvalue(tmp_path):
    # Positive diagonal, but eigenvalues 1 ± 2 and 1: -1 < 0.
    inertia = [[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    msg = load_error(scenario_file(tmp_path, {"spacecraft.1.inertia_kgm2": inertia}))
    assert msg.startswith("spacecraft[1].inertia_kgm2:")
    assert "positive definite" in msg


def test_inertia_breaking_the_triangle_inequality(tmp_path):
    msg = load_error(scenario_file(tmp_path, {"spacecraft.0.inertia_kgm2": [1.0, 1.0, 3.0]}))
    assert msg.startswith("spacecraft[0].inertia_kgm2:")
    assert "triangle inequality" in msg


def test_triangle_inequality_boundary_is_accepted(tmp_path):
    # A flat plate (I1 + I2 = I3) is a rigid body.
    scenario = load_scenario(scenario_file(tmp_path, {"spacecraft.0.inertia_kgm2": [1.0, 2.0, 3.0]}))
    assert scenario.spacecraft[0].inertia_kgm2 == [1.0, 2.0, 3.0]


def test_non_symmetric_inertia(tmp_path):
    inertia = [[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    msg = load_error(scenario_file(tmp_path, {"spacecraft.0.inertia_kgm2": inertia}))
    assert msg.startswith("spacecraft[0].inertia_kgm2:")
    assert "symmetric" in msg


def test_inertia_of_the_wrong_shape(tmp_path):
    msg = load_error(scenario_file(tmp_path, {"spacecraft.0.inertia_kgm2": [1.0, 1.0]}))
    assert msg.startswith("spacecraft[0].inertia_kgm2:")
    assert "3×3" in msg


def test_full_symmetric_inertia_is_accepted_and_builds(tmp_path):
    inertia = [[1.0, 0.1, 0.0], [0.1, 1.2, 0.0], [0.0, 0.0, 0.9]]
    scenario = load_scenario(scenario_file(tmp_path, {"spacecraft.0.inertia_kgm2": inertia}))
    assert build_quietly(scenario).system is not None


# -------------------------------------------------------------------------------- quaternions


def test_zero_quaternion(tmp_path):
    msg = load_error(scenario_file(tmp_path, {"spacecraft.0.q_bi": [0.0, 0.0, 0.0, 0.0]}))
    assert msg.startswith("spacecraft[0].q_bi:")
    assert "non-zero" in msg


def test_quaternion_of_norm_two(tmp_path):
    msg = load_error(scenario_file(tmp_path, {"spacecraft.1.q_bi": [2.0, 0.0, 0.0, 0.0]}))
    assert msg.startswith("spacecraft[1].q_bi:")
    assert "unit quaternion" in msg
    assert "norm is 2" in msg


def test_rounded_quaternion_is_accepted_and_normalised_at_build(tmp_path):
    scenario = load_scenario(scenario_file(tmp_path, {"spacecraft.0.q_bi": [0.75, 0.57, 0.30, -0.03]}))
    built = build_quietly(scenario)
    assert built.system is not None


def test_zero_reference_quaternion_of_the_tracking_law(tmp_path):
    changes = {
        "controller.kind": "consensus-track",
        "controller.k_p": 1.0,
        "controller.k_d": 1.0,
        "controller.omega_ref_rad_s": [0.0, 0.1, 0.0],
        "controller.q_ref0": [0.0, 0.0, 0.0, 0.0],
    }
    msg = load_error(scenario_file(tmp_path, changes))
    assert msg.startswith("controller.q_ref0:")


# ----------------------------------------------------------------------------- finite numbers


@pytest.mark.parametrize("literal", ["nan", "inf", "-inf"])
def test_non_finite_rate_written_as_a_toml_literal(tmp_path, literal):
    path = tmp_path / "nonfinite.toml"
    path.write_text(
        'name = "nonfinite"\n'
        "[sim]\nt_final_s = 1.0\ndt_s = 0.01\n"
        f"[[spacecraft]]\ninertia_kgm2 = [1.0, 0.9, 1.1]\nomega_b_rad_s = [{literal}, 0.0, 0.0]\n"
        "[[spacecraft]]\ninertia_kgm2 = [1.0, 1.2, 0.8]\n"
        '[network]\nkind = "ring"\n'
        '[controller]\nkind = "consensus-sync"\nperiod_s = 0.01\nalpha = 1.0\nbeta = 2.0\n',
        encoding="utf-8",
    )
    msg = load_error(path)
    assert msg.startswith("spacecraft[0].omega_b_rad_s")
    assert "finite" in msg


@pytest.mark.parametrize("field", ["q_bi", "inertia_kgm2"])
def test_nan_in_attitude_or_inertia(tmp_path, field):
    value = [float("nan"), 0.0, 0.0, 0.0] if field == "q_bi" else [float("nan"), 1.0, 1.0]
    msg = load_error(scenario_file(tmp_path, {f"spacecraft.0.{field}": value}))
    assert msg.startswith(f"spacecraft[0].{field}")
    assert "finite" in msg


# ------------------------------------------------------------------------------------ network


def test_edge_to_a_missing_spacecraft(tmp_path):
    changes = {"network": {"kind": "edges", "edges": [["sat1", "sat9", 1.0]]}}
    msg = build_error(scenario_file(tmp_path, changes))
    assert msg.startswith("network.edges[0]:")
    assert "'sat9'" in msg


def test_edges_without_edge_list(tmp_path):
    msg = load_error(scenario_file(tmp_path, {"network": {"kind": "edges"}}))
    assert msg.startswith("network:")
    assert "edges" in msg


def test_edge_with_a_non_positive_weight(tmp_path):
    changes = {"network": {"kind": "edges", "edges": [["sat1", "sat2", 0.0]]}}
    msg = build_error(scenario_file(tmp_path, changes))
    assert "network.edges" in msg
    assert "> 0" in msg


def test_adjacency_of_the_wrong_size(tmp_path):
    adjacency = [[0.0, 1.0, 1.0], [1.0, 0.0, 1.0], [1.0, 1.0, 0.0]]
    msg = build_error(scenario_file(tmp_path, {"network": {"kind": "adjacency", "adjacency": adjacency}}))
    assert msg.startswith("network.adjacency:")
    assert "3×3" in msg and "2 spacecraft" in msg


def test_adjacency_not_square(tmp_path):
    adjacency = [[0.0, 1.0, 1.0], [1.0, 0.0, 1.0]]
    msg = load_error(scenario_file(tmp_path, {"network": {"kind": "adjacency", "adjacency": adjacency}}))
    assert msg.startswith("network.adjacency:")
    assert "square" in msg


def test_hub_of_an_unknown_spacecraft(tmp_path):
    msg = build_error(scenario_file(tmp_path, {"network": {"kind": "star", "hub": "sat7"}}))
    assert msg.startswith("network.hub:")
    assert "'sat7'" in msg


DISCONNECTED = {"network": {"kind": "edges", "edges": [["sat1", "sat2", 1.0], ["sat3", "sat4", 1.0]]}}


def test_disconnected_graph_with_consensus_sync_is_an_error(tmp_path):
    msg = build_error(scenario_file(tmp_path, DISCONNECTED, n_spacecraft=4))
    assert msg.startswith("network:")
    assert "spanning tree" in msg
    assert "{sat1, sat2}" in msg and "{sat3, sat4}" in msg
    assert "require_spanning_tree" in msg


def test_disconnected_graph_builds_with_a_warning_when_allowed(tmp_path):
    changes = {"network": {**DISCONNECTED["network"], "require_spanning_tree": False}}
    scenario = load_scenario(scenario_file(tmp_path, changes, n_spacecraft=4))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        built = build(scenario)
    issued = [str(w.message) for w in caught if issubclass(w.category, DesignWarning)]
    assert any("spanning tree" in note for note in issued)
    assert any("spanning tree" in note for note in built.warnings)
    assert all("\n" not in note for note in built.warnings)


def test_disconnected_graph_is_fine_without_a_consensus_law(tmp_path):
    changes = {**DISCONNECTED, "controller": {"kind": "none"}}
    scenario = load_scenario(scenario_file(tmp_path, changes, n_spacecraft=4))
    assert build_quietly(scenario).warnings == []


@pytest.mark.parametrize(
    "network",
    [
        {"kind": "chain", "directed": True},
        {"kind": "edges", "directed": True, "edges": [["sat1", "sat2", 1.0], ["sat2", "sat3", 1.0], ["sat3", "sat4", 1.0]]},
    ],
    ids=["named-chain", "edge-list-chain"],
)
def test_directed_chain_has_a_spanning_tree(tmp_path, network):
    scenario = load_scenario(scenario_file(tmp_path, {"network": network}, n_spacecraft=4))
    built = build_quietly(scenario)
    assert not any("spanning tree" in note for note in built.warnings)
    assert built.adjacency[1, 0] > 0 and built.adjacency[0, 1] == 0  # sat2 hears sat1 only


def test_directed_graph_with_two_roots_has_no_spanning_tree(tmp_path):
    # sat1 and sat2 only transmit (to sat3): nobody can bring them to agree.
    edges = [["sat1", "sat3", 1.0], ["sat2", "sat3", 1.0]]
    changes = {"network": {"kind": "edges", "directed": True, "edges": edges}}
    msg = build_error(scenario_file(tmp_path, changes, n_spacecraft=3))
    assert "spanning tree" in msg
    assert "{sat1}" in msg and "{sat2}" in msg


# -------------------------------------------------------------------------------- time grid


def test_dt_that_does_not_divide_the_control_period(tmp_path):
    msg = load_error(scenario_file(tmp_path, {"sim.dt_s": 0.003}))
    assert "controller.period_s" in msg and "sim.dt_s" in msg
    assert "whole multiple" in msg


def test_record_interval_not_a_multiple_of_the_period(tmp_path):
    msg = load_error(scenario_file(tmp_path, {"sim.record_interval_s": 0.015}))
    assert "sim.record_interval_s" in msg
    assert "whole multiple" in msg and "control period" in msg


def test_t_final_not_a_multiple_of_the_record_interval(tmp_path):
    msg = load_error(scenario_file(tmp_path, {"sim.record_interval_s": 0.3}))
    assert "sim.t_final_s" in msg and "sim.record_interval_s" in msg
    assert "whole multiple" in msg


def test_time_grid_ratios_are_tolerant_of_float_rounding(tmp_path):
    # 0.3 / 0.1 = 2.9999999999999996 in floating point: still a whole multiple.
    changes = {"sim.dt_s": 0.1, "controller.period_s": 0.1, "sim.t_final_s": 0.3}
    assert build_quietly(load_scenario(scenario_file(tmp_path, changes))).n_records == 3


# ------------------------------------------------------------------------------------ PWM


@pytest.mark.parametrize("min_pulse", [0.01, 0.02])
def test_pwm_minimum_pulse_not_shorter_than_the_period(tmp_path, min_pulse):
    # A cross-table rule (the control period is the controller's): the plug-in checks it at build.
    changes = {"actuators": {"kind": "pwm-thrusters", "torque_max_nm": 0.05, "min_pulse_s": min_pulse}}
    msg = build_error(scenario_file(tmp_path, changes))
    assert "actuators.min_pulse_s" in msg
    assert "shorter than the control period" in msg


def test_pwm_needs_a_controller(tmp_path):
    changes = {
        "controller": {"kind": "none"},
        "actuators": {"kind": "pwm-thrusters", "torque_max_nm": 0.05, "min_pulse_s": 0.001},
    }
    msg = build_error(scenario_file(tmp_path, changes))
    assert "actuators" in msg and "controller" in msg


def test_unknown_controller_kind(tmp_path):
    msg = load_error(scenario_file(tmp_path, {"controller.kind": "consensus-snyc"}))
    assert msg.startswith("controller:")
    assert "consensus-sync" in msg  # names what is expected


# ------------------------------------------------------------------------------ files, TOML


def test_missing_file(tmp_path):
    msg = load_error(tmp_path / "nowhere.toml")
    assert "nowhere.toml" in msg and "no such scenario file" in msg


def test_unknown_bundled_name():
    msg = load_error("no-such-scenario")
    assert "'no-such-scenario'" in msg


def test_invalid_toml(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text("name = \n", encoding="utf-8")
    msg = load_error(path)
    assert "broken.toml" in msg and "not valid TOML" in msg


# ---------------------------------------------------------------------------- --set overrides


def test_numeric_override():
    scenario = load_scenario("consensus-sync-a", overrides=["sim.t_final_s=2.0", "controller.alpha=3"])
    assert scenario.sim.t_final_s == 2.0
    assert scenario.controller.alpha == 3.0
    assert scenario.controller.beta == 2.0  # untouched


def test_array_override():
    scenario = load_scenario("consensus-track", overrides=["controller.omega_ref_rad_s=[0, 0.2, 0]"])
    assert scenario.controller.omega_ref_rad_s == [0.0, 0.2, 0.0]


def test_nested_index_override():
    scenario = load_scenario("consensus-sync-a", overrides=["spacecraft.1.omega_b_rad_s=[0,0,0]"])
    assert scenario.spacecraft[1].omega_b_rad_s == [0.0, 0.0, 0.0]
    assert scenario.spacecraft[0].omega_b_rad_s == [0.5, 0.0, 0.5]  # the others keep theirs
    assert scenario.spacecraft[2].omega_b_rad_s == [0.5, 0.5, -0.5]


def test_override_on_a_file(tmp_path):
    scenario = load_scenario(scenario_file(tmp_path), overrides=["network.kind=complete", "sim.substeps=2"])
    assert scenario.network.kind == "complete"
    assert scenario.sim.substeps == 2


def test_override_that_breaks_validation_names_the_field():
    msg = load_error("consensus-sync-a", overrides=["controller.alpha=-1"])
    assert msg.startswith("controller.alpha:")


@pytest.mark.parametrize(
    "assignment, expected",
    [
        ("nosuch.key=1", "nosuch"),
        ("controller.alpah=1", "controller.alpah"),
        ("spacecraft.9.omega_b_rad_s=[0,0,0]", "spacecraft.9"),
        ("spacecraft.first.omega_b_rad_s=[0,0,0]", "spacecraft.first"),
        ("sim.t_final_s.x=1", "sim.t_final_s"),
        ("sim.t_final_s", "sim.t_final_s"),
    ],
)
def test_bad_override_key_path(assignment, expected):
    msg = load_error("consensus-sync-a", overrides=[assignment])
    assert expected in msg


def test_changing_the_actuator_kind_clears_the_pwm_fields():
    scenario = load_scenario("consensus-sync-a", overrides=["actuators.kind=ideal-torque"])
    assert isinstance(scenario.actuators, IdealTorque)
    assert "min_pulse_s" not in scenario.actuators.model_dump()
    assert scenario.actuators.torque_max_nm == float("inf")


def test_fields_set_after_a_kind_change_are_kept():
    scenario = load_scenario(
        "consensus-sync-a", overrides=["actuators.kind=ideal-torque", "actuators.torque_max_nm=0.1"]
    )
    assert isinstance(scenario.actuators, IdealTorque)
    assert scenario.actuators.torque_max_nm == 0.1


# ------------------------------------------------------------------------------------ extends


def test_extends_a_bundled_scenario(tmp_path):
    path = tmp_path / "variant.toml"
    path.write_text(
        'extends = "consensus-sync-a"\n[sim]\nt_final_s = 10.0\n[controller]\nalpha = 3.0\n',
        encoding="utf-8",
    )
    scenario = load_scenario(path)
    base = load_scenario("consensus-sync-a")
    assert scenario.name == "variant"  # the file's own stem, not the base's name
    assert len(scenario.spacecraft) == 5
    assert scenario.spacecraft == base.spacecraft
    assert scenario.sim.t_final_s == 10.0
    assert scenario.sim.dt_s == base.sim.dt_s
    assert scenario.sim.record_interval_s == base.sim.record_interval_s
    assert scenario.controller.alpha == 3.0
    assert scenario.controller.beta == base.controller.beta
    assert scenario.controller.period_s == base.controller.period_s
    assert scenario.network == base.network
    assert scenario.actuators == base.actuators


def test_extends_a_file_by_relative_path(tmp_path):
    scenario_file(tmp_path, stem="base")
    child = tmp_path / "child.toml"
    child.write_text('extends = "base.toml"\n[controller]\nbeta = 5.0\n', encoding="utf-8")
    scenario = load_scenario(child)
    assert scenario.name == "child"
    assert len(scenario.spacecraft) == 2
    assert scenario.controller.alpha == 1.0
    assert scenario.controller.beta == 5.0


def test_extends_with_another_kind_replaces_the_table(tmp_path):
    path = tmp_path / "ideal.toml"
    path.write_text('extends = "consensus-sync-a"\n[actuators]\nkind = "ideal-torque"\n', encoding="utf-8")
    scenario = load_scenario(path)
    assert isinstance(scenario.actuators, IdealTorque)


def test_extends_cycle_is_a_scenario_error(tmp_path):
    path = tmp_path / "loop.toml"
    path.write_text('extends = "loop.toml"\n', encoding="utf-8")
    msg = load_error(path)
    assert "extends" in msg


def test_extends_table_over_array_is_a_scenario_error(tmp_path):
    path = tmp_path / "table-over-array.toml"
    path.write_text('extends = "consensus-sync-a"\n[spacecraft]\ninertia_kgm2 = [1.0, 1.0, 1.0]\n', encoding="utf-8")
    assert "spacecraft" in load_error(path)


def test_spacecraft_names_must_be_plain(tmp_path):
    path = tmp_path / "bad-name.toml"
    path.write_text('extends = "rigid-body-free"\n[[spacecraft]]\nname = "sat\\n9"\ninertia_kgm2 = [1.0, 1.0, 1.0]\n', encoding="utf-8")
    msg = load_error(path)
    assert "spacecraft[0].name" in msg and "\n" not in msg


# --------------------------------------------------------------------------------- round trip


@pytest.mark.parametrize("name", bundled_names())
def test_resolved_toml_round_trips(tmp_path, name):
    scenario = load_scenario(name)
    path = tmp_path / f"{name}.toml"
    path.write_text(resolved_toml(scenario), encoding="utf-8")
    again = load_scenario(path)
    assert isinstance(again, Scenario)
    assert again.model_dump() == scenario.model_dump()


def test_there_are_at_least_eight_bundled_scenarios():
    assert len(bundled_names()) >= 8


@pytest.mark.parametrize("name", bundled_names())
def test_every_bundled_scenario_builds(name):
    built = build_quietly(load_scenario(name))
    assert len(built.names) == len(built.scenario.spacecraft)
