"""The Sun seen from the Earth: a low-precision direction and a cylindrical shadow (SPEC §5).

The direction is the Astronomical Almanac's low-precision solar coordinates (Vallado,
*Fundamentals of Astrodynamics and Applications*, 4th ed., Algorithm 29): accurate to about
0.01° between 1950 and 2050, in the mean equator and equinox of date, which is the frame the
rotating Earth of :mod:`coopsat.astro.earth` turns in (GMST, no precession or nutation). Written
with ``jax.numpy``: it traces under ``jit`` with the Julian date a traced scalar.
"""


import jax.numpy as jnp

from coopsat.astro.constants import AU_M, R_EARTH_M
from coopsat.astro.earth import JD_J2000


def sun_position_eci_m(jd_ut1):
    """Geocentric position of the Sun, m, mean equator and equinox of date.

    Parameters
    ----------
    jd_ut1 : array_like, shape (...)
        Julian date (UT1 ≈ UTC; the 69 s of TT − UT1 move the Sun by 0.0008°).

    Returns
    -------
    jax.Array, shape (..., 3)

    Notes
    -----
    Vallado Algorithm 29: mean longitude ``λ_M = 280.460° + 36000.771° T``, mean anomaly
    ``M = 357.5291092° + 35999.05034° T``, ecliptic longitude
    ``λ = λ_M + 1.914666471° sin M + 0.019994643° sin 2M``, distance
    ``r = 1.000140612 − 0.016708617 cos M − 0.000139589 cos 2M`` AU, obliquity
    ``ε = 23.439291° − 0.0130042° T``, with T in Julian centuries from J2000.
    """
    t = (jnp.asarray(jd_ut1) - JD_J2000) / 36525.0
    mean_lon = jnp.radians(280.460 + 36000.771 * t)
    m = jnp.radians(357.5291092 + 35999.05034 * t)
    lon = mean_lon + jnp.radians(1.914666471 * jnp.sin(m) + 0.019994643 * jnp.sin(2.0 * m))
    r_au = 1.000140612 - 0.016708617 * jnp.cos(m) - 0.000139589 * jnp.cos(2.0 * m)
    eps = jnp.radians(23.439291 - 0.0130042 * t)
    return (r_au * AU_M)[..., None] * jnp.stack(
        [jnp.cos(lon), jnp.cos(eps) * jnp.sin(lon), jnp.sin(eps) * jnp.sin(lon)], axis=-1
    )


def sun_direction_eci(jd_ut1):
    """Unit vector from the Earth's centre to the Sun, mean equator and equinox of date.

    Parameters
    ----------
    jd_ut1 : array_like, shape (...)

    Returns
    -------
    jax.Array, shape (..., 3)
    """
    r = sun_position_eci_m(jd_ut1)
    return r / jnp.linalg.norm(r, axis=-1, keepdims=True)


def sunlit(r_eci_m, sun_eci, axis=-1):
    """1.0 where a spacecraft is in sunlight, 0.0 in the Earth's cylindrical shadow.

    Parameters
    ----------
    r_eci_m : array_like, shape (..., 3) (component ``axis``)
        Spacecraft position, m.
    sun_eci : array_like, broadcastable against ``r_eci_m``
        Unit vector to the Sun.
    axis : int
        Component axis.

    Returns
    -------
    jax.Array
        The shape of ``r_eci_m`` without the component axis.

    Notes
    -----
    The shadow is the cylinder of the Earth's equatorial radius behind the Earth (Vallado
    Algorithm 34, no penumbra): the spacecraft is shadowed when ``r·ŝ < 0`` and its distance
    from the Earth–Sun line is below ``R_E``.
    """
    along = jnp.sum(r_eci_m * sun_eci, axis=axis, keepdims=True)
    across = jnp.linalg.norm(r_eci_m - along * sun_eci, axis=axis)
    return jnp.where((jnp.squeeze(along, axis) < 0.0) & (across < R_EARTH_M), 0.0, 1.0)
