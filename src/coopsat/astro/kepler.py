"""Classical orbital elements: to and from inertial position and velocity, J2 secular rates.

Design-time code (NumPy): it sets initial states and checks scenarios, it does not run in the
closed loop.
"""

from typing import NamedTuple

import numpy as np

CIRCULAR_E = 1e-11
"""Eccentricity below which :func:`rv_to_elements` treats an orbit as circular (the argument of
periapsis is then undefined and set to 0). Rounding alone leaves ``e`` of order 1e-15 to 1e-13
on a circular orbit's state."""

EQUATORIAL_I_RAD = 1e-11
"""Inclination (or ``π − i``) below which :func:`rv_to_elements` treats an orbit as equatorial
(the node is then undefined and the right ascension set to 0)."""


def solve_kepler(mean_anomaly_rad, eccentricity):
    """Eccentric anomaly E from Kepler's equation ``M = E − e sin E`` (elliptic, 0 ≤ e < 1).

    Parameters
    ----------
    mean_anomaly_rad : float
    eccentricity : float

    Returns
    -------
    float
        Eccentric anomaly, rad.
    """
    from scipy.optimize import newton  # scipy.optimize takes 0.4 s to import

    m = float(np.mod(mean_anomaly_rad, 2.0 * np.pi))
    return float(
        newton(
            lambda e_anom: e_anom - eccentricity * np.sin(e_anom) - m,
            x0=m if eccentricity < 0.8 else np.pi,
            fprime=lambda e_anom: 1.0 - eccentricity * np.cos(e_anom),
            # Absolute tolerance on E: 1e-15 is about one ulp at E ≥ 4, where Newton can then
            # cycle between neighbouring floats; 1e-13 rad is far below any physical need.
            tol=1e-13,
            maxiter=100,
        )
    )


def elements_to_rv(a_m, e, i_rad, raan_rad, argp_rad, mean_anomaly_rad, mu_m3_s2):
    """Position and velocity in the inertial frame from classical elements.

    Parameters
    ----------
    a_m : float
        Semi-major axis, m.
    e : float
        Eccentricity, 0 ≤ e < 1.
    i_rad, raan_rad, argp_rad, mean_anomaly_rad : float
        Inclination, right ascension of the ascending node, argument of periapsis, mean
        anomaly, rad.
    mu_m3_s2 : float
        Gravitational parameter of the central body, m³/s².

    Returns
    -------
    r_eci_m : ndarray, shape (3,)
    v_eci_m_s : ndarray, shape (3,)

    Notes
    -----
    Vallado, *Fundamentals of Astrodynamics and Applications*, 4th ed., Algorithm 10 (COE2RV):
    perifocal state rotated by R3(−Ω) R1(−i) R3(−ω).
    """
    e_anom = solve_kepler(mean_anomaly_rad, e)
    nu = 2.0 * np.arctan2(np.sqrt(1.0 + e) * np.sin(e_anom / 2.0), np.sqrt(1.0 - e) * np.cos(e_anom / 2.0))
    p = a_m * (1.0 - e * e)
    r_pf = p / (1.0 + e * np.cos(nu)) * np.array([np.cos(nu), np.sin(nu), 0.0])
    v_pf = np.sqrt(mu_m3_s2 / p) * np.array([-np.sin(nu), e + np.cos(nu), 0.0])
    co, so = np.cos(raan_rad), np.sin(raan_rad)
    ci, si = np.cos(i_rad), np.sin(i_rad)
    cw, sw = np.cos(argp_rad), np.sin(argp_rad)
    c_ip = np.array(
        [
            [co * cw - so * sw * ci, -co * sw - so * cw * ci, so * si],
            [so * cw + co * sw * ci, -so * sw + co * cw * ci, -co * si],
            [sw * si, cw * si, ci],
        ]
    )
    return c_ip @ r_pf, c_ip @ v_pf


class Elements(NamedTuple):
    """Classical elements of an elliptic orbit (SI units, angles in rad)."""

    a_m: float
    """Semi-major axis, m."""
    e: float
    """Eccentricity, 0 ≤ e < 1."""
    i_rad: float
    """Inclination, [0, π]."""
    raan_rad: float
    """Right ascension of the ascending node, [0, 2π)."""
    argp_rad: float
    """Argument of periapsis, [0, 2π)."""
    nu_rad: float
    """True anomaly, [0, 2π)."""
    mean_anomaly_rad: float
    """Mean anomaly, [0, 2π)."""


def _angle(y, x):
    """``atan2(y, x)`` wrapped to [0, 2π)."""
    return float(np.mod(np.arctan2(y, x), 2.0 * np.pi))


