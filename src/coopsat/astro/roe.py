"""Quasi-nonsingular relative orbital elements (ROE) of a deputy about a chief.

The set, for a chief ``c`` and a deputy ``d`` with mean argument of latitude ``u = ω + M``::

    δa  = (a_d − a_c)/a_c                      relative semi-major axis
    δλ  = (u_d − u_c) + (Ω_d − Ω_c) cos i_c    relative mean longitude
    δex = e_d cos ω_d − e_c cos ω_c            relative eccentricity vector
    δey = e_d sin ω_d − e_c sin ω_c
    δix = i_d − i_c                            relative inclination vector
    δiy = (Ω_d − Ω_c) sin i_c

All six are dimensionless; multiplied by the chief's semi-major axis (``a δα``) they are
lengths, m, of the size of the relative orbit they describe: for a near-circular chief
``a δa`` is the radial offset, ``a δλ`` the along-track offset, ``a |δe|`` and ``a |δi|`` the
in-plane and cross-track oscillation amplitudes.

Near-circular orbits have no defined argument of periapsis ω (nor mean anomaly M), which makes
the classical element differences useless there. This set avoids it: it uses only ``u`` and the
eccentricity vector ``(e cos ω, e sin ω)``, which stay defined and smooth as ``e → 0``. It is
singular for an equatorial chief (``sin i_c = 0``), where ``δiy`` cannot carry the node offset.

The elements here are OSCULATING (the instantaneous Keplerian elements of each state); mean
elements, which strip the short-period J2 terms, are a later step.

Design-time code (NumPy): it sets initial states and checks scenarios, it does not run in the
closed loop.

References
----------
S. D'Amico and O. Montenbruck, "Proximity operations of formation-flying spacecraft using an
eccentricity/inclination vector separation", *Journal of Guidance, Control, and Dynamics*
29(3), 2006, pp. 554-563.
S. D'Amico, *Autonomous Formation Flying in Low Earth Orbit*, PhD thesis, TU Delft, 2010,
chapter 2 (the set above and its first-order mapping to the chief's Hill frame).
"""

import numpy as np

from coopsat.astro.kepler import EQUATORIAL_I_RAD, elements_to_rv, rv_to_elements

TWO_PI = 2.0 * np.pi


def _wrap(angle_rad):
    """``angle_rad`` wrapped to (−π, π].

    An angle already in range is returned unchanged, bit for bit (``π − mod(π − x, 2π)`` would
    round a small difference to a multiple of ulp(π) ≈ 4e-16 rad, i.e. a relative error of 3e-11
    on a 100 m along-track offset in LEO).
    """
    return float(angle_rad - TWO_PI * np.ceil((angle_rad - np.pi) / TWO_PI))


def _is_equatorial(i_rad):
    """Whether the node of an orbit of inclination ``i_rad`` is undefined (``sin i`` ≈ 0)."""
    return abs(np.sin(i_rad)) < EQUATORIAL_I_RAD


