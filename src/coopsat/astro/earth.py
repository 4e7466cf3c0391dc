"""The rotating Earth: time scales, sidereal time, the WGS-84 ellipsoid (SPEC §0, §5).

ECEF turns about the ECI z axis by the Greenwich sidereal angle ``θ(t) = θ0 + ω_E t`` (SPEC §0:
no precession, nutation or polar motion; UT1 is taken equal to UTC, an error below 0.9 s of
Earth rotation, 0.4 km at the equator).
"""

from datetime import datetime, timezone

import numpy as np

OMEGA_EARTH_RAD_S = 7.292115146706979e-5
"""Earth's sidereal rotation rate, rad/s (IERS conventional value 7.2921150e-5 is the mean;
this is 2π/86164.0905 s, the rate of the IAU-82 GMST below)."""

WGS84_A_M = 6378137.0
"""WGS-84 semi-major axis (equatorial radius), m."""

WGS84_F = 1.0 / 298.257223563
"""WGS-84 flattening."""

WGS84_B_M = WGS84_A_M * (1.0 - WGS84_F)
"""WGS-84 semi-minor axis (polar radius), m."""

JD_J2000 = 2451545.0
"""Julian date of J2000.0 (2000-01-01 12:00:00 TT; used here on the UT1 scale as IAU-82 does)."""


def julian_date_utc(iso_utc):
    """Julian date of an ISO-8601 UTC instant (``"2018-06-21T04:00:00"``; a zone suffix other
    than UTC is converted).

    Parameters
    ----------
    iso_utc : str

    Returns
    -------
    float
        Julian date, days (UTC; used as UT1, see the module notes).

    Raises
    ------
    ValueError
        A string that is not an ISO-8601 date-time.
    """
    when = datetime.fromisoformat(iso_utc)
    when = when.replace(tzinfo=timezone.utc) if when.tzinfo is None else when.astimezone(timezone.utc)
    return 2440587.5 + when.timestamp() / 86400.0


def gmst_rad(jd_ut1):
    """Greenwich mean sidereal time, rad in [0, 2π), IAU-82.

    Parameters
    ----------
    jd_ut1 : float
        Julian date on the UT1 scale.

    Notes
    -----
    Vallado, *Fundamentals of Astrodynamics and Applications*, 4th ed., eq. 3-47:
    ``θ = 67310.54841 s + (876600 h + 8640184.812866 s) T + 0.093104 s T² − 6.2e-6 s T³``,
    ``T`` Julian centuries of UT1 from J2000.
    """
    t = (jd_ut1 - JD_J2000) / 36525.0
    seconds = 67310.54841 + (876600.0 * 3600.0 + 8640184.812866) * t + 0.093104 * t**2 - 6.2e-6 * t**3
    return float(np.mod(seconds / 240.0 * np.pi / 180.0, 2.0 * np.pi))
