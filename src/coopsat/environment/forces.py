"""Disturbance forces: solar radiation pressure on a cannonball (SPEC §4).

Disturbance parts as in :mod:`coopsat.environment.torques`: ``init``, ``update``, ``wrench``
(every RK4 stage), ``record``. Arrays are component-major, (3, n).
"""


import jax.numpy as jnp

from coopsat.core.parts import OutputSpec, part
from coopsat.environment.torques import Stateless
from coopsat.geometry.quaternion import dot


def srp_force_eci(r_sun_to_sc_m, area_m2, reflectivity, pressure_1au_n_m2, au_m, axis=-1):
    """Solar radiation pressure force on a cannonball, N, inertial axes.

    Parameters
    ----------
    r_sun_to_sc_m : (..., 3)
        Position of the spacecraft relative to the Sun, m.
    area_m2 : broadcastable to the spacecraft axes
        Effective (Sun-facing) area, m².
    reflectivity : broadcastable like ``area_m2``
        Fraction of the light reflected specularly, 0 (absorber) … 1 (mirror): the pressure
        coefficient is ``C_r = 1 + reflectivity``.
    pressure_1au_n_m2, au_m : scalar
        Pressure on an absorber at 1 AU, N/m², and the AU, m.
    axis : int
        Component axis.

    Returns
    -------
    jax.Array, shape of ``r_sun_to_sc_m``
        ``F = P₁ (AU/r)² A (1 + reflectivity) r̂``, pointing away from the Sun.

    Notes
    -----
    The cannonball model (e.g. Montenbruck & Gill, *Satellite Orbits*, §3.4, eq. 3.75 with the
    Sun–spacecraft vector): the force a flat plate facing the Sun feels when its reflection is
    specular. In a formation only the difference between spacecraft acts on the relative
    motion: different reflectivities (SPEC §4) or areas make it. No eclipse: deep space.
    """
    r2 = dot(r_sun_to_sc_m, r_sun_to_sc_m, axis, keepdims=True)
    scale = pressure_1au_n_m2 * au_m**2 * area_m2 * (1.0 + reflectivity) / (r2 * jnp.sqrt(r2))
    return scale * r_sun_to_sc_m


@part()
class SolarRadiationPressure(Stateless):
    """Solar radiation pressure part; the Sun is the central body of ``[orbit]`` (heliocentric runs).

    Attributes
    ----------
    area_m2, reflectivity : (n,)
        Per spacecraft.
    pressure_1au_n_m2, au_m : scalar
    """

    area_m2: jnp.ndarray
    reflectivity: jnp.ndarray
    pressure_1au_n_m2: jnp.ndarray
    au_m: jnp.ndarray

    def wrench(self, t, x, state):
        return {"force_eci": srp_force_eci(x.r_eci, self.area_m2, self.reflectivity, self.pressure_1au_n_m2, self.au_m, 0)}

    def record(self, t, x, state):
        return {"srp_force": self.wrench(t, x, state)["force_eci"]}

    def output_specs(self):
        return {"srp_force": OutputSpec(("component",), "N", "ECI", "solar radiation pressure force at the sample")}