def roe_from_elements(chief, deputy):
    """Quasi-nonsingular relative orbital elements from the chief's and deputy's elements.

    Parameters
    ----------
    chief, deputy : array_like, shape (6,)
        Classical elements ``(a_m, e, i_rad, raan_rad, argp_rad, mean_anomaly_rad)``:
        semi-major axis, m; eccentricity; inclination, right ascension of the ascending node,
        argument of periapsis and mean anomaly, rad.

    Returns
    -------
    ndarray, shape (6,)
        ``[δa, δλ, δex, δey, δix, δiy]``, dimensionless (rad for the angle-like ones). The
        differences ``u_d − u_c`` and ``Ω_d − Ω_c`` are wrapped to (−π, π] before they enter
        ``δλ`` and ``δiy``.

    Notes
    -----
    Definition of D'Amico (2010), chapter 2, and D'Amico & Montenbruck (2006). For an
    equatorial chief (``|sin i_c|`` below :data:`~coopsat.astro.kepler.EQUATORIAL_I_RAD`) the
    chief's node is undefined, so ``δiy`` takes its limit 0 and the deputy's node offset is lost
    (only ``u + Ω cos i_c`` enters, through ``δλ``); :func:`elements_from_roe` then puts the
    deputy's node on the chief's.
    """
    a_c, e_c, i_c, raan_c, argp_c, m_c = np.asarray(chief, dtype=float)
    a_d, e_d, i_d, raan_d, argp_d, m_d = np.asarray(deputy, dtype=float)
    d_raan = _wrap(raan_d - raan_c)
    d_u = _wrap((argp_d + m_d) - (argp_c + m_c))
    return np.array(
        [
            (a_d - a_c) / a_c,
            d_u + d_raan * np.cos(i_c),
            e_d * np.cos(argp_d) - e_c * np.cos(argp_c),
            e_d * np.sin(argp_d) - e_c * np.sin(argp_c),
            i_d - i_c,
            0.0 if _is_equatorial(i_c) else d_raan * np.sin(i_c),
        ]
    )


def elements_from_roe(chief, roe):
    """Deputy's classical elements from the chief's and the relative orbital elements.

    The exact inverse of :func:`roe_from_elements` (no linearisation).

    Parameters
    ----------
    chief : array_like, shape (6,)
        Chief's ``(a_m, e, i_rad, raan_rad, argp_rad, mean_anomaly_rad)``, as in
        :func:`roe_from_elements`.
    roe : array_like, shape (6,)
        ``[δa, δλ, δex, δey, δix, δiy]``, dimensionless.

    Returns
    -------
    ndarray, shape (6,)
        Deputy's ``(a_m, e, i_rad, raan_rad, argp_rad, mean_anomaly_rad)``; the last three
        angles in [0, 2π). A circular deputy (``e = 0``) gets ``ω = 0`` and ``M = u``, as
        :func:`~coopsat.astro.kepler.rv_to_elements` does.

    Raises
    ------
    ValueError
        One line naming the cause: ``δa ≤ −1`` (deputy semi-major axis ≤ 0), a deputy
        eccentricity ≥ 1, ``δiy ≠ 0`` with an equatorial chief (its node offset cannot be
        recovered), or a deputy inclination ``i_c + δix`` outside [0, π].

    Notes
    -----
    The definition (module docstring; D'Amico 2010, chapter 2) solved for the deputy: ``Ω_d = Ω_c + δiy / sin i_c``,
    ``i_d = i_c + δix``, ``(e cos ω, e sin ω)_d = (e cos ω, e sin ω)_c + (δex, δey)``,
    ``u_d = u_c + δλ − (Ω_d − Ω_c) cos i_c``, ``M_d = u_d − ω_d``.
    """
    a_c, e_c, i_c, raan_c, argp_c, m_c = np.asarray(chief, dtype=float)
    d_a, d_lambda, d_ex, d_ey, d_ix, d_iy = np.asarray(roe, dtype=float)
    a_d = a_c * (1.0 + d_a)
    if a_d <= 0.0:
        raise ValueError(f"roe: δa = {d_a:.6g} gives a non-positive deputy semi-major axis ({a_d:.6g} m)")
    ex_d = e_c * np.cos(argp_c) + d_ex
    ey_d = e_c * np.sin(argp_c) + d_ey
    e_d = float(np.hypot(ex_d, ey_d))
    if e_d >= 1.0:
        raise ValueError(f"roe: (δex, δey) = ({d_ex:.6g}, {d_ey:.6g}) gives a deputy eccentricity {e_d:.6g} ≥ 1")
    if _is_equatorial(i_c):
        if d_iy != 0.0:
            raise ValueError(
                f"roe: δiy = {d_iy:.6g} with an equatorial chief (sin i = {np.sin(i_c):.3g}): "
                "its node offset is undefined"
            )
        d_raan = 0.0
    else:
        d_raan = d_iy / np.sin(i_c)
    i_d = i_c + d_ix
    if not 0.0 <= i_d <= np.pi:
        raise ValueError(f"roe: δix = {d_ix:.6g} gives a deputy inclination {i_d:.6g} rad outside [0, π]")
    # atan2(0, 0) = 0: a circular deputy gets ω = 0, so M carries all of u.
    argp_d = float(np.mod(np.arctan2(ey_d, ex_d), TWO_PI))
    u_d = (argp_c + m_c) + d_lambda - d_raan * np.cos(i_c)
    return np.array([a_d, e_d, i_d, np.mod(raan_c + d_raan, TWO_PI), argp_d, np.mod(u_d - argp_d, TWO_PI)])


