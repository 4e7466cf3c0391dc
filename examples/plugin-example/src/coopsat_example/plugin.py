"""The example's plug-ins: what coopsat imports through the entry point ``example``.

Importing this module registers two kinds (:func:`coopsat.plugins.register`):

* controller ``saturated-consensus`` — :class:`SaturatedConsensusTable`, built into
  :class:`coopsat_example.saturated_consensus.SaturatedConsensus`;
* actuator ``cold-gas-thrusters`` — :class:`ColdGasTable`, built into
  :class:`coopsat_example.cold_gas.ColdGasThrusters`.

At import time it uses only pydantic and :mod:`coopsat.plugins` (the registry is loading; the
scenario schema is composed from it afterwards). The builders import JAX and the parts.
"""

from typing import Literal

from pydantic import Field

from coopsat.plugins import DesignCheck, DesignError, Plugin, Table, register

ANALYSIS = "coopsat_example.analysis"
"""The module whose ``metrics(ds, built)`` a run of the law adds to metrics.json."""


class SaturatedConsensusTable(Table):
    """``[controller] kind = "saturated-consensus"``."""

    kind: Literal["saturated-consensus"]
    period_s: float = Field(gt=0, le=1e5, description="Control period (zero-order hold), s.")
    alpha: float = Field(gt=0, le=1e6, description="Attitude consensus gain α, N·m.")
    beta: float = Field(ge=0, le=1e6, description="Relative rate gain β, N·m·s/rad.")
    gamma: float = Field(0.0, ge=0, le=1e6, description="Absolute rate damping γ, N·m·s/rad (0: law (3) alone).")
    torque_max_nm: float = Field(gt=0, le=1e6, description="Bound of the command per body axis, N·m.")
    short_way: bool = Field(True, description="Error quaternions on the q0 >= 0 hemisphere.")


class ColdGasTable(Table):
    """``[actuators] kind = "cold-gas-thrusters"``."""

    kind: Literal["cold-gas-thrusters"]
    torque_max_nm: float = Field(gt=0, le=1e6, description="Torque of one open thruster couple per body axis, N·m.")
    impulse_bit_nms: float = Field(ge=0, le=1e6, description="Minimum impulse bit, N·m·s: smaller commanded impulses are not executed.")
    delay_periods: int = Field(0, ge=0, le=64, description="Valve opening delay, whole control periods.")
    command: str = Field("torque_b", description="Controller command executed (body torque, N·m).")


def build_law(table, ctx):
    from coopsat_example.saturated_consensus import SaturatedConsensus
    import jax.numpy as jnp

    if ctx.scenario.sim.attitude != "rigid-body":
        raise DesignError('controller: saturated-consensus acts on quaternions; it needs sim.attitude = "rigid-body"')
    return SaturatedConsensus(*(jnp.asarray(float(v)) for v in (table.alpha, table.beta, table.gamma, table.torque_max_nm)),
                              short_way=table.short_way)


def build_thrusters(table, ctx):
    from coopsat_example.cold_gas import ColdGasThrusters
    import jax.numpy as jnp

    return ColdGasThrusters(
        jnp.asarray(table.torque_max_nm), jnp.asarray(table.impulse_bit_nms), command=table.command,
        delay_periods=table.delay_periods,
    )


def _reaches_all(adjacency, root):
    """Whether every spacecraft hears ``root``, directly or through others (A[i, j]: i hears j)."""
    seen, frontier = {root}, [root]
    while frontier:
        j = frontier.pop()
        for i in range(len(adjacency)):
            if adjacency[i][j] > 0 and i not in seen:
                seen.add(i)
                frontier.append(i)
    return len(seen) == len(adjacency)


def check_law(table, ctx):
    """Synchronisation needs a spanning tree in every graph; the law's bound should not exceed
    the torque of the thrusters that execute it (else they clip it)."""
    out = []
    for place, adjacency in zip(ctx.graph_places, ctx.adjacencies):
        if ctx.n > 1 and not any(_reaches_all(adjacency, r) for r in range(ctx.n)):
            out.append(DesignCheck("spanning-tree", False, f"{place}: no spanning tree; the spacecraft cannot all synchronise"))
    limits = [a.torque_max_nm for a in ctx.scenario.actuator_list if getattr(a, "command", "torque_b") == "torque_b"
              and getattr(a, "torque_max_nm", None) is not None]
    if limits:
        ok = table.torque_max_nm <= min(limits)
        note = (f"the law's bound {table.torque_max_nm:g} N·m per axis is "
                + ("within" if ok else "ABOVE") + f" the thrusters' {min(limits):g} N·m"
                + ("" if ok else ": they clip it, and the bound no longer shapes the command"))
        out.append(DesignCheck("law-bound", ok, note, {"law_torque_max_nm": table.torque_max_nm}))
    return out


def check_thrusters(table, ctx):
    """A bit deliverable within one period, a controller to command the valves, and the dead
    band and delay the run will see."""
    if ctx.scenario.controller.kind == "none":
        raise DesignError("actuators: cold-gas-thrusters need a controller")
    full = table.torque_max_nm * ctx.period_s
    if table.impulse_bit_nms > full:
        raise DesignError(
            f"actuators.impulse_bit_nms ({table.impulse_bit_nms:g} N·m·s) is more than a valve open for the whole "
            f"control period delivers ({full:g} N·m·s = torque_max_nm × period)"
        )
    deadband = table.impulse_bit_nms / ctx.period_s
    delay = table.delay_periods * ctx.period_s
    return DesignCheck(
        "cold-gas", True,
        f"cold-gas commands below {deadband:.3g} N·m per axis are not executed (minimum impulse bit); "
        f"valves open {delay:g} s after the command",
        {"cold_gas_deadband_torque_nm": deadband, "cold_gas_min_on_time_s": table.impulse_bit_nms / table.torque_max_nm,
         "cold_gas_delay_s": delay},
    )


register(Plugin("controller", "saturated-consensus", SaturatedConsensusTable, build_law, (check_law,), ANALYSIS))
register(Plugin("actuator", "cold-gas-thrusters", ColdGasTable, build_thrusters, (check_thrusters,)))
