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

# Physically meaningful ranges (docs/scenarios.md, "Ranges"): beyond them a value is a typo or
# an overflow waiting to happen, never a spacecraft.
MAX_TIME_S = 1e9
"""Longest time anywhere in a scenario, s (about 32 years)."""
MAX_GAIN = 1e6
"""Largest control gain or link weight (in its own SI unit)."""
MAX_TORQUE_NM = 1e6
MAX_FORCE_N = 1e6
MAX_RATE_RAD_S = 1e3
MAX_DISTANCE_M = 1e13
"""Largest position or semi-major axis, m (beyond Pluto's orbit)."""
MAX_SPEED_M_S = 1e6


def bounded_norm(limit, unit):
    """Pydantic validator: the vector's Euclidean norm is at most ``limit``."""

    def check(v):
        norm = float(np.linalg.norm(v))
        if norm > limit:
            raise ValueError(f"norm {norm:.3g} {unit} is above {limit:g} {unit}: not a physical value")
        return v

    return AfterValidator(check)


def Bounded3(limit, unit):  # noqa: N802 (a type constructor)
    """Three finite numbers whose norm is at most ``limit`` (in ``unit``)."""
    return Annotated[Vec3, bounded_norm(limit, unit)]

Quat = Annotated[list[float], Field(min_length=4, max_length=4), AfterValidator(_check_quaternion)]
"""A scalar-first quaternion, unit to within :data:`QUAT_NORM_TOL`."""


def whole_ratio(a, b):
    """``a / b`` as an int when it is a whole number (to 1e-9 relative), else None."""
    r = a / b
    if not np.isfinite(r):
        return None
    k = round(r)
    return k if k >= 1 and abs(r - k) <= 1e-9 * max(1.0, r) else None


class FormationTolerance(Table):
    """``[analysis]`` threshold of the formation papers (SPEC §2 and §4): their settle and
    reconfiguration times count from when every error stays below it."""

    formation_tolerance_m: float = Field(
        1.0, gt=0, le=MAX_DISTANCE_M, description="Formation error (translation removed) that counts as settled, m."
    )