def rv_to_elements(r_eci_m, v_eci_m_s, mu_m3_s2):
    """Classical elements of an elliptic orbit from inertial position and velocity.

    Parameters
    ----------
    r_eci_m : array_like, shape (3,)
        Position, m, in a frame whose z axis is the body's pole (ECI).
    v_eci_m_s : array_like, shape (3,)
        Velocity, m/s.
    mu_m3_s2 : float
        Gravitational parameter of the central body, m³/s².

    Returns
    -------
    Elements
        ``(a_m, e, i_rad, raan_rad, argp_rad, nu_rad, mean_anomaly_rad)``. In the degenerate
        cases the undefined angles are set so that
        ``elements_to_rv(a, e, i, Ω, ω, M)`` gives the state back:

        * circular (``e <`` :data:`CIRCULAR_E`): ``ω = 0`` and ``ν = M`` is the argument of
          latitude ``u`` (angle from the ascending node to ``r``);
        * equatorial (``i`` or ``π − i`` below :data:`EQUATORIAL_I_RAD`): ``Ω = 0`` and ``ω`` is
          measured from the x axis in the direction of motion (the true longitude of periapsis
          for a prograde orbit, its negative for a retrograde one);
        * circular and equatorial: ``Ω = ω = 0`` and ``ν`` is the true longitude, measured in the
          direction of motion.

    Raises
    ------
    ValueError
        ``e ≥ 1`` (parabolic, hyperbolic or rectilinear): not an elliptic orbit.

    Notes
    -----
    Vallado, *Fundamentals of Astrodynamics and Applications*, 4th ed., Algorithm 9 (RV2COE),
    with the angles taken by ``atan2`` of the sine and cosine in the orbit plane (accurate at
    0 and π, where ``acos`` loses half its digits) rather than by ``acos`` and a quadrant test.
    ``M = E − e sin E`` with ``E = atan2(√(1 − e²) sin ν, e + cos ν)``.
    """
    r = np.asarray(r_eci_m, dtype=float)
    v = np.asarray(v_eci_m_s, dtype=float)
    r_norm = np.linalg.norm(r)
    h = np.cross(r, v)
    h_norm = np.linalg.norm(h)
    e_vec = ((v @ v - mu_m3_s2 / r_norm) * r - (r @ v) * v) / mu_m3_s2
    e = float(np.linalg.norm(e_vec))
    energy = 0.5 * (v @ v) - mu_m3_s2 / r_norm
    if e >= 1.0 or energy >= 0.0:
        raise ValueError(f"eccentricity {e:.6g} ≥ 1: not an elliptic orbit (specific energy {energy:.6g} J/kg)")
    a = -mu_m3_s2 / (2.0 * energy)
    h_hat = h / h_norm
    i = float(np.arctan2(np.hypot(h[0], h[1]), h[2]))
    if min(i, np.pi - i) < EQUATORIAL_I_RAD:
        raan, node_hat = 0.0, np.array([1.0, 0.0, 0.0])
    else:
        node = np.array([-h[1], h[0], 0.0])  # ẑ × h
        raan, node_hat = _angle(node[1], node[0]), node / np.linalg.norm(node)

    def in_plane_angle(from_hat, to_vec):
        """Angle from ``from_hat`` to ``to_vec`` about ``h``, [0, 2π)."""
        return _angle(h_hat @ np.cross(from_hat, to_vec), from_hat @ to_vec)

    if e < CIRCULAR_E:
        argp, nu = 0.0, in_plane_angle(node_hat, r)
    else:
        argp, nu = in_plane_angle(node_hat, e_vec), in_plane_angle(e_vec / e, r)
    e_anom = np.arctan2(np.sqrt(1.0 - e * e) * np.sin(nu), e + np.cos(nu))
    mean_anomaly = float(np.mod(e_anom - e * np.sin(e_anom), 2.0 * np.pi))
    return Elements(float(a), e, i, raan, argp, nu, mean_anomaly)


def j2_secular_rates(a_m, e, i_rad, mu_m3_s2, j2, r_body_m):
    """First-order secular rates of the node, periapsis and mean anomaly under J2.

    Parameters
    ----------
    a_m : float or ndarray
        Mean semi-major axis, m.
    e : float or ndarray
        Mean eccentricity, 0 ≤ e < 1.
    i_rad : float or ndarray
        Mean inclination, rad.
    mu_m3_s2, j2, r_body_m : float
        Gravitational parameter, J2 coefficient and equatorial radius of the central body.

    Returns
    -------
    raan_dot_rad_s : float or ndarray
        ``Ω̇ = −(3/2) n J2 (R/p)² cos i``.
    argp_dot_rad_s : float or ndarray
        ``ω̇ = (3/4) n J2 (R/p)² (4 − 5 sin² i)``.
    mean_anomaly_dot_rad_s : float or ndarray
        ``Ṁ = n + (3/4) n J2 (R/p)² √(1 − e²) (2 − 3 sin² i)``: the whole rate, mean motion
        ``n = √(μ/a³)`` included.

    Notes
    -----
    Vallado, 4th ed., eq. 9-41 (Kozai 1959, Brouwer 1959), with ``p = a (1 − e²)``. The rates
    are those of the mean elements; osculating elements differ from them by periodic terms of
    relative size J2 (R/a)² ≈ 1e-3 in low Earth orbit, which is also the relative error of
    putting an osculating ``a`` in here.
    """
    n = np.sqrt(mu_m3_s2 / a_m**3)
    k = n * j2 * (r_body_m / (a_m * (1.0 - e * e))) ** 2
    sin2_i = np.sin(i_rad) ** 2
    return (
        -1.5 * k * np.cos(i_rad),
        0.75 * k * (4.0 - 5.0 * sin2_i),
        n + 0.75 * k * np.sqrt(1.0 - e * e) * (2.0 - 3.0 * sin2_i),
    )


def check_orbit_clear_of_body(a_m, e, r_body_m):
    """Raise if an orbit's periapsis lies inside the central body.

    Parameters
    ----------
    a_m : float
        Semi-major axis, m.
    e : float
        Eccentricity.
    r_body_m : float
        Body radius, m (the equatorial radius for the Earth: a conservative test near the
        poles, where the surface is 21 km lower).

    Raises
    ------
    ValueError
        ``a (1 − e) < r_body_m``, as one line giving both radii.
    """
    perigee_m = a_m * (1.0 - e)
    if perigee_m < r_body_m:
        raise ValueError(
            f"orbit intersects the Earth: perigee radius {perigee_m:.1f} m below the body radius {r_body_m:.1f} m"
        )
