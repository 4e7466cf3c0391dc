"""Torque actuators: the ideal (saturated) torque and the PWM thruster pairs of the 2010 paper."""

from typing import Literal

from pydantic import Field

from coopsat.plugins import DesignCheck, DesignError, Plugin, register
from coopsat.plugins.tables import MAX_TORQUE_NM, Table


class IdealTorque(Table):
    """``kind = "ideal-torque"``: the commanded torque, saturated per axis."""

    kind: Literal["ideal-torque"]
    torque_max_nm: float = Field(float("inf"), gt=0, le=MAX_TORQUE_NM, description="Saturation per body axis, N·m (default none).")


class PwmThrusters(Table):
    """``kind = "pwm-thrusters"``: a ± thruster pair per body axis, eq. (10) of the 2010 paper."""

    kind: Literal["pwm-thrusters"]
    torque_max_nm: float = Field(gt=0, le=MAX_TORQUE_NM, description="Torque of one thruster pair T_max, N·m.")
    min_pulse_s: float = Field(ge=0, le=1e5, description="Minimum pulse width τ, s (< control period).")


def _build_ideal(table, ctx):
    from coopsat.actuators.ideal import IdealTorque as Part
    from coopsat.sim.system import as_arrays

    return Part(*as_arrays((table.torque_max_nm,)))


def _build_pwm(table, ctx):
    from coopsat.actuators.pwm import PwmThrusters as Part
    from coopsat.sim.system import as_arrays

    return Part(*as_arrays((table.torque_max_nm, table.min_pulse_s)))


def check_pwm(table, ctx):
    """A minimum pulse shorter than the period, a controller to command the thrusters, and the
    dead band ``T_max·τ/T`` below which a command is not executed."""
    if ctx.scenario.controller.kind == "none":
        raise DesignError("actuators: pwm-thrusters need a controller")
    if not table.min_pulse_s < ctx.period_s:
        raise DesignError(
            f"actuators.min_pulse_s ({table.min_pulse_s:g} s) must be shorter than the control period ({ctx.period_s:g} s)"
        )
    deadband = table.torque_max_nm * table.min_pulse_s / ctx.period_s
    return DesignCheck(
        "pwm-deadband", True, f"PWM commands below {deadband:.3g} N·m are not executed (minimum pulse)",
        {"pwm_deadband_torque_nm": deadband},
    )


register(Plugin("actuator", "ideal-torque", IdealTorque, _build_ideal))
register(Plugin("actuator", "pwm-thrusters", PwmThrusters, _build_pwm, (check_pwm,)))
