"""Disturbance plug-ins (``[[disturbances]]``): environment torques and forces.

Gravity gradient (a point-mass field on an extended body), a seeded random torque, and solar
radiation pressure on a cannonball (SPEC §4). The aerodynamic, solar-pressure and
residual-dipole torques of an Earth orbit (SPEC §5) are in
:mod:`coopsat.plugins.earth_environment`.
"""

from typing import Annotated, Literal

from pydantic import Field

from coopsat.astro.constants import SOLAR_PRESSURE_1AU_N_M2
from coopsat.plugins import DesignError, Plugin, register
from coopsat.plugins.tables import MAX_TORQUE_NM, Bounded3, Table


class GravityGradientTable(Table):
    """``kind = "gravity-gradient"``: ``L = 3μ/r³ r̂_B × (I r̂_B)`` from the central body of ``[orbit]``."""

    kind: Literal["gravity-gradient"]


class RandomTorqueTable(Table):
    """``kind = "random-torque"``: zero-mean normal torque, drawn anew every control period."""

    kind: Literal["random-torque"]
    sigma_nm: Annotated[float, Field(ge=0, le=MAX_TORQUE_NM)] | Bounded3(MAX_TORQUE_NM, "N·m") = Field(description="Standard deviation per body axis, N·m (one value or [x, y, z]).")


Fraction = Annotated[float, Field(ge=0, le=1)]


class SolarRadiationPressureTable(Table):
    """``kind = "solar-radiation-pressure"``: cannonball SRP, ``F = P₁ (AU/r)² A (1 + reflectivity) r̂``,
    about the Sun (the central body of ``[orbit]``) or about the Earth (the Sun from the analytic
    ephemeris, dimmed by the Earth's shadow)."""

    kind: Literal["solar-radiation-pressure"]
    area_m2: Annotated[float, Field(gt=0, le=1e6)] | list[Annotated[float, Field(gt=0, le=1e6)]] = Field(
        description="Effective Sun-facing area, m²: one value, or one per spacecraft in [[spacecraft]] order."
    )
    reflectivity: Fraction | list[Fraction] = Field(
        description="Specular reflectivity, 0 (absorber) … 1 (mirror): one value, or one per spacecraft."
    )
    pressure_1au_n_m2: float = Field(
        SOLAR_PRESSURE_1AU_N_M2, gt=0, le=1.0, description="Pressure on an absorber at 1 AU, N/m² (default 4.54e-6)."
    )
    shadow: Literal["conical", "cylindrical"] = Field(
        "conical", description="About the Earth: its shadow, with penumbra (conical) or the cylinder (no penumbra)."
    )


def per_spacecraft(value, ctx, field):
    import numpy as np

    v = np.asarray(value, dtype=float)
    if v.ndim == 1 and v.shape[0] != ctx.n:
        raise DesignError(f"disturbances.{field}: {v.shape[0]} values given for {ctx.n} spacecraft (give one, or one each)")
    return np.broadcast_to(v, (ctx.n,)).copy()


def _build_srp(table, ctx):
    from coopsat.astro.constants import AU_M, central_body_name
    from coopsat.environment.forces import SolarRadiationPressure
    from coopsat.plugins.force_actuators import require_translation
    from coopsat.sim.system import as_arrays

    require_translation(ctx, "disturbances", "solar-radiation-pressure")
    area = per_spacecraft(table.area_m2, ctx, "area_m2")
    refl = per_spacecraft(table.reflectivity, ctx, "reflectivity")
    if central_body_name(ctx.scenario.orbit.mu_m3_s2) == "EARTH":
        from coopsat.environment.orbit_forces import EarthSolarRadiationPressure
        from coopsat.plugins.earth_environment import epoch

        arrays = (area, refl, table.pressure_1au_n_m2, AU_M, epoch(ctx).jd_tt)
        return EarthSolarRadiationPressure(*as_arrays(arrays), shadow=table.shadow)
    # About any other body, that body is the light source: the Sun of heliocentric runs (SPEC §4).
    return SolarRadiationPressure(*as_arrays((area, refl, table.pressure_1au_n_m2, AU_M)))


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
register(Plugin("disturbance", "solar-radiation-pressure", SolarRadiationPressureTable, _build_srp))
