"""Force actuators: impulse-bit MEMS thrusters (SPEC §2) and proportional thrusters (SPEC §4).

A force actuator needs an ``[orbit]`` table and every spacecraft's ``mass_kg`` (checked by
:mod:`coopsat.scenarios.build` for every ``force*`` channel).
"""

import math
from typing import Literal

from pydantic import Field, model_validator

from coopsat.plugins import DesignCheck, DesignError, Plugin, register
from coopsat.plugins.tables import MAX_FORCE_N, Table

_CHANNEL_COMMAND = {"lvlh": "force_lvlh", "body": "force_b", "inertial": "force_eci"}


class ImpulseBitThrusters(Table):
    """``kind = "impulse-bit-thrusters"``: whole impulse bits per axis, the rounding remainder carried or dropped."""

    kind: Literal["impulse-bit-thrusters"]
    bit_ns: float = Field(1e-5, gt=0, le=1e6, description="Impulse of one bit, N·s.")
    thrust_n: float = Field(gt=0, le=MAX_FORCE_N, description="Force of one firing thruster, N (a bit lasts bit_ns/thrust_n).")
    max_bits_per_period: int | None = Field(
        None, ge=1, description="Most bits per axis and period (default: as many as fit, ⌊T·thrust/bit⌋)."
    )
    frame: Literal["lvlh", "body", "inertial"] = Field(
        "lvlh", description="Thruster axes: the chief's LVLH frame, the body, or inertial (held fixed in space)."
    )
    command: str | None = Field(None, description="Controller command executed (default force_lvlh / force_b / force_eci by frame).")
    remainder: Literal["carry", "drop"] = Field(
        "carry", description="The rounding remainder: carried to the next period (sigma-delta), or dropped (a command "
        "below half a bit per period never fires)."
    )


class ProportionalThrusters(Table):
    """``kind = "proportional-thrusters"``: the commanded force per axis, with a dead zone."""

    kind: Literal["proportional-thrusters"]
    force_min_n: float = Field(1e-3, ge=0, le=MAX_FORCE_N, description="Smallest force per axis, N: smaller commands give none.")
    force_max_n: float = Field(0.1, gt=0, le=MAX_FORCE_N, description="Largest force per axis, N: larger commands are clipped.")
    frame: Literal["lvlh", "body", "inertial"] = Field(
        "lvlh", description="Thruster axes: the chief's LVLH frame, the body, or inertial (held fixed in space)."
    )
    command: str | None = Field(None, description="Controller command executed (default force_lvlh / force_b / force_eci by frame).")

    @model_validator(mode="after")
    def _band(self):
        if self.force_min_n > self.force_max_n:
            raise ValueError(f"force_min_n ({self.force_min_n:g} N) must not exceed force_max_n ({self.force_max_n:g} N)")
        return self


def _command(table):
    return table.command if table.command is not None else _CHANNEL_COMMAND[table.frame]


def max_bits(table, period_s):
    """Bits per axis and period: the table's, or as many as fit in the period.

    Raises
    ------
    DesignError
        When the bits do not fit in the control period (naming the field).
    """
    bit_s = table.bit_ns / table.thrust_n
    if table.max_bits_per_period is None:
        fit = math.floor(period_s / bit_s * (1 + 1e-12))
        if fit < 1:
            raise DesignError(
                f"actuators.thrust_n: one bit takes bit_ns/thrust_n = {bit_s:g} s, longer than the control period "
                f"({period_s:g} s)"
            )
        return fit
    if table.max_bits_per_period * bit_s > period_s * (1 + 1e-12):
        raise DesignError(
            f"actuators.max_bits_per_period: {table.max_bits_per_period} bits of {bit_s:g} s (bit_ns/thrust_n) take "
            f"{table.max_bits_per_period * bit_s:g} s, longer than the control period ({period_s:g} s)"
        )
    return table.max_bits_per_period


def require_translation(ctx, place="actuators", who="a force actuator"):
    """A force needs the translational truth model and every spacecraft's mass.

    Raises
    ------
    DesignError
        Naming ``place`` and ``who`` (the part that needs them).
    """
    if ctx.scenario.orbit is None:
        raise DesignError(f"{place}: {who} needs an [orbit] table (the translational truth model)")
    missing = [sc.name for sc in ctx.scenario.spacecraft if sc.mass_kg is None]
    if missing:
        raise DesignError(f"spacecraft: {who} ({place}) is a force, so every spacecraft needs mass_kg; missing for {missing}")


def check_translation(table, ctx):
    """The force actuators' check: :func:`require_translation`."""
    require_translation(ctx)


def _build_bits(table, ctx):
    from coopsat.actuators.force_thrusters import ImpulseBitThrusters as Part
    from coopsat.sim.system import as_arrays

    bits = float(max_bits(table, ctx.period_s))
    return Part(
        *as_arrays((table.bit_ns, table.thrust_n, bits)), frame=table.frame, command=_command(table), carry=table.remainder == "carry"
    )


def _build_proportional(table, ctx):
    from coopsat.actuators.force_thrusters import ProportionalThrusters as Part
    from coopsat.sim.system import as_arrays

    return Part(*as_arrays((table.force_min_n, table.force_max_n)), frame=table.frame, command=_command(table))


def check_bits(table, ctx):
    """The force resolution (one bit per period) and the largest mean force per axis."""
    bits = max_bits(table, ctx.period_s)
    f_min, f_max = table.bit_ns / ctx.period_s, bits * table.bit_ns / ctx.period_s
    return DesignCheck(
        "impulse-bits", True,
        f"impulse bits of {table.bit_ns:g} N·s: mean force per axis in steps of {f_min:.3g} N up to {f_max:.3g} N "
        f"({bits} bits per {ctx.period_s:g} s period)",
        {"impulse_bit_force_resolution_n": f_min, "impulse_bit_max_force_n": f_max},
    )


def check_proportional(table, ctx):
    """The dead band: commands below ``force_min_n`` per axis are not executed."""
    return DesignCheck(
        "thruster-deadband", True,
        f"thruster commands below {table.force_min_n:.3g} N per axis are not executed; above {table.force_max_n:.3g} N "
        "they are clipped",
        {"thruster_deadband_force_n": table.force_min_n, "thruster_max_force_n": table.force_max_n},
    )


register(Plugin("actuator", "impulse-bit-thrusters", ImpulseBitThrusters, _build_bits, (check_translation, check_bits)))
register(
    Plugin("actuator", "proportional-thrusters", ProportionalThrusters, _build_proportional, (check_translation, check_proportional))
)
