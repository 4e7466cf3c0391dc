"""Environment torques in Earth orbit: aerodynamic and solar pressure on flat facets, and a
residual magnetic dipole in the geomagnetic field (SPEC §5).

Disturbance parts as in :mod:`coopsat.environment.torques` (``init``, ``update``, ``wrench`` at
every integration stage, ``record``); arrays are component-major, ``(3, n)``. The surface is a
set of F flat facets, the same on every spacecraft: unit outward normals ``normals_b`` (3, F),
areas ``areas_m2`` (F,), and centres of pressure ``centres_b_m`` (3, F) measured from the centre
of mass, body axes. A facet feels the flow or the light only on its front side (``n·û > 0``);
facets shadowing one another are not modelled (Basilisk's ``facetDragDynamicEffector`` and
``facetSRPDynamicEffector`` make the same choice). The radiation-pressure force on the facets
(:func:`facet_srp_force_b`, the ``solar-radiation-pressure`` force about the Earth) is here too,
beside the torque, from the same per-facet forces.
"""


import jax.numpy as jnp

from coopsat.core.parts import OutputSpec, part
from coopsat.astro.atmosphere import altitude_m, density_kg_m3
from coopsat.astro.earth import OMEGA_EARTH_RAD_S
from coopsat.astro.earth_orientation import EarthOrientation
from coopsat.astro.magnetic import dipole_field_gcrf
from coopsat.astro.sun import sun_position_eci_m, sunlit
from coopsat.environment.torques import Stateless
from coopsat.geometry.quaternion import cross, quat_rotate_inverse



def body_columns_m(position_m):
    """A body's position from an ephemeris evaluated at the stage time, as loop columns: (3, 1)
    for one time, (3, n) when a pulsed tick gives each spacecraft its own time (n,)."""
    columns = jnp.moveaxis(position_m, -1, 0)
    return columns[:, None] if columns.ndim == 1 else columns


def relative_wind_eci(r_eci_m, v_eci_m_s):
    """Velocity relative to an atmosphere turning with the Earth, ``v − ω_E × r``, m/s, (3, n)."""
    omega = jnp.asarray([0.0, 0.0, OMEGA_EARTH_RAD_S])[:, None]
    return v_eci_m_s - cross(omega, r_eci_m, 0)


def lit_area(normals_b, areas_m2, u_b):
    """``A_f max(n_f·û, 0)`` (F, n) and ``max(n_f·û, 0)`` for unit directions ``u_b`` (3, n)."""
    cos = jnp.maximum(jnp.einsum("kf,kn->fn", normals_b, u_b), 0.0)
    return areas_m2[:, None] * cos, cos


def facet_drag_torque_b(v_rel_b_m_s, density_kg_m3_, normals_b, areas_m2, centres_b_m, cd):
    """Aerodynamic torque on flat facets, N·m, body axes.

    Parameters
    ----------
    v_rel_b_m_s : (3, n)
        Velocity of the spacecraft relative to the air, body axes, m/s.
    density_kg_m3_ : (n,)
        Air density, kg/m³.
    normals_b : (3, F)
    areas_m2 : (F,)
    centres_b_m : (3, F)
    cd : scalar
        Drag coefficient (about 2.2 for free molecular flow on a flat plate).

    Returns
    -------
    jax.Array, (3, n)

    Notes
    -----
    Each facet facing the flow feels ``F_f = −½ ρ C_D A_f cos θ_f |v|² v̂`` at its centre of
    pressure (Wertz, *Spacecraft Attitude Determination and Control*, §17.2); the forces are
    parallel, so the torque is ``(Σ_f A_f cos θ_f c_f) × (−½ ρ C_D |v|² v̂)``.
    """
    speed = jnp.linalg.norm(v_rel_b_m_s, axis=0)
    v_hat = v_rel_b_m_s / speed
    projected, _ = lit_area(normals_b, areas_m2, v_hat)
    lever = centres_b_m @ projected
    return cross(lever, -0.5 * density_kg_m3_ * cd * speed**2 * v_hat, 0)


def facet_srp_components(sun_b, pressure_n_m2, normals_b, areas_m2, specular, diffuse):
    """Solar radiation pressure on each flat facet, split along the ray and the normal, N.

    The one model of the facet force: :func:`facet_srp_force_b` and :func:`facet_srp_torque_b`
    both reduce these, so the force and the torque cannot disagree.

    Parameters
    ----------
    sun_b : (3, n)
        Unit vector from the spacecraft to the Sun, body axes.
    pressure_n_m2 : (n,)
        Pressure on an absorber at the spacecraft, N/m² (0 in shadow).
    normals_b : (3, F)
        Unit outward normals, body axes.
    areas_m2, specular, diffuse : (F,)
        Areas, m², and the fractions of light reflected specularly and diffusely
        (``specular + diffuse ≤ 1``; the rest is absorbed).

    Returns
    -------
    along_ray, along_normal : jax.Array, (F, n)
        ``a_f`` and ``b_f``, N, of each facet's force ``F_f = −(a_f ŝ + b_f n_f)``; both 0 on a
        facet that the light reaches edge-on or from behind (``cos θ = n_f·ŝ ≤ 0``).

    Notes
    -----
    ``F_f = −P A_f cos θ [(1 − c_s) ŝ + 2 (c_s cos θ + c_d/3) n_f]`` on each lit facet (Wertz
    §17.2, eq. 17-12; Montenbruck & Gill §3.4): absorbed and diffuse light push along the ray,
    specular and diffuse reflection along the normal.
    """
    projected, cos = lit_area(normals_b, areas_m2, sun_b)
    pushed = pressure_n_m2 * projected
    return pushed * (1.0 - specular)[:, None], 2.0 * pushed * (specular[:, None] * cos + diffuse[:, None] / 3.0)