def _classical(elements):
    """``(a, e, i, Ω, ω, M)`` of a :class:`~coopsat.astro.kepler.Elements` (true anomaly dropped)."""
    return (elements.a_m, elements.e, elements.i_rad, elements.raan_rad, elements.argp_rad, elements.mean_anomaly_rad)


def roe_from_rv(r_chief_m, v_chief_m_s, r_deputy_m, v_deputy_m_s, mu_m3_s2):
    """Relative orbital elements from the chief's and deputy's inertial states.

    Parameters
    ----------
    r_chief_m, v_chief_m_s : array_like, shape (3,)
        Chief position, m, and velocity, m/s, ECI.
    r_deputy_m, v_deputy_m_s : array_like, shape (3,)
        Deputy position, m, and velocity, m/s, ECI.
    mu_m3_s2 : float
        Gravitational parameter of the central body, m³/s².

    Returns
    -------
    ndarray, shape (6,)
        ``[δa, δλ, δex, δey, δix, δiy]`` of the osculating elements, dimensionless.

    Raises
    ------
    ValueError
        Either state is not an elliptic orbit (from
        :func:`~coopsat.astro.kepler.rv_to_elements`).

    Notes
    -----
    :func:`~coopsat.astro.kepler.rv_to_elements` on each state, then
    :func:`roe_from_elements`. Its convention for a circular orbit (``ω = 0``, ``M = u``) is
    harmless here: only ``u`` and the eccentricity vector enter, and both are continuous as
    ``e`` crosses :data:`~coopsat.astro.kepler.CIRCULAR_E`.
    """
    chief = rv_to_elements(r_chief_m, v_chief_m_s, mu_m3_s2)
    deputy = rv_to_elements(r_deputy_m, v_deputy_m_s, mu_m3_s2)
    return roe_from_elements(_classical(chief), _classical(deputy))


def rv_from_roe(r_chief_m, v_chief_m_s, roe, mu_m3_s2):
    """Deputy's inertial state from the chief's state and the relative orbital elements.

    Parameters
    ----------
    r_chief_m, v_chief_m_s : array_like, shape (3,)
        Chief position, m, and velocity, m/s, ECI.
    roe : array_like, shape (6,)
        ``[δa, δλ, δex, δey, δix, δiy]`` of the osculating elements, dimensionless.
    mu_m3_s2 : float
        Gravitational parameter of the central body, m³/s².

    Returns
    -------
    r_m : ndarray, shape (3,)
        Deputy position, m, ECI.
    v_m_s : ndarray, shape (3,)
        Deputy velocity, m/s, ECI.

    Raises
    ------
    ValueError
        The chief's state is not an elliptic orbit, or ``roe`` gives no valid deputy orbit
        (see :func:`elements_from_roe`).

    Notes
    -----
    :func:`~coopsat.astro.kepler.rv_to_elements` on the chief, :func:`elements_from_roe`, then
    :func:`~coopsat.astro.kepler.elements_to_rv`.
    """
    chief = rv_to_elements(r_chief_m, v_chief_m_s, mu_m3_s2)
    return elements_to_rv(*elements_from_roe(_classical(chief), roe), mu_m3_s2)
