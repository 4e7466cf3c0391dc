"""A real low orbit (``[[disturbances]]``): the gravity field to degree and order 70, drag with
a choice of atmosphere, the Sun and the Moon, and solar radiation pressure with the Earth's
shadow (docs/leo.md).

Every kind here needs ``[orbit]`` about the Earth; the forces (drag, radiation pressure) also
need every spacecraft's ``mass_kg``. Their Sun, Moon and Earth rotation follow
``[orbit] epoch_utc``.
"""

from typing import Annotated, Literal

from pydantic import Field, model_validator

from coopsat.astro.constants import central_body_name
from coopsat.plugins import DesignCheck, DesignError, Plugin, register
from coopsat.plugins.disturbances import per_spacecraft
from coopsat.plugins.earth_environment import epoch
from coopsat.plugins.tables import FACET, Table, check_facets

Positive = Annotated[float, Field(gt=0, le=1e6)]


class GravityFieldTable(Table):
    """``kind = "gravity-field"``: EGM2008 spherical harmonics beyond the point mass, to a degree and order."""

    kind: Literal["gravity-field"]
    model: Literal["EGM2008"] = Field("EGM2008", description="Coefficients: EGM2008, fully normalised, tide-free, to degree 70.")
    degree: int = Field(ge=2, description="Highest degree, 2 … 70 (20: a day of a low orbit to metres).")
    order: int | None = Field(None, ge=0, description="Highest order, 0 … degree (default: the degree; 0: zonal terms only).")


class ThirdBodyTable(Table):
    """``kind = "third-body"``: point-mass attraction of the Sun and the Moon (analytic ephemeris)."""

    kind: Literal["third-body"]
    bodies: list[Literal["sun", "moon"]] = Field(["sun", "moon"], min_length=1, description="Bodies that attract: sun, moon.")

    @model_validator(mode="after")
    def _distinct(self):
        if len(set(self.bodies)) != len(self.bodies):
            raise ValueError(f"bodies: each body once, got {self.bodies}")
        return self


class DragTable(Table):
    """``kind = "drag"``: atmospheric drag on a cannonball (``area_m2``) or on flat facets."""

    kind: Literal["drag"]
    cd: Positive | list[Positive] = Field(2.2, description="Drag coefficient: one value, or one per spacecraft.")
    area_m2: Positive | list[Positive] | None = Field(
        None, description="Cannonball area facing the flow, m²: one value, or one per spacecraft."
    )
    facets: list[FACET] | None = Field(
        None, description="Instead of area_m2, flat facets [nx, ny, nz, area_m2, cx, cy, cz] (as aerodynamic-torque): "
        "the area facing the flow follows the attitude.",
    )
    density: str = Field("exponential", description="Density model: exponential or harris-priester.")
    f107: float | None = Field(None, description="harris-priester: the mean solar flux F10.7, sfu, that picks its table.")
    hp_exponent: float = Field(2.0, ge=2, le=6, description="harris-priester: the bulge exponent n, 2 (low inclination) … 6 (polar).")
    density_scale: float = Field(1.0, gt=0, le=100, description="exponential: factor on the table's density.")

    @model_validator(mode="after")
    def _one_surface(self):
        if (self.area_m2 is None) == (self.facets is None):
            raise ValueError("give area_m2 (a cannonball) or facets, one of them")
        if self.density not in DENSITY_MODELS:
            raise ValueError(f"density: unknown model '{self.density}' (known: {', '.join(DENSITY_MODELS)})")
        # A field of the other model away from its default (a resolved scenario writes every default back).
        only = {"f107": "harris-priester", "hp_exponent": "harris-priester", "density_scale": "exponential"}
        for field, model in only.items():
            if getattr(self, field) != type(self).model_fields[field].default and self.density != model:
                raise ValueError(f"{field} is only read with density = '{model}'")
        if self.facets is not None:
            check_facets(self.facets)
        return self


def _harris_priester(table, ctx):
    from coopsat.astro.harris_priester import harris_priester_table
    from coopsat.environment.atmospheres import HarrisPriesterAtmosphere
    from coopsat.sim.system import as_arrays

    if table.f107 is None:
        raise DesignError("disturbances: drag with density = 'harris-priester' needs f107 (the mean solar flux, sfu)")
    try:
        heights, rho_min, rho_max = harris_priester_table(table.f107)
    except ValueError as exc:
        raise DesignError(f"disturbances: drag: {exc}") from None
    return HarrisPriesterAtmosphere(*as_arrays((heights, rho_min, rho_max, table.hp_exponent, epoch(ctx).jd_tt)))


def _exponential(table, ctx):
    from coopsat.environment.atmospheres import ExponentialAtmosphere
    from coopsat.sim.system import as_arrays

    return ExponentialAtmosphere(*as_arrays((table.density_scale,)))


DENSITY_MODELS = {"exponential": _exponential, "harris-priester": _harris_priester}
"""Density models by ``density`` name: ``builder(table, ctx) -> atmosphere part``."""


