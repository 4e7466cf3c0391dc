"""The field types other packages' tables use, ``coopsat.plugins.Quaternion`` and
``coopsat.plugins.UnitVector`` (docs/plugins.md, "Field types"): the rule of coopsat's own
``q_bi`` (finite, norm within QUAT_NORM_TOL of 1), values kept as written, one-line messages."""

import math
from typing import Literal

import pytest
from pydantic import BaseModel, ValidationError

import coopsat
from coopsat.plugins import Quaternion, Table, UnitVector
from coopsat.plugins.tables import QUAT_NORM_TOL


class Pointing(Table):
    kind: Literal["pointing"]
    q_commanded: Quaternion = (1.0, 0.0, 0.0, 0.0)
    axis_b: UnitVector = (0.0, 0.0, 1.0)


class Loose(BaseModel):
    """Not a coopsat Table (NaN allowed by the model): the type refuses it itself."""

    q: Quaternion
    axis: UnitVector


def _error(**fields):
    with pytest.raises(ValidationError) as info:
        Pointing(kind="pointing", **fields)
    (error,) = info.value.errors()
    return error["loc"], error["msg"].removeprefix("Value error, ")


def test_exported_lazily_from_coopsat_plugins():
    import coopsat.plugins as plugins

    assert {"Quaternion", "UnitVector"} <= set(plugins.__all__)
    assert plugins.Quaternion is Quaternion and plugins.UnitVector is UnitVector


def test_valid_values_are_kept_as_written():
    # A paper's rounded quaternion (norm 0.989) and a TOML array (a list) are accepted and held
    # as a tuple of the numbers written: the builder normalises, the resolved scenario replays.
    t = Pointing(kind="pointing", q_commanded=[0.75, 0.57, 0.30, -0.03], axis_b=[0.6, 0.8, 0])
    assert t.q_commanded == (0.75, 0.57, 0.30, -0.03)
    assert t.axis_b == (0.6, 0.8, 0.0) and all(isinstance(x, float) for x in t.axis_b)
    assert Pointing(kind="pointing").q_commanded == (1.0, 0.0, 0.0, 0.0)


@pytest.mark.parametrize("norm", [1.0 - QUAT_NORM_TOL * 0.99, 1.0 + QUAT_NORM_TOL * 0.99])
def test_the_tolerance_is_the_scenario_schemas(norm):
    Pointing(kind="pointing", q_commanded=[norm, 0.0, 0.0, 0.0], axis_b=[0.0, norm, 0.0])
    # coopsat's own q_bi accepts the same numbers
    coopsat.Scenario.load("rigid-body-free").set("spacecraft.0.q_bi", [norm, 0.0, 0.0, 0.0])


def test_a_non_unit_quaternion_is_refused_naming_its_norm():
    assert _error(q_commanded=[1.0, 1.0, 0.0, 0.0]) == (
        ("q_commanded",),
        "norm is 1.414; expected a unit quaternion [q0, q1, q2, q3], scalar first (norm within 0.05 of 1)",
    )
    assert _error(q_commanded=[0.0, 0.0, 0.0, 0.0]) == (
        ("q_commanded",), "is zero; expected a unit quaternion [q0, q1, q2, q3], scalar first",
    )


def test_a_non_unit_vector_is_refused_naming_its_norm():
    assert _error(axis_b=[1.0, 0.0, 0.7]) == (
        ("axis_b",), "norm is 1.221; expected a unit vector [x, y, z] (norm within 0.05 of 1)",
    )
    loc, msg = _error(axis_b=[1.5e308, 1.5e308, 0.0])
    assert msg.startswith("norm overflows float64")


def test_nan_and_infinity_are_refused():
    # In a Table, pydantic refuses the element (allow_inf_nan=False) and names its index.
    assert _error(q_commanded=[math.nan, 0.0, 0.0, 1.0]) == (("q_commanded", 0), "Input should be a finite number")
    assert _error(axis_b=[0.0, math.inf, 0.0])[0] == ("axis_b", 1)
    # In any other model the type refuses it itself.
    with pytest.raises(ValidationError) as info:
        Loose(q=[math.nan, 0.0, 0.0, 1.0], axis=[0.0, 0.0, 1.0])
    assert info.value.errors()[0]["msg"] == (
        "Value error, must be finite, got [nan, 0.0, 0.0, 1.0]; expected a unit quaternion [q0, q1, q2, q3], scalar first"
    )


@pytest.mark.parametrize(("field", "value", "message"), [
    ("q_commanded", [1.0, 0.0, 0.0], "needs 4 numbers [q0, q1, q2, q3] (scalar first), got 3"),
    ("q_commanded", (1.0, 0.0, 0.0, 0.0, 0.0), "needs 4 numbers [q0, q1, q2, q3] (scalar first), got 5"),
    ("axis_b", [0.0, 1.0], "needs 3 numbers [x, y, z], got 2"),
])
def test_a_wrong_length_is_one_line(field, value, message):
    assert _error(**{field: value}) == ((field,), message)


def test_wrong_types_are_refused_not_coerced():
    assert _error(q_commanded=[True, 0.0, 0.0, 0.0])[0] == ("q_commanded", 0)
    assert _error(axis_b="z")[0] == ("axis_b",)


def test_a_scenario_error_is_one_line_naming_the_field():
    # What a scenario file's author sees (the loader's message), through a plug-in's table.
    from coopsat.scenarios.load import format_validation_error

    with pytest.raises(ValidationError) as info:
        Pointing(kind="pointing", q_commanded=[0.5, 0.5, 0.5, 0.0])
    text = format_validation_error(info.value, "controller")
    assert text == (
        "controller.q_commanded: norm is 0.866; expected a unit quaternion [q0, q1, q2, q3], scalar first "
        "(norm within 0.05 of 1)"
    )
