"""Disturbance plug-ins (``[[disturbances]]``): environment torques and forces.

Gravity gradient (a point-mass field on an extended body) and a seeded random torque; the
papers' aerodynamic, solar-pressure and residual-dipole terms (SPEC §4, §5) plug in beside
them.
"""

from typing import Annotated, Literal

from pydantic import Field

from coopsat.plugins import DesignError, Plugin, register
from coopsat.plugins.tables import MAX_TORQUE_NM, Bounded3, Table


class GravityGradientTable(Table):
    """``kind = "gravity-gradient"``: ``L = 3μ/r³ r̂_B × (I r̂_B)`` from the central body of ``[orbit]``."""

    kind: Literal["gravity-gradient"]


class RandomTorqueTable(Table):
    """``kind = "random-torque"``: zero-mean normal torque, drawn anew every control period."""

    kind: Literal["random-torque"]
    sigma_nm: Annotated[float, Field(ge=0, le=MAX_TORQUE_NM)] | Bounded3(MAX_TORQUE_NM, "N·m") = Field(description="Standard deviation per body axis, N·m (one value or [x, y, z]).")


def _build_gravity_gradient(table, ctx):
    import numpy as np

    from coopsat.environment.torques import GravityGradient
    from coopsat.sim.system import as_arrays

    orbit = ctx.scenario.orbit
    if orbit is None:
        raise DesignError("disturbances: gravity-gradient needs an [orbit] table (the torque depends on the position)")
    if ctx.scenario.sim.attitude != "rigid-body":
        raise DesignError('disturbances: gravity-gradient needs sim.attitude = "rigid-body" (it depends on the attitude)')
    inertia = ctx.inertia_kgm2
    diagonal = all(np.count_nonzero(m - np.diag(np.diag(m))) == 0 for m in inertia)
    # Component-major, as the loop's arrays: (3, n) principal moments or (3, 3, n).
    inertia_cm = np.diagonal(inertia, axis1=1, axis2=2).T if diagonal else np.moveaxis(inertia, 0, -1)
    return GravityGradient(*as_arrays((inertia_cm, orbit.mu_m3_s2)))


def _build_random_torque(table, ctx):
    import numpy as np

    from coopsat.environment.torques import RandomTorque
    from coopsat.sim.system import as_arrays

    sigma = np.broadcast_to(np.asarray(table.sigma_nm, dtype=float), (3,)).reshape(3, 1)
    if np.any(sigma < 0):
        raise DesignError("disturbances: random-torque sigma_nm must be >= 0")
    return RandomTorque(*as_arrays((sigma,)))


register(Plugin("disturbance", "gravity-gradient", GravityGradientTable, _build_gravity_gradient))
register(Plugin("disturbance", "random-torque", RandomTorqueTable, _build_random_torque))
