"""Building blocks of scenario tables shared by the core schema and every plug-in's table.

Every table forbids unknown keys, NaN and infinity, and is frozen; vectors and quaternions are
checked by the annotated types below (one definition each).
"""

from typing import Annotated

import numpy as np
from pydantic import AfterValidator, BaseModel, BeforeValidator, ConfigDict, Field

QUAT_NORM_TOL = 0.05
"""Scenario quaternions are normalised at load; a norm further than this from 1 is a typo."""


class Table(BaseModel):
    """Base of every scenario table: unknown keys, NaN, infinity and wrong types are errors.

    Strict: a bool or a string where a number belongs (``alpha = true``, ``dt_s = "0.01"``) or
    a string where a bool belongs (``short_way = "yes"``) is refused, not coerced; an integer
    is a valid float (TOML writes ``1`` for 1.0).
    """

    # NaN and infinity are never valid input (an unsaturated actuator omits torque_max_nm).
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False, strict=True)


def _list_as_tuple(v):
    # TOML has arrays, not tuples: accept an array where a fixed-length record is expected
    # (its elements are still validated strictly).
    return tuple(v) if isinstance(v, list) else v


def Record(*types):  # noqa: N802 (a type constructor, used like tuple[...])
    """A fixed-length TOML array of the given element types, validated strictly."""
    return Annotated[tuple[types], BeforeValidator(_list_as_tuple)]


def _check_quaternion(q):
    norm = float(np.linalg.norm(q))
    if not np.all(np.isfinite(q)) or norm == 0.0:
        raise ValueError("must be a non-zero, finite quaternion [q0, q1, q2, q3] (scalar first)")
    if abs(norm - 1.0) > QUAT_NORM_TOL:
        raise ValueError(
            f"norm is {norm:.4g}; expected a unit quaternion (scalar first; within {QUAT_NORM_TOL:g} of 1, "
            "rounded values are normalised)"
        )
    return q


def check_finite(v):
    """Pydantic validator: every element finite."""
    if not np.all(np.isfinite(v)):
        raise ValueError("must be finite")
    return v


Vec3 = Annotated[list[float], Field(min_length=3, max_length=3), AfterValidator(check_finite)]
"""Three finite numbers."""

Quat = Annotated[list[float], Field(min_length=4, max_length=4), AfterValidator(_check_quaternion)]
"""A scalar-first quaternion, unit to within :data:`QUAT_NORM_TOL`."""


def whole_ratio(a, b):
    """``a / b`` as an int when it is a whole number (to 1e-9 relative), else None."""
    r = a / b
    k = round(r)
    return k if k >= 1 and abs(r - k) <= 1e-9 * max(1.0, r) else None
