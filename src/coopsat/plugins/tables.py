"""Building blocks of scenario tables shared by the core schema and every plug-in's table.

Every table forbids unknown keys, NaN and infinity, and is frozen; vectors and quaternions are
checked by the annotated types below (one definition each). :data:`Quaternion` and
:data:`UnitVector` are the field types offered to other packages' tables (``coopsat.plugins``).
"""

import math
import sys
from typing import Annotated

import numpy as np
from pydantic import AfterValidator, BaseModel, BeforeValidator, ConfigDict, Field, ValidationError, model_validator
from pydantic_core import core_schema

QUAT_NORM_TOL = 0.05
"""Largest distance of a scenario quaternion's (or unit vector's) norm from 1. The papers print
quaternions rounded to two decimals (``q_bi = [0.75, 0.57, 0.30, -0.03]``, norm 0.989), which
the builders normalise; a norm further than this from 1 is a typo (a lost or doubled digit)."""


def float_errors_raise():
    """Context in which NumPy's overflow, invalid value and division by zero raise
    :class:`FloatingPointError` instead of printing a RuntimeWarning."""
    return np.errstate(over="raise", invalid="raise", divide="raise")


def _refuse_float_trouble(value, handler):
    # Every table's checks run with float trouble raising: extreme input is refused naming its
    # table (the innermost), not computed into a RuntimeWarning line and an "inf" in the message.
    with float_errors_raise():
        try:
            return handler(value)
        except ArithmeticError as err:
            raise ValueError(arithmetic_message(err, value)) from None


EXTREME = 1e100
"""Magnitude beyond which (or below whose inverse, but not 0) a number is named as the likely
cause of a floating-point failure: no physical value in SI units comes near it."""


def extreme_values(data, prefix=""):
    """``name = value`` of every number in ``data`` (a table, or its dict, nested) whose
    magnitude is above :data:`EXTREME` or, not zero, below its inverse."""
    if isinstance(data, BaseModel):
        data = data.model_dump()
    items = data.items() if isinstance(data, dict) else enumerate(data) if isinstance(data, (list, tuple)) else ()
    found = []
    for key, value in items:
        name = f"{prefix}[{key}]" if isinstance(key, int) else f"{prefix}.{key}" if prefix else str(key)
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            if value != 0 and not 1 / EXTREME <= abs(value) <= EXTREME:
                found.append(f"{name} = {value:.3g}")
        else:
            found += extreme_values(value, name)
    return found


def arithmetic_message(err, data=None):
    """What a floating-point failure (FloatingPointError, OverflowError, ZeroDivisionError)
    means for the input, in words, naming the extreme numbers of ``data`` (the table where it
    happened) that likely caused it: ``overflows float64 arithmetic (overflow encountered in
    multiply): position_scale_m = 1e-300 is too extreme to compute with``."""
    text = str(err)
    if isinstance(err, OverflowError) or "overflow" in text:
        cause = "overflows float64 arithmetic"
    elif isinstance(err, ZeroDivisionError) or "divide by zero" in text:
        cause = "divides by zero in float64 arithmetic"
    else:
        cause = "gives an undefined result (such as inf - inf) in float64 arithmetic"
    extreme = extreme_values(data)[:3] if data is not None else []
    culprit = f": {', '.join(extreme)} {'is' if len(extreme) == 1 else 'are'} too extreme to compute with" if extreme else "; give values of physical size"
    return f"{cause} ({text}){culprit}"


class Table(BaseModel):
    """Base of every scenario table: unknown keys, NaN, infinity and wrong types are errors.

    Strict: a bool or a string where a number belongs (``alpha = true``, ``dt_s = "0.01"``) or
    a string where a bool belongs (``short_way = "yes"``) is refused, not coerced; an integer
    is a valid float (TOML writes ``1`` for 1.0).
    """

    # NaN and infinity are never valid input (an unsaturated actuator omits torque_max_nm).
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False, strict=True)

    @classmethod
    def __get_pydantic_core_schema__(cls, source, handler):
        # Outermost around each table's validation (its model validators included, which a
        # ``model_validator(mode="wrap")`` on this base would not enclose).
        return core_schema.no_info_wrap_validator_function(_refuse_float_trouble, handler(source))


def _list_as_tuple(v):
    # TOML has arrays, not tuples: accept an array where a fixed-length record is expected
    # (its elements are still validated strictly).
    return tuple(v) if isinstance(v, list) else v


def Record(*types):  # noqa: N802 (a type constructor, used like tuple[...])
    """A fixed-length TOML array of the given element types, validated strictly."""
    return Annotated[tuple[types], BeforeValidator(_list_as_tuple)]


FLOAT_MAX = sys.float_info.max
"""Largest float64 (about 1.8e308): a norm beyond it is reported as overflowing."""


def vector_norm(v):
    """Euclidean norm of finite numbers, scaled by the largest so that no square overflows
    (``np.linalg.norm`` squares first: [1e308, 0, 0] would give inf and a RuntimeWarning).

    Returns inf, without a warning, only when the norm itself is above :data:`FLOAT_MAX`.

    Notes
    -----
    ``math.hypot`` (scaled, correctly rounded in CPython ≥ 3.10): in plain Python, since a
    scenario validates a few vectors per spacecraft and NumPy's per-call cost was most of it.
    """
    flat = v if isinstance(v, (list, tuple)) and not any(isinstance(x, (list, tuple)) for x in v) else np.ravel(v).tolist()
    return math.hypot(*(float(x) for x in flat))


