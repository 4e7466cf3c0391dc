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
