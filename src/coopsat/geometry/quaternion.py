"""Quaternion algebra, vectorised over leading axes.

Convention (SPEC §0, docs/conventions.md): scalar-first ``q = [q0, q1, q2, q3]``, Hamilton
product, and ``q_bi`` takes body-frame components to inertial-frame components,
``v_i = q_bi ⊗ [0, v_b] ⊗ q_bi*``. Kinematics ``q̇ = ½ q ⊗ [0, ω_b]`` is the Ω(ω) matrix of the
2010 consensus paper, eq. (1). The error (relative) quaternion of i with respect to j is
``q_j* ⊗ q_i`` (the paper's H(q_j * q_i) is its vector part).

Every function takes arrays of shape ``(..., 4)`` (and ``(..., 3)`` for vectors) and works on
NumPy and JAX arrays alike: NumPy inputs are computed by NumPy and give NumPy arrays (the
analysis of a finished run: JAX would dispatch, and compile once per shape, every operation),
any JAX array or tracer makes it JAX (the compiled loop, gradients). The algebra functions also take ``axis``, the position of the
component axis: the compiled loop keeps its arrays component-major, ``(4, n)`` and ``(3, n)``
(``axis=0``), so that each component is a contiguous row and XLA vectorises the arithmetic over
spacecraft (measured twice as fast as ``(n, 4)`` on the CPU; see docs/architecture.md).
"""


import jax
import jax.numpy as jnp
import numpy as np


def array_namespace(*arrays):
    """``jax.numpy`` when any of ``arrays`` is a JAX array or tracer, else ``numpy``."""
    return jnp if any(isinstance(a, jax.Array) for a in arrays) else np


def split(x, axis=-1):
    """Components of ``x`` along ``axis`` as a tuple of arrays (views, no copy)."""
    x = x if isinstance(x, jax.Array) else np.asarray(x)
    return tuple(array_namespace(x).moveaxis(x, axis, 0)) if axis not in (0, -x.ndim) else tuple(x)


def join(parts, axis=-1):
    """Inverse of :func:`split`: stack components along ``axis``."""
    return array_namespace(*parts).stack(parts, axis=axis)


def cross(a, b, axis=-1):
    """Cross product of 3-vectors along ``axis``, written per component (fuses under XLA)."""
    a1, a2, a3 = split(a, axis)
    b1, b2, b3 = split(b, axis)
    return join([a2 * b3 - a3 * b2, a3 * b1 - a1 * b3, a1 * b2 - a2 * b1], axis)


def dot(a, b, axis=-1, keepdims=False):
    """Sum of the product of ``a`` and ``b`` along ``axis``."""
    xp = array_namespace(a, b)
    return xp.sum(a * b, axis=axis, keepdims=keepdims)


def quat_multiply(p, q, axis=-1):
    """Hamilton product ``p ⊗ q``.

    Parameters
    ----------
    p, q : array_like, shape (..., 4)
        Scalar-first quaternions; other axes broadcast.
    axis : int
        Component axis.

    Returns
    -------
    jax.Array, shape (..., 4)

    Notes
    -----
    The matrix form is the one printed in the 2010 consensus paper (§1.1).
    """
    p0, p1, p2, p3 = split(p, axis)
    q0, q1, q2, q3 = split(q, axis)
    return join(
        [
            p0 * q0 - p1 * q1 - p2 * q2 - p3 * q3,
            p0 * q1 + p1 * q0 + p2 * q3 - p3 * q2,
            p0 * q2 - p1 * q3 + p2 * q0 + p3 * q1,
            p0 * q3 + p1 * q2 - p2 * q1 + p3 * q0,
        ],
        axis,
    )


def quat_conjugate(q, axis=-1):
    """Conjugate ``q* = [q0, −q1, −q2, −q3]`` (the inverse of a unit quaternion), shape (..., 4)."""
    q0, q1, q2, q3 = split(q, axis)
    return join([q0, -q1, -q2, -q3], axis)