def facet_srp_force_b(sun_b, pressure_n_m2, normals_b, areas_m2, specular, diffuse):
    """Solar radiation pressure force on flat facets, ``Σ_f F_f``, N, body axes, (3, n);
    arguments as :func:`facet_srp_components`."""
    along_ray, along_normal = facet_srp_components(sun_b, pressure_n_m2, normals_b, areas_m2, specular, diffuse)
    return -(sun_b * jnp.sum(along_ray, axis=0) + normals_b @ along_normal)


def facet_srp_torque_b(sun_b, pressure_n_m2, normals_b, areas_m2, centres_b_m, specular, diffuse):
    """Solar radiation pressure torque on flat facets, ``Σ_f c_f × F_f``, N·m, body axes, (3, n).

    Arguments as :func:`facet_srp_components`, and the centres of pressure ``centres_b_m``
    (3, F), m, body axes, from the centre of mass.
    """
    along_ray, along_normal = facet_srp_components(sun_b, pressure_n_m2, normals_b, areas_m2, specular, diffuse)
    return -(cross(centres_b_m @ along_ray, sun_b, 0) + cross(centres_b_m, normals_b, 0) @ along_normal)


@part()
class AerodynamicTorque(Stateless):
    """Aerodynamic torque on facets in an exponential atmosphere that turns with the Earth.

    Attributes
    ----------
    normals_b, centres_b_m : (3, F)
    areas_m2 : (F,)
    cd : scalar
        Drag coefficient.
    """

    normals_b: jnp.ndarray
    areas_m2: jnp.ndarray
    centres_b_m: jnp.ndarray
    cd: jnp.ndarray

    def wrench(self, t, x, state):
        v_rel = relative_wind_eci(x.r_eci, x.v_eci)
        rho = density_kg_m3(altitude_m(x.r_eci, 0))
        torque = facet_drag_torque_b(quat_rotate_inverse(x.q_bi, v_rel, 0), rho, self.normals_b, self.areas_m2, self.centres_b_m, self.cd)
        return {"torque_b": torque}

    def record(self, t, x, state):
        return {"aerodynamic_torque": self.wrench(t, x, state)["torque_b"]}

    def output_specs(self):
        return {"aerodynamic_torque": OutputSpec(("component",), "N m", "body", "aerodynamic torque at the sample")}


@part()
class SolarPressureTorque(Stateless):
    """Solar radiation pressure torque on facets, with the Earth's cylindrical shadow.

    Attributes
    ----------
    normals_b, centres_b_m : (3, F)
    areas_m2, specular, diffuse : (F,)
    pressure_1au_n_m2, au_m : scalar
    jd0 : scalar
        Julian date of t = 0 (the Sun moves 1° a day).
    """

    normals_b: jnp.ndarray
    areas_m2: jnp.ndarray
    centres_b_m: jnp.ndarray
    specular: jnp.ndarray
    diffuse: jnp.ndarray
    pressure_1au_n_m2: jnp.ndarray
    au_m: jnp.ndarray
    jd0: jnp.ndarray

    def wrench(self, t, x, state):
        r_sun = body_columns_m(sun_position_eci_m(self.jd0 + t / 86400.0))
        to_sun = r_sun - x.r_eci
        distance = jnp.linalg.norm(to_sun, axis=0)
        s_eci = to_sun / distance
        pressure = self.pressure_1au_n_m2 * (self.au_m / distance) ** 2 * sunlit(x.r_eci, s_eci, 0)
        torque = facet_srp_torque_b(
            quat_rotate_inverse(x.q_bi, s_eci, 0), pressure, self.normals_b, self.areas_m2, self.centres_b_m, self.specular, self.diffuse
        )
        return {"torque_b": torque}

    def record(self, t, x, state):
        return {"solar_pressure_torque": self.wrench(t, x, state)["torque_b"]}

    def output_specs(self):
        return {
            "solar_pressure_torque": OutputSpec(("component",), "N m", "body", "solar radiation pressure torque at the sample")
        }


@part()
class ResidualDipoleTorque(Stateless):
    """Torque of a residual magnetic dipole ``m`` in the Earth's field, ``L = m × B``.

    Attributes
    ----------
    dipole_b_am2 : (3, 1)
        Residual dipole, body axes, A·m² (the same on every spacecraft).
    earth : EarthOrientation
        The Earth's orientation over the run (the field turns with the Earth).
    """

    dipole_b_am2: jnp.ndarray
    earth: EarthOrientation

    def wrench(self, t, x, state):
        b_b = quat_rotate_inverse(x.q_bi, dipole_field_gcrf(x.r_eci, t, self.earth, 0), 0)
        return {"torque_b": cross(jnp.broadcast_to(self.dipole_b_am2, b_b.shape), b_b, 0)}

    def record(self, t, x, state):
        return {"residual_dipole_torque": self.wrench(t, x, state)["torque_b"]}

    def output_specs(self):
        return {
            "residual_dipole_torque": OutputSpec(("component",), "N m", "body", "torque of the residual magnetic dipole at the sample")
        }
