"""Clohessy–Wiltshire relative motion in closed form, traceable by JAX (SPEC §2).

Frame (one definition, :mod:`coopsat.geometry.frames`): the chief's LVLH axes with x
along-track, y along the negative orbit normal, z toward the Earth's centre. State
``[x, y, z, ẋ, ẏ, ż]`` (m, m/s), chief on a circular orbit of mean motion n:

    ẍ − 2n ż = f_x,     ÿ + n² y = f_y,     z̈ + 2n ẋ − 3n² z = f_z.

Everything here is pure ``jax.numpy`` (no ``float()`` casts), so the closed loop can call it
inside its jitted scan, ``vmap`` it and differentiate it. :mod:`coopsat.design.cw` reuses these
functions for its numpy design work.
"""


import jax.numpy as jnp
import numpy as np

#: From the classical Hill frame (x_H radial out, y_H along-track, z_H orbit normal) to ours,
#: as an index and a sign per state component: x = y_H, y = −z_H, z = −x_H (velocities alike).
_HILL_INDEX = np.array([1, 2, 0, 4, 5, 3])
_HILL_SIGN = np.array([1.0, -1.0, -1.0, 1.0, -1.0, -1.0])


def cw_matrices(n_rad_s):
    """State and input matrices of the CW equations in our LVLH axes.

    Parameters
    ----------
    n_rad_s : float or scalar jax.Array
        Mean motion of the chief's circular orbit, rad/s.

    Returns
    -------
    a : jax.Array (6, 6)
        ``ẋ = a x + b f``; entries in 1/s and 1/s².
    b : jax.Array (6, 3)
        Input: specific force ``f``, m/s².
    """
    n = jnp.asarray(n_rad_s, dtype=float)
    a = (
        jnp.zeros((6, 6))
        .at[:3, 3:].set(jnp.eye(3))
        .at[3, 5].set(2.0 * n)  # ẍ = 2n ż
        .at[4, 1].set(-n * n)  # ÿ = −n² y
        .at[5, 3].set(-2.0 * n)  # z̈ = −2n ẋ + 3n² z
        .at[5, 2].set(3.0 * n * n)
    )
    b = jnp.concatenate([jnp.zeros((3, 3)), jnp.eye(3)])
    return a, b


def cw_stm(n_rad_s, t_s):
    """Closed-form state-transition matrix Φ(t) of the unforced CW equations, our LVLH axes.

    Parameters
    ----------
    n_rad_s : float or array_like
        Mean motion, rad/s; broadcast against ``t_s``.
    t_s : float or array_like (...)
        Elapsed time, s.

    Returns
    -------
    jax.Array (..., 6, 6)
        ``x(t) = Φ(t) x(0)``; blocks Φrr (1), Φrv (s), Φvr (1/s), Φvv (1).

    Notes
    -----
    The classical Hill-frame solution (Vallado, *Fundamentals of Astrodynamics and
    Applications*, 4th ed., §6.8, eq. 6-66), rotated into our axes by the fixed permutation
    with signs ``x = y_H, y = −z_H, z = −x_H``. The permutation is applied by indexing, so it
    is exact and costs no matrix products inside the loop.
    """
    n, t = jnp.broadcast_arrays(jnp.asarray(n_rad_s, dtype=float), jnp.asarray(t_s, dtype=float))
    nt = n * t
    s, c = jnp.sin(nt), jnp.cos(nt)
    zero, one = jnp.zeros_like(nt), jnp.ones_like(nt)
    # Hill frame: [x_H, y_H, z_H, ẋ_H, ẏ_H, ż_H].
    rows = [
        [4 - 3 * c, zero, zero, s / n, 2 * (1 - c) / n, zero],
        [6 * (s - nt), one, zero, -2 * (1 - c) / n, (4 * s - 3 * nt) / n, zero],
        [zero, zero, c, zero, zero, s / n],
        [3 * n * s, zero, zero, c, 2 * s, zero],
        [-6 * n * (1 - c), zero, zero, -2 * s, 4 * c - 3, zero],
        [zero, zero, -n * s, zero, zero, c],
    ]
    phi_h = jnp.stack([jnp.stack(row, axis=-1) for row in rows], axis=-2)
    return _HILL_SIGN[:, None] * _HILL_SIGN * phi_h[..., _HILL_INDEX[:, None], _HILL_INDEX]