def _check_quaternion(q):
    norm = vector_norm(q) if all(math.isfinite(x) for x in q) else 0.0
    if norm == 0.0:
        raise ValueError("must be a non-zero, finite quaternion [q0, q1, q2, q3] (scalar first)")
    if abs(norm - 1.0) > QUAT_NORM_TOL:
        shown = f"{norm:.4g}" if math.isfinite(norm) else f"above {FLOAT_MAX:.3g} (overflows float64)"
        raise ValueError(
            f"norm is {shown}; expected a unit quaternion (scalar first; within {QUAT_NORM_TOL:g} of 1, "
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
        norm = vector_norm(v)
        if math.isinf(norm):
            raise ValueError(f"norm overflows float64 (above {FLOAT_MAX:.3g} {unit}); at most {limit:g} {unit} is physical")
        if norm > limit:
            raise ValueError(f"norm {norm:.3g} {unit} is above {limit:g} {unit}: not a physical value")
        return v

    return AfterValidator(check)


def Bounded3(limit, unit):  # noqa: N802 (a type constructor)
    """Three finite numbers whose norm is at most ``limit`` (in ``unit``)."""
    return Annotated[Vec3, bounded_norm(limit, unit)]

Quat = Annotated[list[float], Field(min_length=4, max_length=4), AfterValidator(_check_quaternion)]
"""A scalar-first quaternion, unit to within :data:`QUAT_NORM_TOL`."""


# The field types of plug-in tables (exported by coopsat.plugins, docs/plugins.md "Field
# types"): the rule of coopsat's own q_bi and spin axes, with messages that name the problem.


def _fixed_length(n, what):
    """Before validation: a TOML array (a list) as a tuple, of exactly ``n`` elements."""

    def check(v):
        if isinstance(v, list):
            v = tuple(v)
        if isinstance(v, tuple) and len(v) != n:
            raise ValueError(f"needs {n} numbers {what}, got {len(v)}")
        return v

    return BeforeValidator(check)


def _unit_norm(what):
    """After validation: every element finite and the norm within :data:`QUAT_NORM_TOL` of 1.
    The value is returned as written (not normalised), as coopsat's own scenario fields keep it:
    the resolved scenario then replays bit for bit, and the builder normalises."""

    def check(v):
        if not all(math.isfinite(x) for x in v):
            raise ValueError(f"must be finite, got {list(v)}; expected {what}")
        norm = vector_norm(v)
        if norm == 0.0:
            raise ValueError(f"is zero; expected {what}")
        if math.isinf(norm):
            raise ValueError(f"norm overflows float64 (above {FLOAT_MAX:.3g}); expected {what}")
        if abs(norm - 1.0) > QUAT_NORM_TOL:
            raise ValueError(f"norm is {norm:.4g}; expected {what} (norm within {QUAT_NORM_TOL:g} of 1)")
        return v

    return AfterValidator(check)


_QUATERNION = "a unit quaternion [q0, q1, q2, q3], scalar first"
_UNIT_VECTOR = "a unit vector [x, y, z]"

Quaternion = Annotated[tuple[float, float, float, float], _fixed_length(4, "[q0, q1, q2, q3] (scalar first)"),
                       _unit_norm(_QUATERNION)]
"""A scalar-first unit quaternion ``(q0, q1, q2, q3)``, Hamilton convention, for a plug-in's table.

Accepts a TOML array (list) or a tuple of four finite numbers whose norm is within
:data:`QUAT_NORM_TOL` (0.05) of 1: the rule of coopsat's own ``q_bi``, so that a quaternion
copied from a paper, printed to two decimals, is accepted in either place. The table holds the
numbers as written (a tuple); the builder normalises them (``q / np.linalg.norm(q)``). Refused,
in one line: a length other than 4, a non-finite element, a zero quaternion, a norm further
from 1 (a typo: a lost or doubled digit)."""

UnitVector = Annotated[tuple[float, float, float], _fixed_length(3, "[x, y, z]"), _unit_norm(_UNIT_VECTOR)]
"""A unit 3-vector ``(x, y, z)`` (an axis, a direction) for a plug-in's table: three finite
numbers whose norm is within :data:`QUAT_NORM_TOL` of 1 (the rule of ``reaction-wheels``'
``spin_axes_b``), held as written; the builder normalises. Refused as :data:`Quaternion` is."""


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


FACET = Record(float, float, float, float, float, float, float)
"""One flat facet as a scenario row: [nx, ny, nz, area_m2, cx, cy, cz]."""


class Facets(Table):
    """The surface: flat facets given as ``[nx, ny, nz, area_m2, cx, cy, cz]``."""

    facets: list[FACET] = Field(
        min_length=1,
        description="Flat facets, one per row: [nx, ny, nz, area_m2, cx, cy, cz] — outward normal (body axes; "
        "normalised), area in m², centre of pressure relative to the centre of mass, m, body axes.",
    )

    @model_validator(mode="after")
    def _facets_physical(self):
        for k, (nx, ny, nz, area, *centre) in enumerate(self.facets):
            if not np.isfinite([nx, ny, nz, area, *centre]).all():
                raise ValueError(f"facets[{k}]: every number must be finite")
            if vector_norm([nx, ny, nz]) == 0.0:
                raise ValueError(f"facets[{k}]: the normal [nx, ny, nz] must not be zero")
            if not 0.0 < area <= 1e4:
                raise ValueError(f"facets[{k}]: area_m2 must be in (0, 1e4] m², got {area:g}")
            if vector_norm(centre) > 1e3:
                raise ValueError(f"facets[{k}]: centre of pressure more than 1 km from the centre of mass")
        return self


def check_facets(facets):
    """Facet rows checked as :class:`Facets` checks them, for a table whose surface is facets or
    something else (a cannonball area): a ValueError with :class:`Facets`' own message."""
    try:
        Facets(facets=facets)
    except ValidationError as exc:
        raise ValueError(exc.errors()[0]["msg"].removeprefix("Value error, ")) from None
