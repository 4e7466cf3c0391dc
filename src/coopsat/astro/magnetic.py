"""The Earth's magnetic field as a tilted dipole (IGRF-13, epoch 2020.0) (SPEC §5).

The degree-1 terms of the IGRF give the potential ``V = a³ (g·r)/r³`` with
``g = (g₁¹, h₁¹, g₁⁰)`` in ECEF axes (x: Greenwich meridian, z: north pole), so the field is
``B = −∇V = a³ (3 (g·r̂) r̂ − g) / r³``: a dipole of moment ``4π a³ g / μ₀`` about 7.7e22 A·m²,
tilted 9.4° from the pole towards 72.7° W. SPEC §5 takes the dipole as enough for momentum
dumping; the higher degrees change the field at 500 km by up to about 20 % in direction and
magnitude, and the secular variation moves ``g`` by about 0.1 % a year. ``jax.numpy``: traces
under ``jit``.
"""


import jax.numpy as jnp

from coopsat.astro.earth_orientation import gcrf_to_itrf, itrf_to_gcrf

IGRF_RADIUS_M = 6371200.0
"""IGRF reference radius a, m."""

IGRF2020_DIPOLE_T = (-1450.9e-9, 4652.5e-9, -29404.8e-9)
"""IGRF-13 degree-1 Gauss coefficients at 2020.0, ``(g₁¹, h₁¹, g₁⁰)``, tesla (Alken et al.,
*Earth, Planets and Space* 73:49, 2021), in the order of the ECEF axes they multiply."""


def _dot(a, b, axis):
    return jnp.sum(a * b, axis=axis, keepdims=True)


def dipole_field_ecef(r_ecef_m, axis=-1):
    """Field of the tilted dipole at a point, ECEF components, T.

    Parameters
    ----------
    r_ecef_m : array_like, shape (..., 3) (component ``axis``)
        Position relative to the Earth's centre, ECEF, m.
    axis : int
        Component axis.

    Returns
    -------
    jax.Array, the shape of ``r_ecef_m``
        ``B = a³ (3 (g·r̂) r̂ − g) / r³``.
    """
    r_ecef_m = jnp.asarray(r_ecef_m)
    shape = [1] * r_ecef_m.ndim
    shape[axis] = 3
    g = jnp.asarray(IGRF2020_DIPOLE_T).reshape(shape)
    r = jnp.sqrt(_dot(r_ecef_m, r_ecef_m, axis))
    r_hat = r_ecef_m / r
    return (IGRF_RADIUS_M / r) ** 3 * (3.0 * _dot(g, r_hat, axis) * r_hat - g)


def dipole_field_gcrf(r_gcrf_m, t_s, earth, axis=-1):
    """Field of the tilted dipole, inertial components, T.

    Parameters
    ----------
    r_gcrf_m : array_like, shape (..., 3) (component ``axis``)
        Position, inertial (GCRF), m.
    t_s : array_like
        Run time, s, broadcast as in :func:`coopsat.astro.earth_orientation.gcrf_to_itrf`.
    earth : coopsat.astro.earth_orientation.EarthOrientation
        The Earth's orientation over the run (the dipole is fixed to the Earth).
    axis : int
        Component axis.

    Returns
    -------
    jax.Array, the shape of ``r_gcrf_m``
    """
    return itrf_to_gcrf(dipole_field_ecef(gcrf_to_itrf(r_gcrf_m, t_s, earth, axis), axis), t_s, earth, axis)
