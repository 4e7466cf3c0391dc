"""What moves a low orbit beyond J2: the gravity field, drag, the Sun and the Moon, and solar
radiation pressure with the Earth's shadow.

Disturbance parts as in :mod:`coopsat.environment.torques` (``init``, ``update``, ``wrench`` at
every integration stage, ``record``); arrays are component-major, ``(3, n)``. Gravity acts
through the ``accel_eci`` channel (whatever the mass), drag and radiation pressure through
``force_eci``. The Earth-fixed frame is the run's :class:`~coopsat.astro.earth_orientation.EarthOrientation`
(IAU 2006/2000A by default), and the ephemerides take the run's clock, which is TT
(:mod:`coopsat.astro.timescales`). The analytic series give EME2000; the frame bias to the
GCRF (0.02″) is far below their own error (docs/leo.md), so it is not applied.
"""

import jax.numpy as jnp

from coopsat.astro.earth_orientation import EarthOrientation, itrf_from_gcrf_matrix, rotate
from coopsat.astro.ephemeris import (
    moon_position_eme2000_m,
    shadow_fraction_conical,
    shadow_fraction_cylindrical,
    sun_position_eme2000_m,
    third_body_accel,
)
from coopsat.astro.gravity_field import harmonic_accel_ecef
from coopsat.core.parts import OutputSpec, part
from coopsat.environment.earth_torques import body_columns_m, facet_srp_force_b, lit_area, relative_wind_eci
from coopsat.environment.torques import Stateless
from coopsat.geometry.quaternion import quat_rotate, quat_rotate_inverse

SECONDS_PER_DAY = 86400.0


@part()
class GravityField(Stateless):
    """The field's degrees 2…N (spherical harmonics; the point mass is the plant's).

    Attributes
    ----------
    c, s : (N+1, N+1)
        Fully normalised coefficients (:func:`coopsat.astro.gravity_field.egm2008`).
    gm_m3_s2, radius_m : scalar
        The model's GM and reference radius.
    earth : EarthOrientation
        The Earth's orientation over the run (the field is fixed to the Earth).
    """

    c: jnp.ndarray
    s: jnp.ndarray
    gm_m3_s2: jnp.ndarray
    radius_m: jnp.ndarray
    earth: EarthOrientation

    def wrench(self, t, x, state):
        to_itrf = itrf_from_gcrf_matrix(self.earth, t)  # once for both ways
        a_itrf = harmonic_accel_ecef(rotate(to_itrf, x.r_eci, 0), self.c, self.s, self.gm_m3_s2, self.radius_m, 0)
        return {"accel_eci": rotate(jnp.swapaxes(to_itrf, -1, -2), a_itrf, 0)}

    def record(self, t, x, state):
        return {"gravity_field_accel": self.wrench(t, x, state)["accel_eci"]}

    def output_specs(self):
        return {
            "gravity_field_accel": OutputSpec(
                ("component",), "m s-2", "ECI", "acceleration of the gravity field's degrees 2 and above at the sample"
            )
        }


@part(static=("bodies",))
class ThirdBodies(Stateless):
    """Point-mass attraction of the Sun and/or the Moon (the perturbation, with its indirect
    term: the Earth is accelerated too).

    Attributes
    ----------
    mu_m3_s2 : (B,)
        Gravitational parameters of the bodies, in the order of ``bodies``.
    jd0_tt : scalar
        Julian date of t = 0.
    bodies : tuple of str, static
        ``"sun"``, ``"moon"``.
    """

    mu_m3_s2: jnp.ndarray
    jd0_tt: jnp.ndarray
    bodies: tuple = ("sun", "moon")

    def wrench(self, t, x, state):
        jd = self.jd0_tt + t / SECONDS_PER_DAY
        accel = jnp.zeros_like(x.r_eci)
        for k, body in enumerate(self.bodies):
            position = sun_position_eme2000_m(jd) if body == "sun" else moon_position_eme2000_m(jd)
            accel = accel + third_body_accel(x.r_eci, body_columns_m(position), self.mu_m3_s2[k], 0)
        return {"accel_eci": accel}

    def record(self, t, x, state):
        return {"third_body_accel": self.wrench(t, x, state)["accel_eci"]}

    def output_specs(self):
        return {"third_body_accel": OutputSpec(("component",), "m s-2", "ECI", "third-body acceleration at the sample")}


def drag_force_eci(v_rel_eci_m_s, density_kg_m3, cd_area_m2):
    """Drag force ``F = −½ ρ (C_D A) |v_r| v_r``, N, (3, n).

    Parameters
    ----------
    v_rel_eci_m_s : (3, n)
        Velocity relative to the air, m/s.
    density_kg_m3 : (n,)
    cd_area_m2 : (n,)
        Drag coefficient times the area facing the flow, m².

    Notes
    -----
    Montenbruck & Gill, *Satellite Orbits*, eq. 3.97 (times the mass).
    """
    speed = jnp.linalg.norm(v_rel_eci_m_s, axis=0)
    return -0.5 * density_kg_m3 * cd_area_m2 * speed * v_rel_eci_m_s