def require_earth_translation(ctx, kind, force):
    """``[orbit]`` about the Earth, and every mass when ``force``; else a DesignError naming the kind."""
    orbit = ctx.scenario.orbit
    where = f"disturbances: {kind}"
    if orbit is None:
        raise DesignError(f"{where} needs an [orbit] table (it acts on the orbit about the Earth)")
    if central_body_name(orbit.mu_m3_s2) != "EARTH":
        raise DesignError(f"{where} models the Earth's environment; [orbit] mu_m3_s2 = {orbit.mu_m3_s2:.6g} is not the Earth's")
    if force:
        from coopsat.plugins.force_actuators import require_translation

        require_translation(ctx, "disturbances", kind)


def _build_gravity_field(table, ctx):
    from coopsat.astro.gravity_field import egm2008
    from coopsat.environment.orbit_forces import GravityField
    from coopsat.sim.system import as_arrays

    require_earth_translation(ctx, "gravity-field", force=False)
    if ctx.scenario.orbit.gravity != "two-body":
        raise DesignError(
            f"disturbances: gravity-field includes J2; set [orbit] gravity = 'two-body' (not '{ctx.scenario.orbit.gravity}') "
            "so that it is not counted twice"
        )
    try:
        field = egm2008(table.degree, table.order)
    except ValueError as exc:
        raise DesignError(f"disturbances: gravity-field: {exc}") from None
    return GravityField(*as_arrays((field.c, field.s, field.gm_m3_s2, field.radius_m, epoch(ctx).earth)))


def _build_third_body(table, ctx):
    from coopsat.astro.constants import MU_SUN_M3_S2
    from coopsat.astro.ephemeris import MU_MOON_M3_S2
    from coopsat.environment.orbit_forces import ThirdBodies
    from coopsat.sim.system import as_arrays

    require_earth_translation(ctx, "third-body", force=False)
    mu = {"sun": MU_SUN_M3_S2, "moon": MU_MOON_M3_S2}
    return ThirdBodies(*as_arrays(([mu[b] for b in table.bodies], epoch(ctx).jd_tt)), bodies=tuple(table.bodies))


def _build_drag(table, ctx):
    import numpy as np

    from coopsat.environment.orbit_forces import Drag
    from coopsat.plugins.earth_environment import facet_arrays
    from coopsat.sim.system import as_arrays

    require_earth_translation(ctx, "drag", force=True)
    cd = per_spacecraft(table.cd, ctx, "cd")
    if table.facets is not None:
        normals, areas, _ = facet_arrays(table)
        area = np.zeros(ctx.n)
    else:
        normals, areas = np.zeros((3, 0)), np.zeros(0)
        area = per_spacecraft(table.area_m2, ctx, "area_m2")
    atmosphere = DENSITY_MODELS[table.density](table, ctx)
    return Drag(atmosphere, *as_arrays((cd, area, normals, areas)))


EPHEMERIS_LIMITS_DEG = {"sun": 0.2, "moon": 0.2}
"""Largest direction differences from DE421 within the analytic series' accuracy, degrees:
the Sun's fixed perigee drifts 0.32° a century from J2000 (0.17° by 2050), the Moon's
truncated series errs by up to 0.09° (tests/unit/test_ephemeris.py)."""


def check_ephemeris(table, ctx):
    """The analytic Sun and Moon against JPL DE421 over the run (the ``ephemeris`` extra)."""
    from coopsat.astro.ephemeris import ephemeris_difference

    jd0 = epoch(ctx).jd_tt
    try:
        diff = ephemeris_difference(jd0, jd0 + ctx.scenario.sim.t_final_s / 86400.0, samples=9)
    except ValueError as exc:  # outside DE421's 1899–2053
        return DesignCheck("ephemeris", True, f"analytic Sun and Moon not checked against DE421: {exc}")
    if diff is None:
        return DesignCheck("ephemeris", True, "analytic Sun and Moon not checked (install coopsat[ephemeris] for JPL DE421)")
    ok = diff.sun_direction_deg <= EPHEMERIS_LIMITS_DEG["sun"] and diff.moon_direction_deg <= EPHEMERIS_LIMITS_DEG["moon"]
    note = (f"analytic ephemeris vs JPL DE421 over the run: Sun {diff.sun_direction_deg:.4f}° "
            f"({diff.sun_position_m / 1e3:.0f} km), Moon {diff.moon_direction_deg:.4f}° ({diff.moon_position_m / 1e3:.0f} km)")
    metrics = {"ephemeris_sun_deg": diff.sun_direction_deg, "ephemeris_moon_deg": diff.moon_direction_deg,
               "ephemeris_moon_m": diff.moon_position_m}
    return DesignCheck("ephemeris", ok, note + ("" if ok else " — beyond the series' accuracy"), metrics, diff)


ANALYSIS = "coopsat.analysis.papers.low_orbit"

register(Plugin("disturbance", "gravity-field", GravityFieldTable, _build_gravity_field, analysis=ANALYSIS))
register(Plugin("disturbance", "third-body", ThirdBodyTable, _build_third_body, (check_ephemeris,), analysis=ANALYSIS))
register(Plugin("disturbance", "drag", DragTable, _build_drag, analysis=ANALYSIS))
