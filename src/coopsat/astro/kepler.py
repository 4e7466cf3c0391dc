"""Classical orbital elements to inertial position and velocity.

Design-time code (NumPy): it sets initial states, it does not run in the closed loop.
"""

import numpy as np
from scipy.optimize import newton


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