@part()
class Drag(Stateless):
    """Atmospheric drag on each spacecraft: a cannonball, or flat facets whose area facing the
    flow follows the attitude.

    Attributes
    ----------
    atmosphere : part
        Density model with ``density_kg_m3(t, r_eci)`` -> (n,) (:mod:`coopsat.plugins.orbit_environment`).
    cd : (n,)
        Drag coefficient.
    area_m2 : (n,)
        Cannonball area, m² (ignored with facets).
    normals_b : (3, F)
        Facets' unit outward normals, body axes; F = 0 for a cannonball.
    areas_m2 : (F,)
        Facets' areas, m².
    """

    atmosphere: object
    cd: jnp.ndarray
    area_m2: jnp.ndarray
    normals_b: jnp.ndarray
    areas_m2: jnp.ndarray

    def _force_and_density(self, t, x):
        v_rel = relative_wind_eci(x.r_eci, x.v_eci)
        rho = self.atmosphere.density_kg_m3(t, x.r_eci)
        if self.areas_m2.shape[0] == 0:
            area = self.area_m2
        else:
            v_b = quat_rotate_inverse(x.q_bi, v_rel, 0)
            area = jnp.sum(lit_area(self.normals_b, self.areas_m2, v_b / jnp.linalg.norm(v_b, axis=0))[0], axis=0)
        return drag_force_eci(v_rel, rho, self.cd * area), rho

    def wrench(self, t, x, state):
        return {"force_eci": self._force_and_density(t, x)[0]}

    def record(self, t, x, state):
        force, rho = self._force_and_density(t, x)
        return {"drag_force": force, "air_density": rho}

    def output_specs(self):
        return {
            "drag_force": OutputSpec(("component",), "N", "ECI", "atmospheric drag force at the sample"),
            "air_density": OutputSpec((), "kg m-3", "", "air density at the spacecraft at the sample"),
        }


_SHADOWS = {"conical": shadow_fraction_conical, "cylindrical": shadow_fraction_cylindrical}


@part(static=("shadow",))
class EarthSolarRadiationPressure(Stateless):
    """Solar radiation pressure about the Earth, dimmed by the Earth's shadow: on a cannonball,
    or on flat facets whose force follows the attitude.

    Attributes
    ----------
    area_m2, reflectivity : (n,)
        Cannonball Sun-facing area, m², and specular reflectivity (``C_r = 1 + reflectivity``);
        ignored with facets.
    normals_b : (3, F)
        Facets' unit outward normals, body axes; F = 0 for a cannonball.
    areas_m2, specular, diffuse : (F,)
        Facets' areas, m², and the fractions of light they reflect specularly and diffusely.
    pressure_1au_n_m2, au_m : scalar
    jd0_tt : scalar
        Julian date of t = 0.
    shadow : {"conical", "cylindrical"}, static
        The Earth's shadow: umbra and penumbra, or the cylinder.
    """

    area_m2: jnp.ndarray
    reflectivity: jnp.ndarray
    normals_b: jnp.ndarray
    areas_m2: jnp.ndarray
    specular: jnp.ndarray
    diffuse: jnp.ndarray
    pressure_1au_n_m2: jnp.ndarray
    au_m: jnp.ndarray
    jd0_tt: jnp.ndarray
    shadow: str = "conical"

    def _force_and_light(self, t, x):
        r_sun = body_columns_m(sun_position_eme2000_m(self.jd0_tt + t / SECONDS_PER_DAY))
        light = _SHADOWS[self.shadow](x.r_eci, r_sun, 0)
        from_sun = x.r_eci - r_sun
        distance2 = jnp.sum(from_sun * from_sun, axis=0)
        if self.areas_m2.shape[0] == 0:
            scale = light * self.pressure_1au_n_m2 * self.au_m**2 * self.area_m2 * (1.0 + self.reflectivity) / (distance2 * jnp.sqrt(distance2))
            return scale * from_sun, light
        sun_eci = -from_sun / jnp.sqrt(distance2)
        pressure = light * self.pressure_1au_n_m2 * self.au_m**2 / distance2
        force_b = facet_srp_force_b(
            quat_rotate_inverse(x.q_bi, sun_eci, 0), pressure, self.normals_b, self.areas_m2, self.specular, self.diffuse
        )
        return quat_rotate(x.q_bi, force_b, 0), light

    def wrench(self, t, x, state):
        return {"force_eci": self._force_and_light(t, x)[0]}

    def record(self, t, x, state):
        force, light = self._force_and_light(t, x)
        return {"srp_force": force, "sunlight_fraction": light}

    def output_specs(self):
        return {
            "srp_force": OutputSpec(("component",), "N", "ECI", "solar radiation pressure force at the sample"),
            "sunlight_fraction": OutputSpec((), "1", "", "fraction of the Sun's disc seen past the Earth (0: eclipse)"),
        }
