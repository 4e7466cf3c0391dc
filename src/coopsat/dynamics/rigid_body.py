"""Rigid-body rotational dynamics with optional wheel momentum.

``I ω̇ + ω × (I ω + h_w) = τ`` in the body frame (SPEC §0: the 2010 paper's eq. (2) drops the
I in front of ω̇, a typo). ``h_w`` is the wheels' angular momentum in body components; with no
wheels it is zero.
"""


import jax.numpy as jnp

from coopsat.geometry.quaternion import cross, dot


def matvec3(m, v, axis=-1):
    """``m @ v`` for stacks of 3×3 matrices, or elementwise for principal (diagonal) moments.

    Parameters
    ----------
    m : array_like
        Full matrices, shape (..., 3, 3) (``axis=-1``) or (3, 3, ...) (``axis=0``); or the
        diagonal only, with the shape of ``v``. One matrix per vector: the two forms are told
        apart by rank, so a single matrix shared by a stack of vectors must be broadcast first.
    v : array_like, shape (..., 3) or (3, ...)
    axis : {-1, 0}
        Component axis of ``v``.

    Returns
    -------
    jax.Array, shape of ``v``

    Notes
    -----
    Written as a broadcast product and a sum, not ``@``, so that XLA fuses it with the
    surrounding elementwise code.
    """
    if jnp.ndim(m) == jnp.ndim(v):
        return m * v
    if axis == 0:
        return jnp.sum(m * v[None], axis=1)
    return jnp.sum(m * v[..., None, :], axis=-1)


def omega_dot_b(omega_b, torque_b_nm, inertia_kgm2, inertia_inv, h_wheels_b_nms, axis=-1):
    """Angular acceleration of the body, rad/s².

    Parameters
    ----------
    omega_b : array_like, shape (..., 3)
        Body rate relative to inertial, body components, rad/s.
    torque_b_nm : array_like, shape (..., 3)
        External plus control torque on the body (wheel reaction excluded), N·m.
    inertia_kgm2, inertia_inv : array_like
        Inertia about the centre of mass (body frame), kg·m², and its inverse: (..., 3, 3), or
        principal moments and their reciprocals with the shape of ``omega_b`` (see
        :func:`matvec3`).
    h_wheels_b_nms : array_like, shape (..., 3)
        Wheel angular momentum relative to the body, body components, N·m·s.
    axis : {-1, 0}
        Component axis.

    Returns
    -------
    jax.Array, shape (..., 3)

    Notes
    -----
    Euler's equation, SPEC §0; 2010 consensus paper eq. (2) with the inertia restored.
    """
    h_total = matvec3(inertia_kgm2, omega_b, axis) + h_wheels_b_nms
    return matvec3(inertia_inv, torque_b_nm - cross(omega_b, h_total, axis), axis)


def rotational_energy_j(omega_b, inertia_kgm2, axis=-1):
    """Rotational kinetic energy ``½ ωᵀ I ω``, J; shapes (..., 3), (..., 3, 3) -> (...)."""
    return 0.5 * dot(omega_b, matvec3(inertia_kgm2, omega_b, axis), axis)
