"""Translational dynamics in an inertial frame: point-mass gravity with optional J2.

The truth models of SPEC §2 and §5 propagate every spacecraft in ECI with these forces; the
ECI frame is the one defined in docs/conventions.md (Earth-centred, z along the pole).
"""


import jax.numpy as jnp

from coopsat.geometry.quaternion import dot, join, split


def two_body_accel(r_eci_m, mu_m3_s2, axis=-1):
    """Point-mass gravity ``−μ r / |r|³``, m/s²; shape (..., 3) -> (..., 3) (component ``axis``)."""
    r2 = dot(r_eci_m, r_eci_m, axis, keepdims=True)
    return -mu_m3_s2 * r_eci_m / (r2 * jnp.sqrt(r2))


def j2_accel(r_eci_m, mu_m3_s2, j2, r_body_m, axis=-1):
    """Perturbing acceleration of the J2 zonal harmonic, m/s²; shape (..., 3) -> (..., 3).

    Parameters
    ----------
    r_eci_m : array_like, shape (..., 3)
        Position in the body-centred inertial frame whose z axis is the body's pole, m.
    mu_m3_s2, j2, r_body_m : float
        Gravitational parameter, J2 coefficient and equatorial radius of the central body.
    axis : int
        Component axis.

    Notes
    -----
    Vallado, 4th ed., eq. (8-30): the gradient of ``−μ J2 R² (3 sin²φ − 1) / (2 r³)``.
    """
    x, y, z = split(r_eci_m, axis)
    r2 = x * x + y * y + z * z
    r = jnp.sqrt(r2)
    k = -1.5 * j2 * mu_m3_s2 * r_body_m**2 / (r2 * r2 * r)
    z2 = 5.0 * z * z / r2
    return join([k * x * (1.0 - z2), k * y * (1.0 - z2), k * z * (3.0 - z2)], axis)


def specific_energy_j_kg(r_eci_m, v_eci_m_s, mu_m3_s2, axis=-1):
    """Two-body specific orbital energy ``v²/2 − μ/r``, J/kg; shapes (..., 3) -> (...)."""
    return 0.5 * dot(v_eci_m_s, v_eci_m_s, axis) - mu_m3_s2 / jnp.sqrt(dot(r_eci_m, r_eci_m, axis))
