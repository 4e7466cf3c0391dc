"""Density models the drag force reads: parts with ``density_kg_m3(t, r_eci) -> (n,)``.

Each is a part (:func:`coopsat.core.parts.part`) held by :class:`coopsat.environment.orbit_forces.Drag`,
so its tables are traced data a campaign may disperse; ``r_eci`` is component-major (3, n), m,
``t`` the run's time, s.
"""

import jax.numpy as jnp

from coopsat.astro import atmosphere, harris_priester
from coopsat.astro.ephemeris import sun_position_eme2000_m
from coopsat.core.parts import part
from coopsat.environment.earth_torques import body_columns_m


@part()
class ExponentialAtmosphere:
    """Vallado's piecewise exponential atmosphere (Table 8-4, a solar-cycle mean), by height
    above the ellipsoid (:mod:`coopsat.astro.atmosphere`).

    Attributes
    ----------
    scale : scalar
        Factor on the table's density (1: the table), e.g. a dispersion of the solar activity.
    """

    scale: jnp.ndarray

    def density_kg_m3(self, t, r_eci_m):
        return self.scale * atmosphere.density_kg_m3(atmosphere.altitude_m(r_eci_m, 0))


@part()
class HarrisPriesterAtmosphere:
    """Harris–Priester: densities between a night and a day profile with the diurnal bulge
    (:mod:`coopsat.astro.harris_priester`), the Sun from the analytic ephemeris.

    Attributes
    ----------
    heights_km, rho_min_kg_m3, rho_max_kg_m3 : (H,)
        The table for the scenario's solar-flux level.
    n_exponent : scalar
        ``cos^n(ψ/2)``: 2 (low inclination) … 6 (polar).
    jd0_tt : scalar
        Julian date of t = 0.
    """

    heights_km: jnp.ndarray
    rho_min_kg_m3: jnp.ndarray
    rho_max_kg_m3: jnp.ndarray
    n_exponent: jnp.ndarray
    jd0_tt: jnp.ndarray

    def density_kg_m3(self, t, r_eci_m):
        r_sun = body_columns_m(sun_position_eme2000_m(self.jd0_tt + t / 86400.0))
        table = (self.heights_km, self.rho_min_kg_m3, self.rho_max_kg_m3)
        return harris_priester.density_kg_m3(r_eci_m, r_sun, table, self.n_exponent, 0)