def quat_normalize(q, axis=-1):
    """Scale to unit norm, shape (..., 4). A zero quaternion gives NaN: validate input first."""
    xp = array_namespace(q)
    # Written per component rather than as a reduction, so that XLA fuses it with the step
    # that produced q (one kernel instead of a reduction and a broadcast).
    q0, q1, q2, q3 = split(q, axis)
    return q / xp.sqrt(xp.expand_dims(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3, axis))


def quat_positive(q, axis=-1):
    """Flip sign to the ``q0 ≥ 0`` hemisphere (same rotation, short way round), shape (..., 4)."""
    xp = array_namespace(q)
    return xp.where(xp.expand_dims(split(q, axis)[0], axis) < 0.0, -q, q)


def quat_error(q_i, q_j, axis=-1):
    """Error quaternion of i with respect to j, ``q_j* ⊗ q_i``, shape (..., 4).

    Notes
    -----
    The argument of H(·) in laws (3) and (4) of the 2010 consensus paper.
    """
    return quat_multiply(quat_conjugate(q_j, axis), q_i, axis)


def quat_vector(q, axis=-1):
    """Vector part ``H(q) = [q1, q2, q3]``, shape (..., 4) -> (..., 3)."""
    return join(split(q, axis)[1:], axis)


def quat_rotate(q, v, axis=-1):
    """Rotate vectors: ``q ⊗ [0, v] ⊗ q*`` for unit ``q``.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Unit quaternion ``q_ab`` (takes frame-b components to frame-a components).
    v : array_like, shape (..., 3)
        Vector components in frame b.
    axis : int
        Component axis.

    Returns
    -------
    jax.Array, shape (..., 3)
        The same vector's components in frame a.
    """
    xp = array_namespace(q, v)
    s = xp.expand_dims(split(q, axis)[0], axis)
    u = quat_vector(q, axis)
    t = 2.0 * cross(u, v, axis)
    return v + s * t + cross(u, t, axis)


def quat_rotate_inverse(q, v, axis=-1):
    """Components in frame b of a vector given in frame a: ``q* ⊗ [0, v] ⊗ q`` for unit
    ``q = q_ab`` (e.g. an inertial vector in body axes from ``q_bi``); shapes as
    :func:`quat_rotate`."""
    return quat_rotate(quat_conjugate(q, axis), v, axis)


def quat_to_dcm(q):
    """Direction-cosine matrix ``C_ab`` of a unit ``q_ab``: ``v_a = C_ab @ v_b``.

    Parameters
    ----------
    q : array_like, shape (..., 4)

    Returns
    -------
    jax.Array, shape (..., 3, 3)
    """
    xp = array_namespace(q)
    q0, q1, q2, q3 = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    rows = [
        [1 - 2 * (q2 * q2 + q3 * q3), 2 * (q1 * q2 - q0 * q3), 2 * (q1 * q3 + q0 * q2)],
        [2 * (q1 * q2 + q0 * q3), 1 - 2 * (q1 * q1 + q3 * q3), 2 * (q2 * q3 - q0 * q1)],
        [2 * (q1 * q3 - q0 * q2), 2 * (q2 * q3 + q0 * q1), 1 - 2 * (q1 * q1 + q2 * q2)],
    ]
    return xp.stack([xp.stack(r, axis=-1) for r in rows], axis=-2)


def dcm_to_quat(c):
    """Unit quaternion (``q0 ≥ 0``) of a rotation matrix ``C_ab``, shape (..., 3, 3) -> (..., 4).

    Notes
    -----
    Shepperd's method: take the largest of the four squared components so that the division
    is always well conditioned. All four candidates are computed and the best one selected,
    which keeps the function branch-free (traceable, vectorised).
    """
    xp = array_namespace(c)
    tr = xp.trace(c, axis1=-2, axis2=-1)
    d0, d1, d2 = c[..., 0, 0], c[..., 1, 1], c[..., 2, 2]
    cand = xp.stack(
        [
            xp.stack(
                [1 + tr, c[..., 2, 1] - c[..., 1, 2], c[..., 0, 2] - c[..., 2, 0], c[..., 1, 0] - c[..., 0, 1]],
                axis=-1,
            ),
            xp.stack(
                [c[..., 2, 1] - c[..., 1, 2], 1 + 2 * d0 - tr, c[..., 0, 1] + c[..., 1, 0], c[..., 0, 2] + c[..., 2, 0]],
                axis=-1,
            ),
            xp.stack(
                [c[..., 0, 2] - c[..., 2, 0], c[..., 0, 1] + c[..., 1, 0], 1 + 2 * d1 - tr, c[..., 1, 2] + c[..., 2, 1]],
                axis=-1,
            ),
            xp.stack(
                [c[..., 1, 0] - c[..., 0, 1], c[..., 0, 2] + c[..., 2, 0], c[..., 1, 2] + c[..., 2, 1], 1 + 2 * d2 - tr],
                axis=-1,
            ),
        ],
        axis=-2,
    )
    best = xp.argmax(xp.stack([tr, d0, d1, d2], axis=-1), axis=-1)
    q = xp.take_along_axis(cand, best[..., None, None], axis=-2)[..., 0, :]
    return quat_positive(quat_normalize(q))


