"""The truth plant: stacked spacecraft states and their time derivative.

One :class:`PlantState` holds every spacecraft of a run: each field ``(n, k)`` at the package's
interfaces, ``(k, n)`` (component-major, ``axis=0``) inside the compiled loop. Attitude is always
propagated; translation only when the scenario has an orbit (a static choice, made when the
closed loop is traced, so a rigid-body run pays nothing for it).
"""

from typing import NamedTuple


import jax.numpy as jnp

from coopsat.dynamics.rigid_body import matvec3, omega_dot_b
from coopsat.dynamics.translational import j2_accel, two_body_accel
from coopsat.geometry.frames import lvlh_vector_to_eci
from coopsat.geometry.quaternion import quat_kinematics, quat_rotate


class PlantState(NamedTuple):
    """State of n spacecraft.

    Attributes
    ----------
    q_bi : (n, 4)
        Attitude of body B relative to inertial I, scalar-first unit quaternion.
    omega_b : (n, 3)
        Body rate relative to inertial, body components, rad/s.
    h_wheels_b : (n, 3)
        Wheel angular momentum relative to the body, body components, N·m·s.
    r_eci : (n, 3)
        Position, m (zero and frozen when the run has no orbit).
    v_eci : (n, 3)
        Velocity, m/s (likewise).
    angle_rad : (n, 3)
        Small attitude angles about the body axes, rad: the state of the small-angle attitude
        model (zero and frozen in the rigid-body model, where ``q_bi`` is the attitude).
    """

    q_bi: jnp.ndarray
    omega_b: jnp.ndarray
    h_wheels_b: jnp.ndarray
    r_eci: jnp.ndarray
    v_eci: jnp.ndarray
    angle_rad: jnp.ndarray


class PlantParams(NamedTuple):
    """Mass properties and force-model constants (arrays; traced, never static).

    Attributes
    ----------
    inertia_kgm2, inertia_inv : (n, 3, 3) or (n, 3)
        Full inertia and its inverse, kg·m²; or principal moments and their reciprocals when
        every spacecraft's inertia is diagonal (the cheaper path in the compiled loop).
    mu_m3_s2, j2, r_body_m : scalar
        Central body's gravitational parameter, J2 and equatorial radius.
    mass_kg : (n,)
        Spacecraft masses, kg (NaN where no force acts, so a forgotten mass cannot pass
        silently).
    chief : int scalar
        Index of the spacecraft whose LVLH frame LVLH-axis forces refer to.
    """

    inertia_kgm2: jnp.ndarray
    inertia_inv: jnp.ndarray
    mu_m3_s2: jnp.ndarray
    j2: jnp.ndarray
    r_body_m: jnp.ndarray
    mass_kg: jnp.ndarray
    chief: jnp.ndarray


WRENCH_CHANNELS = ("torque_b", "wheel_torque_b", "force_eci", "force_b", "force_lvlh", "accel_eci")
"""What actuators and disturbances may act through, each (3, n) (component-major in the loop):

* ``torque_b`` — external torque on the body (thrusters, magnetorquers, environment), N·m;
* ``wheel_torque_b`` — rate of change of the wheels' momentum, body components, N·m (the
  body feels its reaction);
* ``force_eci`` — force in ECI components, N;
* ``force_b`` — force in body components (body-fixed thrusters), N;
* ``force_lvlh`` — force in the axes of the chief's LVLH frame (``params.chief``;
  :mod:`coopsat.geometry.frames`), N: thrusters held aligned with the chief's LVLH axes by the
  attitude control (the formation-flying papers' assumption). It is turned into ECI inside the
  derivative with the chief's current position and velocity (each RK4 stage), so it follows
  the frame as it turns; the chief's own LVLH force is in its own frame;
* ``accel_eci`` — acceleration in ECI components, m/s²: gravity beyond the central body's point
  mass (harmonics, the Sun and the Moon), which acts whatever the mass.
"""

_FORCE_CHANNELS = ("force_eci", "force_b", "force_lvlh")


def _chief(a, chief, axis):
    """The chief's row of a per-spacecraft vector field, kept broadcastable against it:
    (3, n) -> (3, 1) component-major, (n, 3) -> (1, 3), and (3, B, n) -> (3, B, 1) for a batch
    of B runs (``chief`` then (B, 1)); for a batch's flat rows (3, B·n) ``chief`` is (B·n,), each
    spacecraft's chief's index in the row, and the result (3, B·n)
    (:func:`coopsat.sim.layout._flat_plant`)."""
    if jnp.ndim(chief) > 0:
        # A batch: one chief per run (B, 1) into (3, B, n), or per spacecraft (B·n,) into (3, B·n).
        return jnp.take_along_axis(a, chief[None], axis=-1)
    sc_axis = 1 if axis == 0 else 0
    return jnp.expand_dims(jnp.take(a, chief, axis=sc_axis), sc_axis)


