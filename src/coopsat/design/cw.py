"""Clohessy–Wiltshire relative motion in the chief's LVLH frame (SPEC §2): the design model of
the cartwheel formation.

Frame (one definition, :mod:`coopsat.geometry.frames`): x along-track, y along the negative
orbit normal, z toward the Earth's centre. State ``[x, y, z, ẋ, ẏ, ż]`` (m, m/s), input the
specific force ``f`` (m/s², force over mass), chief on a circular orbit of mean motion n:

    ẍ − 2n ż = f_x,     ÿ + n² y = f_y,     z̈ + 2n ẋ − 3n² z = f_z.

The space circular formation ("cartwheel") of radius ρ, tilted 30° from the local horizontal:
``x = ρ cos θ``, ``y = (√3/2) ρ sin θ``, ``z = −(ρ/2) sin θ``, ``θ = n t + φ``: an exact,
bounded solution of the unforced equations with ``|r| = ρ`` at all times.

The keeping gain is the sampled LQR of this model (SPEC §2 eqs. 12–14 in discrete form, the
command held over the period): ``coopsat.design.riccati.lqr(*cw_matrices(n), Q, R,
discrete_dt_s=T)``.
"""

import numpy as np

from coopsat.dynamics import cw as dynamics_cw


def cw_matrices(n_rad_s):
    """State and input matrices of the CW equations in our LVLH axes, as numpy arrays.

    Parameters
    ----------
    n_rad_s : float
        Mean motion of the chief's circular orbit, rad/s.

    Returns
    -------
    a : ndarray (6, 6), 1/s and 1/s²
    b : ndarray (6, 3)
        Input: specific force, m/s².

    Notes
    -----
    One implementation: :func:`coopsat.dynamics.cw.cw_matrices`, copied into writable numpy
    arrays for scipy.
    """
    a, b = dynamics_cw.cw_matrices(n_rad_s)
    return np.array(a), np.array(b)


def cw_stm(n_rad_s, t_s):
    """Closed-form state-transition matrix Φ(t) of the unforced CW equations, our LVLH axes.

    Parameters
    ----------
    n_rad_s : float
        Mean motion, rad/s.
    t_s : float or array_like (...)
        Elapsed time, s.

    Returns
    -------
    ndarray (..., 6, 6)

    Notes
    -----
    One implementation: :func:`coopsat.dynamics.cw.cw_stm` (Vallado, 4th ed., eq. 6-66, with
    ``x = y_H, y = −z_H, z = −x_H``), converted to numpy.
    """
    return np.array(dynamics_cw.cw_stm(n_rad_s, t_s))


def cartwheel_state(rho_m, n_rad_s, t_s, phase_rad):
    """State on the SPEC §2 relative circle, ``(..., 6)``, as a numpy array.

    One implementation: :func:`coopsat.dynamics.cw.cartwheel_state` (broadcast over t and φ).
    """
    return np.asarray(dynamics_cw.cartwheel_state(rho_m, n_rad_s, t_s, phase_rad))


def deputy_phases(psi_rad, k=3):
    """Phases ``φ_j = ψ + 2π (j − 1)/k`` of k deputies evenly spread on the circle, rad."""
    return psi_rad + 2.0 * np.pi * np.arange(k) / k


def cartwheel_eci(r_chief_eci, v_chief_eci, rho_m, n_rad_s, phase_rad, t_s=0.0):
    """ECI positions and velocities of deputies placed on the relative circle at time t.

    Parameters
    ----------
    r_chief_eci, v_chief_eci : (3,)
        Chief position, m, and velocity, m/s.
    rho_m, n_rad_s : float
    phase_rad : (k,)
    t_s : float

    Returns
    -------
    r_eci, v_eci : ndarray (k, 3)
        Through :func:`coopsat.geometry.frames.lvlh_to_eci` (rotating-frame velocity of the
        circle plus the frame's rotation).
    """
    from coopsat.geometry.frames import lvlh_to_eci

    x = cartwheel_state(rho_m, n_rad_s, t_s, phase_rad)
    r, v = lvlh_to_eci(np.asarray(r_chief_eci), np.asarray(v_chief_eci), x[:, :3], x[:, 3:])
    return np.asarray(r), np.asarray(v)
