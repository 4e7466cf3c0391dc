"""Reaction wheels (SPEC §5): momentum exchange, wheel torque and speed limits.

The same wheel set on every spacecraft. Its initial per-wheel momenta come from each
spacecraft's ``h_wheels_b_nms`` by the pseudo-inverse of the spin-axis matrix (the smallest
momenta that make it up); see :mod:`coopsat.actuators.reaction_wheels`.
"""

import math
from typing import Annotated, Literal

import numpy as np
from pydantic import Field

from coopsat.plugins import DesignCheck, DesignError, Plugin, register
from coopsat.plugins.tables import QUAT_NORM_TOL, Table, Vec3

Positive = Annotated[float, Field(gt=0, le=1e9)]
PerWheel = Positive | list[Positive]
"""One value for every wheel, or one per wheel (in the order of ``spin_axes_b``)."""

RPM = 2.0 * math.pi / 60.0
"""rad/s per rpm."""


class ReactionWheels(Table):
    """``kind = "reaction-wheels"``: wheels that exchange momentum with the body."""

    kind: Literal["reaction-wheels"]
    spin_axes_b: list[Vec3] | None = Field(
        None, min_length=3,
        description="Unit spin axis of each wheel, body frame (default the three body axes and (1, 1, 1)/√3).",
    )
    inertia_kgm2: PerWheel = Field(description="Each wheel's inertia about its spin axis, kg·m².")
    max_speed_rpm: PerWheel = Field(description="Each wheel's speed limit relative to the body, rpm.")
    torque_max_nm: PerWheel = Field(description="Each wheel's motor torque limit, N·m.")
    speed_error_rpm_3sigma: Annotated[float, Field(ge=0, le=1e5)] = Field(
        0.0, description="Speed-control error of every wheel, 3σ, rpm (0: none); a Gauss–Markov process."
    )
    speed_error_time_s: Annotated[float, Field(gt=0, le=1e6)] = Field(
        1.0, description="Correlation time of the speed-control error, s."
    )
    command: str = Field("torque_b", description="Controller command executed (the body torque wanted, N·m).")


def spin_axes(table):
    """``G`` (3, m) from the table: unit columns, rank 3.

    Raises
    ------
    DesignError
        An axis that is not a unit vector (within the quaternion tolerance; rounded ones are
        normalised), or axes that do not span the three body axes.
    """
    from coopsat.actuators.wheels import THREE_AXIS_PLUS_SKEW_B

    if table.spin_axes_b is None:
        return np.array(THREE_AXIS_PLUS_SKEW_B, dtype=float)
    g = np.asarray(table.spin_axes_b, dtype=float).T
    norms = np.linalg.norm(g, axis=0)
    for k, norm in enumerate(norms):
        if abs(norm - 1.0) > QUAT_NORM_TOL:
            raise DesignError(
                f"actuators.spin_axes_b[{k}]: norm is {norm:.4g}; a spin axis is a unit vector (within {QUAT_NORM_TOL:g} "
                "of 1, rounded values are normalised)"
            )
    g = g / norms
    rank = np.linalg.matrix_rank(g)
    if rank < 3:
        raise DesignError(
            f"actuators.spin_axes_b: the spin axes span {rank} dimension(s), so the wheels cannot produce torque about "
            "every axis (need rank 3)"
        )
    return g


def per_wheel(value, m, name):
    """A per-wheel field as a column (m, 1)."""
    v = np.asarray(value, dtype=float)
    if v.ndim == 0:
        return np.full((m, 1), float(v))
    if v.shape != (m,):
        raise DesignError(f"actuators.{name}: {v.size} values for {m} wheels (give one number, or one per wheel)")
    return v[:, None]


def momentum_capacity_nms(table):
    """Largest momentum the wheel set can store along each body axis, (3,) N·m·s.

    Along a unit axis e the wheels give ``Σ_k h_k g_k·e`` with ``|h_k| ≤ h_max,k``: the
    constraints are separate boxes, so the largest is ``Σ_k h_max,k |g_k·e|``.
    """
    g = spin_axes(table)
    m = g.shape[1]
    h_max = per_wheel(table.inertia_kgm2, m, "inertia_kgm2") * per_wheel(table.max_speed_rpm, m, "max_speed_rpm") * RPM
    return np.abs(g) @ h_max[:, 0]


def _arrays(table, ctx):
    g = spin_axes(table)
    m = g.shape[1]
    inertia = per_wheel(table.inertia_kgm2, m, "inertia_kgm2")
    h_max = inertia * per_wheel(table.max_speed_rpm, m, "max_speed_rpm") * RPM
    g_pinv = np.linalg.pinv(g)
    h_b0 = np.array([sc.h_wheels_b_nms for sc in ctx.scenario.spacecraft], dtype=float)  # (n, 3)
    return g, g_pinv, inertia, per_wheel(table.torque_max_nm, m, "torque_max_nm"), h_max, g_pinv @ h_b0.T


def _build(table, ctx):
    from coopsat.actuators.reaction_wheels import ReactionWheels as Part
    from coopsat.sim.system import as_arrays

    g = _arrays(table, ctx)
    sigma = np.full((g[0].shape[1], 1), table.speed_error_rpm_3sigma / 3.0 * RPM)
    phi = math.exp(-ctx.period_s / table.speed_error_time_s)
    return Part(*as_arrays((*g, sigma, phi)), command=table.command, speed_noise=table.speed_error_rpm_3sigma > 0.0)


def check_initial_speed(table, ctx):
    """Every wheel starts within its speed limit (its momentum from ``h_wheels_b_nms``)."""
    _, _, inertia, _, h_max, h0 = _arrays(table, ctx)
    over = np.abs(h0) > h_max * (1 + 1e-12)
    if not over.any():
        return None
    k, i = np.argwhere(over)[0]
    return DesignCheck(
        "wheel-speed", False,
        f"{ctx.names[i]}: h_wheels_b_nms puts wheel {k + 1} at {abs(h0[k, i] / inertia[k, 0]) / RPM:.4g} rpm, beyond its "
        f"max_speed_rpm ({h_max[k, 0] / inertia[k, 0] / RPM:.4g}); it can only slow down",
    )


register(Plugin("actuator", "reaction-wheels", ReactionWheels, _build, (check_initial_speed,)))