STATE_QUANTITIES = {
    "q": ("q_bi", "attitude q"),
    "angle": ("angle_rad", "attitude angle"),
    "omega": ("omega_b", "rate omega"),
    "h_wheels": ("h_wheels_b", "wheel momentum"),
    "r_eci": ("r_eci", "position"),
    "v_eci": ("v_eci", "velocity"),
}
"""Named state quantities (what sensors read and runs record): the :class:`PlantState` field
of each and a short label for messages."""

DRIVEN_STATE = {"wheel_torque_b": "h_wheels"}
"""Wrench channels that drive a state of their own (integrated only when some part uses them)."""


def state_quantities(attitude, gravity, channels):
    """Names of the state quantities that evolve in a run, in a fixed order.

    Parameters
    ----------
    attitude : {"rigid-body", "small-angle"}
    gravity : {"none", "two-body", "j2"}
        "none" freezes position and velocity.
    channels : iterable of str
        Wrench channels the run's actuators use.

    Returns
    -------
    tuple of str
        Keys of :data:`STATE_QUANTITIES`.
    """
    names = ["angle" if attitude == "small-angle" else "q", "omega"]
    names += [DRIVEN_STATE[c] for c in sorted(set(channels)) if c in DRIVEN_STATE]
    return tuple(names + ([] if gravity == "none" else ["r_eci", "v_eci"]))


ATTITUDE_MODELS = ("rigid-body", "small-angle")
"""Attitude models: the full rigid body (quaternion, Euler's equation), or its small-angle
linearisation about rest, ``θ̇ = ω``, ``I ω̇ = τ`` (per axis a double integrator, the model of
the leader–follower delay paper, SPEC §3)."""


def plant_derivative(x, wrench, params, gravity, axis=-1, attitude="rigid-body"):
    """Time derivative of :class:`PlantState`.

    Parameters
    ----------
    x : PlantState
    wrench : dict of str -> array, each (n, 3)
        What acts on the bodies (actuators plus disturbances), by channel of
        :data:`WRENCH_CHANNELS`; an absent channel is zero (static: it costs nothing).
    params : PlantParams
    gravity : {"none", "two-body", "j2"}
        Static: "none" freezes position and velocity.
    axis : int
        Component axis of every field.
    attitude : {"rigid-body", "small-angle"}
        Static: the attitude model (:data:`ATTITUDE_MODELS`).

    Returns
    -------
    PlantState
        Derivatives.

    Notes
    -----
    ``I ω̇ + ω × (I ω + h_w) = τ − ḣ_w`` (SPEC §0): a wheel's motor torque spins the wheel
    up by ``ḣ_w`` and the body down by the same amount, so with no external torque the total
    ``I ω + h_w`` is conserved in inertial space. ``m r̈ = m g(r) + F``.
    """
    unknown = set(wrench) - set(WRENCH_CHANNELS)
    if unknown:
        raise KeyError(f"unknown wrench channels {sorted(unknown)} (known: {', '.join(WRENCH_CHANNELS)})")
    zeros3 = jnp.zeros_like(x.omega_b)
    torque = wrench.get("torque_b", zeros3)
    dh = wrench.get("wheel_torque_b", zeros3)
    if "wheel_torque_b" in wrench:
        torque = torque - dh
    if attitude == "small-angle":
        # Linearised about rest: no gyroscopic term, angles integrate the rates.
        dq, d_angle = jnp.zeros_like(x.q_bi), x.omega_b
        dw = matvec3(params.inertia_inv, torque, axis)
    else:
        dq, d_angle = quat_kinematics(x.q_bi, x.omega_b, axis), zeros3
        dw = omega_dot_b(x.omega_b, torque, params.inertia_kgm2, params.inertia_inv, x.h_wheels_b, axis)
    if gravity == "none":
        dr, dv = zeros3, zeros3
    else:
        dr = x.v_eci
        dv = two_body_accel(x.r_eci, params.mu_m3_s2, axis)
        if gravity == "j2":
            dv = dv + j2_accel(x.r_eci, params.mu_m3_s2, params.j2, params.r_body_m, axis)
        force = wrench.get("force_eci", zeros3)
        if "force_b" in wrench:
            force = force + quat_rotate(x.q_bi, wrench["force_b"], axis)
        if "force_lvlh" in wrench:
            r_c, v_c = _chief(x.r_eci, params.chief, axis), _chief(x.v_eci, params.chief, axis)
            force = force + lvlh_vector_to_eci(r_c, v_c, wrench["force_lvlh"], axis)
        if any(c in wrench for c in _FORCE_CHANNELS):
            dv = dv + force / params.mass_kg
        if "accel_eci" in wrench:
            dv = dv + wrench["accel_eci"]
    return PlantState(dq, dw, dh, dr, dv, d_angle)
