"""Physical constants, SI units.

Earth values are those of EGM2008 / WGS-84 as used by Basilisk and Vallado (4th ed.),
so that orbits agree with those tools to the digits that matter.
"""

MU_EARTH_M3_S2 = 3.986004418e14
"""Earth's gravitational parameter, m³/s² (WGS-84 / EGM2008)."""

R_EARTH_M = 6378137.0
"""Earth's equatorial radius, m (WGS-84 semi-major axis)."""

J2_EARTH = 1.08262668e-3
"""Earth's second zonal harmonic, dimensionless (EGM2008, unnormalised)."""

MU_SUN_M3_S2 = 1.32712440e20
"""Sun's gravitational parameter, m³/s² (SPEC §4)."""

AU_M = 149597870700.0
"""Astronomical unit, m (IAU 2012 Resolution B2, exact)."""

SOLAR_PRESSURE_1AU_N_M2 = 3.828e26 / (4.0 * 3.141592653589793 * AU_M**2 * 299792458.0)
"""Solar radiation pressure on a perfect absorber at 1 AU, N/m² (about 4.54e-6): the nominal
solar luminosity 3.828e26 W (IAU 2015 Resolution B3) spread over the 1 AU sphere, over c."""

CENTRAL_BODIES = {"EARTH": MU_EARTH_M3_S2, "SUN": MU_SUN_M3_S2}
"""The central bodies a run may orbit, by CCSDS ``CENTER_NAME``: their gravitational parameter, m³/s²."""

MU_MATCH_RTOL = 0.01
"""An ``[orbit] mu_m3_s2`` names a body when within this fraction of the body's μ (the
Earth-environment models accept the Earth within the same 1 %)."""


def central_body_name(mu_m3_s2):
    """CCSDS ``CENTER_NAME`` (``EARTH``, ``SUN``) of the body whose μ is ``mu_m3_s2``, m³/s², or None."""
    for name, mu in CENTRAL_BODIES.items():
        if abs(mu_m3_s2 / mu - 1.0) <= MU_MATCH_RTOL:
            return name
    return None