def quat_angle(q, axis=-1):
    """Principal rotation angle in [0, π] rad of a unit quaternion, shape (..., 4) -> (...)
    (``axis``: the component axis, removed).

    Notes
    -----
    ``2 atan2(|vec q|, |q0|)`` is accurate near 0 and π, unlike ``2 acos(q0)``.
    """
    xp = array_namespace(q)
    q = xp.moveaxis(q, axis, -1)
    return 2.0 * xp.arctan2(xp.linalg.norm(q[..., 1:], axis=-1), xp.abs(q[..., 0]))


def quat_from_axis_angle(axis, angle_rad):
    """Unit quaternion rotating by ``angle_rad`` about the unit ``axis``.

    Parameters
    ----------
    axis : array_like, shape (..., 3)
        Unit rotation axis.
    angle_rad : array_like, shape (...)

    Returns
    -------
    jax.Array, shape (..., 4)
    """
    xp = array_namespace(axis, angle_rad)
    half = 0.5 * xp.asarray(angle_rad)[..., None]
    return xp.concatenate([xp.cos(half), xp.sin(half) * axis], axis=-1)


def quat_exp_rate(omega_b, t_s):
    """Rotation accumulated by a constant body rate over ``t_s``: ``exp(½ [0, ω] t)``.

    Parameters
    ----------
    omega_b : array_like, shape (..., 3)
        Constant body-frame rate, rad/s.
    t_s : array_like, shape (...)
        Elapsed time, s.

    Returns
    -------
    jax.Array, shape (..., 4)
        ``q(t) = q(0) ⊗ quat_exp_rate(ω, t)`` solves ``q̇ = ½ q ⊗ [0, ω]`` exactly.
    """
    xp = array_namespace(omega_b, t_s)
    t = xp.asarray(t_s)[..., None]
    rate2 = xp.sum(omega_b * omega_b, axis=-1, keepdims=True)
    # |ω| with a finite derivative at ω = 0 (the plain norm's is NaN there).
    rate = xp.where(rate2 > 0.0, xp.sqrt(xp.where(rate2 > 0.0, rate2, 1.0)), 0.0)
    half = 0.5 * rate * t
    # sin(½|ω|t)/|ω| written with sinc so that ω = 0 is exact and differentiable.
    sin_over_rate = 0.5 * t * xp.sinc(half / xp.pi)
    return xp.concatenate([xp.cos(half), sin_over_rate * omega_b], axis=-1)


def quat_kinematics(q, omega_b, axis=-1):
    """Attitude kinematics ``q̇ = ½ q ⊗ [0, ω_b]``, shapes (..., 4), (..., 3) -> (..., 4).

    Notes
    -----
    2010 consensus paper, eq. (1): ``q̇ = ½ Ω(ω) q``.
    """
    q0, q1, q2, q3 = split(q, axis)
    wx, wy, wz = split(omega_b, axis)
    return join(
        [
            -0.5 * (q1 * wx + q2 * wy + q3 * wz),
            0.5 * (q0 * wx - q3 * wy + q2 * wz),
            0.5 * (q3 * wx + q0 * wy - q1 * wz),
            0.5 * (-q2 * wx + q1 * wy + q0 * wz),
        ],
        axis,
    )