def cw_two_impulse(x0, xf, n_rad_s, tof_s):
    """Two-impulse CW transfer from state ``x0`` to state ``xf`` in time ``tof_s``.

    Parameters
    ----------
    x0, xf : array_like (..., 6)
        Initial and final relative states ``[x, y, z, ẋ, ẏ, ż]``, m and m/s, our LVLH axes.
    n_rad_s : float
        Mean motion, rad/s.
    tof_s : float or array_like (...)
        Time of flight, s; broadcast against the states' leading dimensions.

    Returns
    -------
    dv1 : jax.Array (..., 3)
        Velocity change at the start, m/s: puts the spacecraft on the arc reaching ``xf``'s
        position after ``tof_s``.
    dv2 : jax.Array (..., 3)
        Velocity change on arrival, m/s: matches ``xf``'s velocity.

    Notes
    -----
    With the blocks of Φ(tof) (:func:`cw_stm`): ``r_f = Φrr r0 + Φrv v0⁺`` gives
    ``v0⁺ = Φrv⁻¹ (r_f − Φrr r0)``; then ``v_f⁻ = Φvr r0 + Φvv v0⁺``, ``dv1 = v0⁺ − v0`` and
    ``dv2 = v_f − v_f⁻``.

    Φrv is singular, and ill-conditioned near, where its determinant
    ``sin(nτ)·2 sin(nτ/2)·(8 sin(nτ/2) − 3nτ cos(nτ/2)) / n³`` vanishes:

    - out of plane, every half orbit, ``nτ = kπ`` (y after half an orbit is −y0 whatever ẏ0);
    - in plane, every whole orbit, ``nτ = 2πk``, and where ``tan(nτ/2) = 3nτ/8``, first at
      ``nτ ≈ 8.839 rad`` (1.41 orbits), then about once an orbit (15.36, 21.75 rad, …).

    The transfer therefore needs ``0 < n·tof < π`` (less than half an orbit) or a window
    chosen clear of those roots. Nothing is raised inside the compiled loop: near a root the
    impulses grow without bound, and exactly on one the solve returns inf or nan.
    """
    x0, xf = jnp.asarray(x0, dtype=float), jnp.asarray(xf, dtype=float)
    phi = cw_stm(n_rad_s, tof_s)
    batch = jnp.broadcast_shapes(phi.shape[:-2], x0.shape[:-1], xf.shape[:-1])
    phi = jnp.broadcast_to(phi, batch + (6, 6))
    x0, xf = jnp.broadcast_to(x0, batch + (6,)), jnp.broadcast_to(xf, batch + (6,))
    r0, v0, rf, vf = x0[..., :3], x0[..., 3:], xf[..., :3], xf[..., 3:]
    phi_rr, phi_rv = phi[..., :3, :3], phi[..., :3, 3:]
    phi_vr, phi_vv = phi[..., 3:, :3], phi[..., 3:, 3:]
    # Solve with an explicit trailing axis: a stacked right-hand side is then never read as a
    # matrix, whatever the batch shape.
    rhs = rf - jnp.einsum("...ij,...j->...i", phi_rr, r0)
    v0_plus = jnp.linalg.solve(phi_rv, rhs[..., None])[..., 0]
    vf_minus = jnp.einsum("...ij,...j->...i", phi_vr, r0) + jnp.einsum("...ij,...j->...i", phi_vv, v0_plus)
    return v0_plus - v0, vf - vf_minus


def transfer_impulse_l1(x0, xf, n_rad_s, tof_s, mass_kg):
    """Total impulse of the two-impulse transfer, summed per LVLH axis, N·s.

    Parameters
    ----------
    x0, xf : array_like (..., 6)
        Initial and final relative states, m and m/s.
    n_rad_s : float
        Mean motion, rad/s.
    tof_s : float or array_like (...)
        Time of flight, s (see :func:`cw_two_impulse` for the windows to avoid).
    mass_kg : float or array_like (...)
        Spacecraft mass, kg.

    Returns
    -------
    jax.Array (...)
        ``mass · (‖dv1‖₁ + ‖dv2‖₁)``: the L1 norm because the thrusters fire along each LVLH
        axis separately, so an impulse's cost is the sum of its axis components.
    """
    dv1, dv2 = cw_two_impulse(x0, xf, n_rad_s, tof_s)
    return mass_kg * (jnp.sum(jnp.abs(dv1), axis=-1) + jnp.sum(jnp.abs(dv2), axis=-1))


_HALF_SQRT3 = 0.8660254037844386

PLANE_AXES_LVLH = np.array([[1.0, 0.0, 0.0], [0.0, _HALF_SQRT3, 0.5], [0.0, -0.5, _HALF_SQRT3]])
"""Columns ``e1, e2, e3``: the relative circle's plane (``e1 = x̂``, ``e2 = (0, √3/2, −1/2)``)
and its normal ``e3 = e1 × e2``, LVLH components; the circle turns at ``ω = n e3``."""


def cartwheel_state(rho_m, n_rad_s, t_s, phase_rad):
    """State on the SPEC §2 relative circle ("cartwheel"), ``[x, y, z, ẋ, ẏ, ż]`` (m, m/s), LVLH.

    Parameters
    ----------
    rho_m, n_rad_s : scalar
    t_s : scalar or array
    phase_rad : scalar or array (broadcast with ``t_s``)

    Returns
    -------
    jax.Array (..., 6)
        ``x = ρ cos θ``, ``y = (√3/2) ρ sin θ``, ``z = −(ρ/2) sin θ``, ``θ = n t + φ`` (SPEC §2):
        an exact, bounded solution of the unforced CW equations with ``|r| = ρ``, in the plane
        tilted 30° from the local horizontal.
    """
    theta = n_rad_s * jnp.asarray(t_s) + jnp.asarray(phase_rad)
    s, c = jnp.sin(theta), jnp.cos(theta)
    pos = rho_m * jnp.stack([c, _HALF_SQRT3 * s, -0.5 * s], axis=-1)
    vel = rho_m * n_rad_s * jnp.stack([-s, _HALF_SQRT3 * c, -0.5 * c], axis=-1)
    return jnp.concatenate([pos, vel], axis=-1)
