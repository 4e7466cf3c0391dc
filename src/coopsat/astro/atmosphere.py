"""An exponential atmosphere: piecewise exponential density by altitude (SPEC §5).

Vallado, *Fundamentals of Astrodynamics and Applications*, 4th ed., Table 8-4 (from the
CIRA-72 model): in each altitude band ``ρ = ρ₀ exp(−(h − h₀)/H)``. It is a mean over the
solar cycle; at 500 km the real density swings by a factor of ten with solar activity, which
is the honest size of its error. ``jax.numpy``: traces under ``jit``.
"""


import jax.numpy as jnp

from coopsat.astro.earth import WGS84_A_M, WGS84_F

# (base altitude h0 km, nominal density rho0 kg/m^3, scale height H km), Vallado Table 8-4.
_TABLE = (
    (0.0, 1.225, 7.249), (25.0, 3.899e-2, 6.349), (30.0, 1.774e-2, 6.682), (40.0, 3.972e-3, 7.554),
    (50.0, 1.057e-3, 8.382), (60.0, 3.206e-4, 7.714), (70.0, 8.770e-5, 6.549), (80.0, 1.905e-5, 5.799),
    (90.0, 3.396e-6, 5.382), (100.0, 5.297e-7, 5.877), (110.0, 9.661e-8, 7.263), (120.0, 2.438e-8, 9.473),
    (130.0, 8.484e-9, 12.636), (140.0, 3.845e-9, 16.149), (150.0, 2.070e-9, 22.523), (180.0, 5.464e-10, 29.740),
    (200.0, 2.789e-10, 37.105), (250.0, 7.248e-11, 45.546), (300.0, 2.418e-11, 53.628), (350.0, 9.518e-12, 53.298),
    (400.0, 3.725e-12, 58.515), (450.0, 1.585e-12, 60.828), (500.0, 6.967e-13, 63.822), (600.0, 1.454e-13, 71.835),
    (700.0, 3.614e-14, 88.667), (800.0, 1.170e-14, 124.64), (900.0, 5.245e-15, 181.05), (1000.0, 3.019e-15, 268.00),
)


def density_kg_m3(altitude_m):
    """Density of the exponential atmosphere, kg/m³.

    Parameters
    ----------
    altitude_m : array_like
        Height above the ellipsoid, m. Below 0 the sea-level band continues; above 1000 km the
        last band's scale height continues.

    Returns
    -------
    jax.Array, the shape of ``altitude_m``
    """
    h_km = jnp.asarray(altitude_m) / 1000.0
    table = jnp.asarray(_TABLE)
    k = jnp.clip(jnp.searchsorted(table[:, 0], h_km, side="right") - 1, 0, table.shape[0] - 1)
    h0, rho0, scale = table[k, 0], table[k, 1], table[k, 2]
    return rho0 * jnp.exp(-(h_km - h0) / scale)


def altitude_m(r_m, axis=-1):
    """Approximate height above the WGS-84 ellipsoid of a point, m.

    Parameters
    ----------
    r_m : array_like, shape (..., 3) (component ``axis``)
        Position relative to the Earth's centre (ECI or ECEF: only ``z`` and ``|r|`` count), m.
    axis : int

    Returns
    -------
    jax.Array, the shape without the component axis

    Notes
    -----
    ``h ≈ |r| − a (1 − f sin²φ_c)`` with ``sin φ_c = z/|r|``: the ellipsoid's radius at the
    geocentric latitude, to first order in the flattening (error below 100 m in low orbit, a
    density error below 0.2 %, where a sphere of radius a would err by up to 21 km).
    """
    r_m = jnp.asarray(r_m)
    r = jnp.linalg.norm(r_m, axis=axis)
    sin_lat = jnp.take(r_m, 2, axis=axis) / r
    return r - WGS84_A_M * (1.0 - WGS84_F * sin_lat**2)
