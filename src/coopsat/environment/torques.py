"""Disturbance torques: gravity gradient, and a seeded random torque.

Disturbance parts (docs/architecture.md §4): ``init(n) -> state``; ``update(t, x, state, key)
-> state`` once per control period (draws of random terms); ``wrench(t, x, state) -> dict``
evaluated at every integration stage, so a torque that depends on the state (gravity
gradient) is exact to the integrator's order; ``record(t, x, state) -> dict`` what the run
records at a sample. Arrays are component-major, (3, n).
"""


import jax.numpy as jnp

from coopsat.core.parts import OutputSpec, part, per_spacecraft_normal
from coopsat.dynamics.rigid_body import matvec3
from coopsat.geometry.quaternion import cross, dot, quat_conjugate, quat_rotate


def gravity_gradient_torque_b(q_bi, r_eci_m, inertia_kgm2, mu_m3_s2, axis=-1):
    """Gravity-gradient torque ``L = 3 μ / r³ · r̂_B × (I r̂_B)``, N·m, body axes.

    Parameters
    ----------
    q_bi : (..., 4)
        Attitude, body to inertial.
    r_eci_m : (..., 3)
        Position of the centre of mass relative to the central body, m.
    inertia_kgm2 : (..., 3, 3) or principal moments with the shape of ``r_eci_m``
        See :func:`coopsat.dynamics.rigid_body.matvec3`.
    mu_m3_s2 : scalar
    axis : int
        Component axis.

    Returns
    -------
    jax.Array, (..., 3)

    Notes
    -----
    The first term of the torque of a point-mass field on an extended body (e.g. Schaub &
    Junkins, *Analytical Mechanics of Space Systems*, §4.5.1); Basilisk's
    ``GravityGradientEffector`` computes the same.
    """
    r2 = dot(r_eci_m, r_eci_m, axis, keepdims=True)
    r_hat_b = quat_rotate(quat_conjugate(q_bi, axis), r_eci_m / jnp.sqrt(r2), axis)
    return 3.0 * mu_m3_s2 / (r2 * jnp.sqrt(r2)) * cross(r_hat_b, matvec3(inertia_kgm2, r_hat_b, axis), axis)


class Stateless:
    """Base of a disturbance part without state: ``init`` gives none (``()``) and ``update``
    keeps it, so the part defines only ``wrench``, ``record`` and ``output_specs``."""

    def init(self, n):
        return ()

    def update(self, t, x, state, key):
        return state


@part()
class GravityGradient(Stateless):
    """Gravity-gradient torque part (needs an orbit).

    Attributes
    ----------
    inertia_kgm2 : (3, n) principal moments or (3, 3, n) full, component-major
    mu_m3_s2 : scalar
    """

    inertia_kgm2: jnp.ndarray
    mu_m3_s2: jnp.ndarray

    def wrench(self, t, x, state):
        return {"torque_b": gravity_gradient_torque_b(x.q_bi, x.r_eci, self.inertia_kgm2, self.mu_m3_s2, 0)}

    def record(self, t, x, state):
        return {"gravity_gradient_torque": self.wrench(t, x, state)["torque_b"]}

    def output_specs(self):
        return {"gravity_gradient_torque": OutputSpec(("component",), "N m", "body", "gravity-gradient torque at the sample")}


@part()
class RandomTorque:
    """A random body torque, constant over each control period and drawn anew every period
    from a normal distribution (zero mean, ``sigma_nm`` per body axis), from the run's seed.

    Attributes
    ----------
    sigma_nm : (3, 1)
        Standard deviation per body axis, N·m.
    """

    sigma_nm: jnp.ndarray

    def init(self, n):
        return jnp.zeros((3, n))

    def update(self, t, x, state, key):
        """Draw this period's torque; each spacecraft has its own stream (``fold_in``)."""
        return self.sigma_nm * per_spacecraft_normal(key, 3, state.shape[-1])

    def wrench(self, t, x, state):
        return {"torque_b": state}

    def record(self, t, x, state):
        return {"random_torque": state}

    def output_specs(self):
        return {
            "random_torque": OutputSpec(
                ("component",), "N m", "body", "random disturbance torque over the control period starting at the sample"
            )
        }
