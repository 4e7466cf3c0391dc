"""The chief's LVLH (Hill) frame: the one place its axes are defined (SPEC §0, §2).

Axes, from the chief's inertial position ``r`` and velocity ``v`` (ECI) and ``h = r × v``:

* ``z`` toward the Earth's centre (nadir): ``ẑ = −r/|r|``;
* ``y`` along the negative orbit normal: ``ŷ = −h/|h|``;
* ``x = ŷ × ẑ`` completes the right-handed triad; it is the transverse (along-track) direction,
  along ``v`` on a circular orbit.

In these axes the Clohessy–Wiltshire equations read ``ẍ − 2n ż = f_x``, ``ÿ + n² y = f_y``,
``z̈ + 2n ẋ − 3n² z = f_z`` (SPEC §2).

Relative velocities are taken as seen in the rotating frame. The frame turns with angular
velocity ``ω = h/|r|²`` (about the orbit normal), which assumes the chief's acceleration is
central (Keplerian, ``h`` constant). An out-of-plane perturbing acceleration ``a_h`` of the chief
(J2, drag) also turns the frame about ``r̂`` at ``|r| a_h/|h|``; it is neglected here: for J2 at
500 km that is about 2e-6 rad/s against n ≈ 1.1e-3 rad/s, i.e. a velocity error of about
2e-6 m/s per metre of separation.

Vectors are ``(..., 3)`` by default; ``axis=0`` takes the component-major ``(3, n)`` layout of
the compiled loop. Chief and deputy arrays broadcast against each other with the component
axis aligned (a single chief against ``(3, n)`` deputies is ``(3, 1)``). A chief with ``r ∥ v``
(``h = 0``) has no orbit plane and gives NaN.
"""


from coopsat.geometry.quaternion import array_namespace, cross, dot, join, split


def _unit(x, axis):
    return x / array_namespace(x).sqrt(dot(x, x, axis, keepdims=True))


def _lvlh_axes(r_eci, v_eci, axis):
    """Unit vectors ``(x̂, ŷ, ẑ)`` of the LVLH frame, ECI components, each shaped like ``r_eci``."""
    z_hat = -_unit(r_eci, axis)
    y_hat = -_unit(cross(r_eci, v_eci, axis), axis)
    return cross(y_hat, z_hat, axis), y_hat, z_hat


def _frame_rate_eci(r_eci, v_eci, axis):
    """Angular velocity of the LVLH frame, ``(r × v)/|r|²``, ECI components, rad/s."""
    return cross(r_eci, v_eci, axis) / dot(r_eci, r_eci, axis, keepdims=True)


def _to_lvlh(axes, vec_eci, axis):
    return join([dot(a, vec_eci, axis) for a in axes], axis)


def _to_eci(axes, vec_lvlh, axis):
    x_hat, y_hat, z_hat = axes
    c_x, c_y, c_z = (array_namespace(c).expand_dims(c, axis) for c in split(vec_lvlh, axis))
    return c_x * x_hat + c_y * y_hat + c_z * z_hat


def lvlh_dcm(r_eci, v_eci, axis=-1):
    """Direction-cosine matrix ``C_lvlh_eci``: ``vec_lvlh = C_lvlh_eci @ vec_eci``.

    Parameters
    ----------
    r_eci, v_eci : array_like, shape (..., 3) or (3, ...) with ``axis=0``
        Chief position, m, and velocity, m/s, ECI.
    axis : {-1, 0}
        Component axis of the inputs.

    Returns
    -------
    jax.Array
        ``axis=-1``: shape (..., 3, 3), ``C[..., i, j]``; ``axis=0``: shape (3, 3, ...),
        ``C[i, j, ...]``. Row ``i`` is LVLH axis ``i`` (x, y, z) in ECI components.
    """
    axes = _lvlh_axes(r_eci, v_eci, axis)
    return array_namespace(*axes).stack(axes, axis=axis - 1 if axis < 0 else axis)


def eci_to_lvlh(r_chief_eci, v_chief_eci, r_eci, v_eci, axis=-1):
    """Relative position and velocity of a deputy in the chief's LVLH frame.

    Parameters
    ----------
    r_chief_eci, v_chief_eci : array_like, shape (..., 3)
        Chief position, m, and velocity, m/s, ECI.
    r_eci, v_eci : array_like, shape (..., 3)
        Deputy position, m, and velocity, m/s, ECI.
    axis : int
        Component axis.

    Returns
    -------
    rho_lvlh : jax.Array, shape (..., 3)
        ``C_lvlh_eci (r − r_chief)``, m.
    rho_dot_lvlh : jax.Array, shape (..., 3)
        Time derivative of ``rho_lvlh`` as seen in the rotating frame,
        ``C_lvlh_eci (v − v_chief − ω × (r − r_chief))``, m/s (transport theorem with the
        Keplerian frame rate ``ω``; see the module notes).
    """
    axes = _lvlh_axes(r_chief_eci, v_chief_eci, axis)
    dr_eci = r_eci - r_chief_eci
    dv_rot_eci = v_eci - v_chief_eci - cross(_frame_rate_eci(r_chief_eci, v_chief_eci, axis), dr_eci, axis)
    return _to_lvlh(axes, dr_eci, axis), _to_lvlh(axes, dv_rot_eci, axis)


def lvlh_to_eci(r_chief_eci, v_chief_eci, rho_lvlh, rho_dot_lvlh, axis=-1):
    """Inverse of :func:`eci_to_lvlh`: deputy position, m, and velocity, m/s, in ECI.

    Parameters
    ----------
    r_chief_eci, v_chief_eci : array_like, shape (..., 3)
        Chief position, m, and velocity, m/s, ECI.
    rho_lvlh, rho_dot_lvlh : array_like, shape (..., 3)
        Relative position, m, and rotating-frame relative velocity, m/s, LVLH.
    axis : int
        Component axis.

    Returns
    -------
    r_eci, v_eci : jax.Array, shape (..., 3)
    """
    axes = _lvlh_axes(r_chief_eci, v_chief_eci, axis)
    dr_eci = _to_eci(axes, rho_lvlh, axis)
    dv_eci = _to_eci(axes, rho_dot_lvlh, axis) + cross(_frame_rate_eci(r_chief_eci, v_chief_eci, axis), dr_eci, axis)
    return r_chief_eci + dr_eci, v_chief_eci + dv_eci


def lvlh_vector_to_eci(r_chief_eci, v_chief_eci, vec_lvlh, axis=-1):
    """ECI components of a free vector (force, acceleration) given in the chief's LVLH frame.

    Parameters
    ----------
    r_chief_eci, v_chief_eci : array_like, shape (..., 3)
        Chief position, m, and velocity, m/s, ECI.
    vec_lvlh : array_like, shape (..., 3)
        Vector components in LVLH (any unit; returned in the same unit).
    axis : int
        Component axis.

    Returns
    -------
    jax.Array, shape (..., 3)
        ``C_lvlh_eciᵀ vec_lvlh``.
    """
    return _to_eci(_lvlh_axes(r_chief_eci, v_chief_eci, axis), vec_lvlh, axis)
