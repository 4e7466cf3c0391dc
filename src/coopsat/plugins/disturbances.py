"""Disturbance plug-ins (``[[disturbances]]``): environment torques and forces.

Gravity gradient (a point-mass field on an extended body), a seeded random torque, and solar
radiation pressure on a cannonball (SPEC §4) or, about the Earth, on flat facets. The
aerodynamic, solar-pressure and residual-dipole torques of an Earth orbit (SPEC §5) are in
:mod:`coopsat.plugins.earth_environment`.
"""

from typing import Annotated, Literal

from pydantic import Field, model_validator

from coopsat.astro.constants import SOLAR_PRESSURE_1AU_N_M2
from coopsat.plugins import DesignError, Plugin, register
from coopsat.plugins.tables import FACET, MAX_TORQUE_NM, Bounded3, Table, check_facets


class GravityGradientTable(Table):
    """``kind = "gravity-gradient"``: ``L = 3μ/r³ r̂_B × (I r̂_B)`` from the central body of ``[orbit]``."""

    kind: Literal["gravity-gradient"]


class RandomTorqueTable(Table):
    """``kind = "random-torque"``: zero-mean normal torque, drawn anew every control period."""

    kind: Literal["random-torque"]
    sigma_nm: Annotated[float, Field(ge=0, le=MAX_TORQUE_NM)] | Bounded3(MAX_TORQUE_NM, "N·m") = Field(description="Standard deviation per body axis, N·m (one value or [x, y, z]).")


Fraction = Annotated[float, Field(ge=0, le=1)]


class SolarRadiationPressureTable(Table):
    """``kind = "solar-radiation-pressure"``: SRP on a cannonball, ``F = P₁ (AU/r)² A (1 + reflectivity) r̂``,
    about the Sun (the central body of ``[orbit]``) or about the Earth (the Sun from the analytic
    ephemeris, dimmed by the Earth's shadow); about the Earth also on flat facets, whose force
    follows the attitude."""

    kind: Literal["solar-radiation-pressure"]
    area_m2: Annotated[float, Field(gt=0, le=1e6)] | list[Annotated[float, Field(gt=0, le=1e6)]] | None = Field(
        None, description="Effective Sun-facing area of a cannonball, m²: one value, or one per spacecraft in [[spacecraft]] order."
    )
    reflectivity: Fraction | list[Fraction] | None = Field(
        None, description="With area_m2: specular reflectivity, 0 (absorber) … 1 (mirror): one value, or one per spacecraft."
    )
    facets: list[FACET] | None = Field(
        None, description="Instead of area_m2, about the Earth: flat facets [nx, ny, nz, area_m2, cx, cy, cz] (as "
        "solar-pressure-torque), the same on every spacecraft: the force follows the attitude.",
    )
    specular: Fraction | list[Fraction] = Field(
        0.1, description="With facets: fraction of light reflected specularly, one value or one per facet."
    )
    diffuse: Fraction | list[Fraction] = Field(0.2, description="With facets: fraction reflected diffusely, one value or one per facet.")
    pressure_1au_n_m2: float = Field(
        SOLAR_PRESSURE_1AU_N_M2, gt=0, le=1.0, description="Pressure on an absorber at 1 AU, N/m² (default 4.54e-6)."
    )
    shadow: Literal["conical", "cylindrical"] = Field(
        "conical", description="About the Earth: its shadow, with penumbra (conical) or the cylinder (no penumbra)."
    )

    @model_validator(mode="after")
    def _one_surface(self):
        if (self.area_m2 is None) == (self.facets is None):
            raise ValueError("give area_m2 (a cannonball) or facets, one of them")
        if self.facets is None:
            if self.reflectivity is None:
                raise ValueError("reflectivity: give the cannonball's reflectivity with area_m2")
            # A resolved scenario writes every default back: only a value away from it is the user's.
            for field in ("specular", "diffuse"):
                if getattr(self, field) != type(self).model_fields[field].default:
                    raise ValueError(f"{field} is only read with facets (the cannonball takes reflectivity)")
        else:
            if self.reflectivity is not None:
                raise ValueError("reflectivity is only read with area_m2 (facets take specular and diffuse)")
            check_facets(self.facets)
        return self


def per_spacecraft(value, ctx, field):
    import numpy as np

    v = np.asarray(value, dtype=float)
    if v.ndim == 1 and v.shape[0] != ctx.n:
        raise DesignError(f"disturbances.{field}: {v.shape[0]} values given for {ctx.n} spacecraft (give one, or one each)")
    return np.broadcast_to(v, (ctx.n,)).copy()


def _build_srp(table, ctx):
    import numpy as np

    from coopsat.astro.constants import AU_M, central_body_name
    from coopsat.environment.forces import SolarRadiationPressure
    from coopsat.plugins.force_actuators import require_translation
    from coopsat.sim.system import as_arrays

    require_translation(ctx, "disturbances", "solar-radiation-pressure")
    if central_body_name(ctx.scenario.orbit.mu_m3_s2) == "EARTH":
        from coopsat.environment.orbit_forces import EarthSolarRadiationPressure
        from coopsat.plugins.earth_environment import epoch, facet_arrays, facet_optics

        if table.facets is None:
            area = per_spacecraft(table.area_m2, ctx, "area_m2")
            refl = per_spacecraft(table.reflectivity, ctx, "reflectivity")
            normals, areas, specular, diffuse = np.zeros((3, 0)), np.zeros(0), np.zeros(0), np.zeros(0)
        else:
            normals, areas, _ = facet_arrays(table)
            specular, diffuse = facet_optics(table, "solar-radiation-pressure")
            area = refl = np.zeros(ctx.n)
        arrays = (area, refl, normals, areas, specular, diffuse, table.pressure_1au_n_m2, AU_M, epoch(ctx).jd_tt)
        return EarthSolarRadiationPressure(*as_arrays(arrays), shadow=table.shadow)
    if table.facets is not None:
        raise DesignError(
            "disturbances.facets: solar-radiation-pressure on flat facets is modelled about the Earth only; "
            "about the Sun give area_m2 and reflectivity (a cannonball)"
        )
    # About any other body, that body is the light source: the Sun of heliocentric runs (SPEC §4).
    area = per_spacecraft(table.area_m2, ctx, "area_m2")
    refl = per_spacecraft(table.reflectivity, ctx, "reflectivity")
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
