"""Cooperative Earth observation: two spacecraft stare at one ground target (SPEC §5).

Quaternions follow SPEC §0 (scalar first, ``q_bi`` takes body components to inertial ones). The
paper (Fang et al. 2019) writes them scalar-last and its errors as ``ΔQ = Q_d ⊗ Q⁻¹``; here the
attitude error of a spacecraft is the body relative to its desired frame, ``δq = q_d* ⊗ q``
(body components, ``q0 ≥ 0``), so the paper's ``ΔQ̄`` is ``vec(δq)`` up to the sign the
restoring term carries: every law below pushes ``vec(δq)`` to zero.

* Desired attitude (eqs. 1–2, 17–18): from the sun-pointing attitude ``Q_s`` (−y to the Sun,
  held inertial, eq. 3), the minimum rotation that puts +z on the line of sight ``ρ``. In
  ``Q_s`` axes ``p = ρ/|ρ|`` and the rotation is ``[1 + p_z, −p_y, p_x, 0]`` normalised: the
  paper's ``[cos δ/2, u sin δ/2]`` with ``δ = arccos p_z``, ``u = [−p_y, p_x, 0]/√(p_x² + p_y²)``,
  written without its 0/0 at ``p = ẑ``.
* Desired rate and acceleration: exact derivatives of that attitude along
  ``ρ(t + τ) = ρ + ρ̇ τ + ½ ρ̈ τ²`` (forward-mode JAX, twice), with ``ρ̈`` from the target's
  rotation with the Earth and the spacecraft's two-body acceleration (the paper's choice).
  ``ω_d = 2 vec(q_d* ⊗ q̇_d)``, ``ω̇_d = 2 vec(q_d* ⊗ q̈_d)`` (desired-frame components).
* Law (8), the reference and an independent follower:
  ``τ = I ω̇_d^b + ω_d^b × (I ω_d^b + h) − k1 vec(δq) − k2 (ω − ω_d^b)`` with
  ``ω_d^b = C(δq)ᵀ ω_d`` (the paper's ``A(ΔQ) ω_d``) and likewise ``ω̇_d^b``.
* Law (23), the cooperative follower: the same tracking structure on
  ``δq_fr = δq_r* ⊗ δq_f`` (the paper's ``ΔQ_f ⊗ ΔQ_r⁻¹``). Driving ``δq_fr`` to zero is
  tracking the frame ``T = q_fd ⊗ δq_r``: the follower's own desired attitude carrying the
  reference's current error, so that the target falls on the same image-plane point in both
  cameras (eqs. 15–16). T's rate and acceleration, in T axes, are
  ``ω_T = ω_r + C(δq_r)ᵀ(ω_fd − ω_rd)`` and
  ``ω̇_T = ω̇_r + C(δq_r)ᵀ(ω̇_fd − ω̇_rd) − ω_rel × C(δq_r)ᵀ(ω_fd − ω_rd)``,
  ``ω_rel = ω_r − C(δq_r)ᵀ ω_rd`` — the paper's grouping of eq. 23 into the reference's rate
  and the desired relative rate. Eq. 23 cancels the whole gyroscopic term
  ``ω_f × (I ω_f + h_f)``, so the follower's closed loop is ``I Δω̇ = −k1 vec(δq_fr) − k2 Δω``.
* The reference's angular acceleration ``ω̇_r`` is the one its own law (8) commands: the
  follower recomputes that command from the reference's measurements received over the link
  (the same numbers, the same function), ``ω̇_r = I⁻¹(τ_r − ω_r × (I ω_r + h_r))``.

Arrays here are one spacecraft's vectors, shape (3,) or (4,) (``local`` flight software).
"""


import jax
import jax.numpy as jnp

from coopsat.core.parts import OutputSpec, part
from coopsat.astro.earth import elevation_rad
from coopsat.astro.earth_orientation import EarthOrientation, earth_fixed_point_gcrf, itrf_to_gcrf
from coopsat.geometry.quaternion import cross, dot, quat_conjugate, quat_multiply, quat_positive, quat_rotate, quat_vector


def _unit(v):
    return v / jnp.sqrt(dot(v, v))


def stare_quaternion(los_eci, q_sun_bi):
    """Desired attitude ``Q_d = Q_s ⊗ R``: the least rotation of ``Q_s`` that puts +z on the line
    of sight (eqs. 1–2).

    Parameters
    ----------
    los_eci : array_like, shape (3,)
        Line of sight from the spacecraft to the target, ECI, any length.
    q_sun_bi : array_like, shape (4,)
        Sun-pointing attitude ``Q_s``, body to inertial.

    Returns
    -------
    jax.Array, shape (4,)
        Unit quaternion; undefined only when the target lies exactly along −z of ``Q_s``.
    """
    p = _unit(quat_rotate(quat_conjugate(q_sun_bi), los_eci))
    half = jnp.stack([1.0 + p[2], -p[1], p[0], 0.0])
    return quat_multiply(q_sun_bi, _unit(half))


def desired_motion(los_eci, los_rate_eci, los_accel_eci, q_sun_bi):
    """Desired attitude, rate and angular acceleration of a staring camera.

    Parameters
    ----------
    los_eci, los_rate_eci, los_accel_eci : array_like, shape (3,)
        Line of sight ρ (m), ρ̇ (m/s), ρ̈ (m/s²), ECI.
    q_sun_bi : array_like, shape (4,)

    Returns
    -------
    q_d : jax.Array, shape (4,)
    omega_d : jax.Array, shape (3,)
        Desired rate relative to inertial, desired-frame components, rad/s.
    omega_dot_d : jax.Array, shape (3,)
        Its derivative, desired-frame components, rad/s².

    Notes
    -----
    ``ω_d = 2 vec(q_d* ⊗ q̇_d)`` and ``ω̇_d = 2 vec(q_d* ⊗ q̈_d)`` (the scalar part of
    ``q̇_d* ⊗ q̇_d`` carries no vector part), the derivatives taken exactly by forward-mode
    differentiation along the quadratic ρ(t + τ) (SPEC §5: no finite differences).
    """

    def along(tau):
        return stare_quaternion(los_eci + los_rate_eci * tau + 0.5 * los_accel_eci * tau * tau, q_sun_bi)

    def rate(tau):
        return jax.jvp(along, (tau,), (jnp.ones_like(tau),))[1]

    tau0 = jnp.zeros((), dtype=jnp.result_type(los_eci, float))
    q_d, q_dot = jax.jvp(along, (tau0,), (jnp.ones_like(tau0),))
    q_ddot = jax.jvp(rate, (tau0,), (jnp.ones_like(tau0),))[1]
    q_d_conj = quat_conjugate(q_d)
    return q_d, 2.0 * quat_vector(quat_multiply(q_d_conj, q_dot)), 2.0 * quat_vector(quat_multiply(q_d_conj, q_ddot))


def body_error(q_bi, q_d):
    """``δq = q_d* ⊗ q`` on the ``q0 ≥ 0`` hemisphere: the body relative to the desired frame."""
    return quat_positive(quat_multiply(quat_conjugate(q_d), q_bi))


def law8_torque(q_bi, omega_b, h_b, q_d, omega_d, omega_dot_d, inertia_kgm2, k1, k2):
    """Reference control law (eq. 8), body torque, N·m.

    Parameters
    ----------
    q_bi : (4,)
        Measured attitude.
    omega_b : (3,)
        Measured body rate, rad/s.
    h_b : (3,)
        Wheel momentum, body axes, N·m·s.
    q_d, omega_d, omega_dot_d : (4,), (3,), (3,)
        Desired attitude, rate and acceleration (desired-frame components).
    inertia_kgm2 : (3, 3)
    k1 : scalar
        N·m per unit of ``vec(δq)``.
    k2 : scalar
        N·m·s/rad.
    """
    dq = body_error(q_bi, q_d)
    to_body = quat_conjugate(dq)
    w_d = quat_rotate(to_body, omega_d)
    w_dot_d = quat_rotate(to_body, omega_dot_d)
    return inertia_kgm2 @ w_dot_d + cross(w_d, inertia_kgm2 @ w_d + h_b) - k1 * quat_vector(dq) - k2 * (omega_b - w_d)


def cooperative_target(q_fd, omega_fd, omega_dot_fd, dq_r, omega_r, omega_dot_r, omega_rd, omega_dot_rd):
    """The frame ``T = q_fd ⊗ δq_r`` the cooperative follower tracks, with its rate and
    acceleration in T axes (module notes).

    Parameters
    ----------
    q_fd, omega_fd, omega_dot_fd : (4,), (3,), (3,)
        Follower's desired attitude, rate, acceleration (its desired-frame components).
    dq_r : (4,)
        Reference's error ``δq_r = q_rd* ⊗ q_r``.
    omega_r, omega_dot_r : (3,)
        Reference's body rate and angular acceleration, its body components.
    omega_rd, omega_dot_rd : (3,)
        Reference's desired rate and acceleration, its desired-frame components.

    Returns
    -------
    q_t : (4,), omega_t : (3,), omega_dot_t : (3,)
    """
    to_body = quat_conjugate(dq_r)
    extra = quat_rotate(to_body, omega_fd - omega_rd)
    omega_rel = omega_r - quat_rotate(to_body, omega_rd)
    omega_dot_t = omega_dot_r + quat_rotate(to_body, omega_dot_fd - omega_dot_rd) - cross(omega_rel, extra)
    return quat_multiply(q_fd, dq_r), omega_r + extra, omega_dot_t


def law23_torque(q_bi, omega_b, h_b, q_t, omega_t, omega_dot_t, inertia_kgm2, k1, k2):
    """Cooperative follower law (eq. 23), body torque, N·m: exact tracking of the frame T.

    ``τ = −k1 vec(δq) − k2 Δω + ω × (I ω + h) + I (C(δq)ᵀ ω̇_T − Δω × C(δq)ᵀ ω_T)`` with
    ``δq = q_T* ⊗ q`` (which is ``δq_fr``) and ``Δω = ω − C(δq)ᵀ ω_T``. Arguments as
    :func:`law8_torque`, with T in place of the desired frame.
    """
    dq = body_error(q_bi, q_t)
    to_body = quat_conjugate(dq)
    w_t = quat_rotate(to_body, omega_t)
    d_omega = omega_b - w_t
    feed = inertia_kgm2 @ (quat_rotate(to_body, omega_dot_t) - cross(d_omega, w_t))
    return -k1 * quat_vector(dq) - k2 * d_omega + cross(omega_b, inertia_kgm2 @ omega_b + h_b) + feed


def angular_acceleration(omega_b, h_b, torque_b, inertia_kgm2):
    """``ω̇ = I⁻¹(τ − ω × (I ω + h))``, rad/s² (the wheels' torque counted in ``τ``)."""
    return jnp.linalg.solve(inertia_kgm2, torque_b - cross(omega_b, inertia_kgm2 @ omega_b + h_b))


def dumping_dipole(h_b, b_b):
    """Cross-product momentum dumping direction: ``m = (h × B)/|B|²`` per unit gain, A·m² per N·m·s·s⁻¹.

    The magnetic torque ``m × B = −h⊥`` (the part of ``h`` across the field) unloads the wheels
    at a rate of the gain; ``h`` along ``B`` cannot be unloaded at this instant.
    """
    return cross(h_b, b_b) / dot(b_b, b_b)


@part(static=("cooperative", "wheels", "dump"))
class ObservationSoftware:
    """One spacecraft's staring attitude software (``local``; SPEC §5).

    Every spacecraft holds its sun-pointing attitude until the target is at least
    ``min_elevation_rad`` above its horizon as seen from the spacecraft, then stares at it
    (law 8). A cooperative follower (every spacecraft but the reference, ``cooperative``) flies
    law 23 while it stares, the reference stares, and the reference's message of this period
    has arrived; otherwise law 8 on its own error. The reference broadcasts what it measures
    (attitude, rate, wheel momentum, position, velocity) and the time it measured it; the
    follower rebuilds the reference's desired motion and law-8 command from that message.

    Attributes
    ----------
    q_sun_bi : (4, n)
        Each spacecraft's sun-pointing attitude ``Q_s``.
    target_ecef_m : (3,)
        The target, Earth-fixed, m.
    up_ecef : (3,)
        The ellipsoid normal at the target (its local vertical), Earth-fixed.
    earth : EarthOrientation
        The Earth's orientation over the run.
    mu_m3_s2 : scalar
        For the spacecraft's two-body acceleration in ρ̈.
    inertia_kgm2 : (3, 3, n)
    k1 : scalar
        N·m per unit of ``vec(δq)``.
    k2 : scalar
        N·m·s/rad.
    torque_max_nm : scalar
        Each axis of the torque command is clipped to ±this (what the wheels can give; the
        follower's model of the reference's acceleration uses the clipped command too).
    dump_gain_1_s : scalar
        Momentum dumping gain: dipole ``k (h × B)/|B|²`` from the measured field.
    dipole_max_am2 : scalar
        Each axis of the dipole command is clipped to ±this (the magnetorquers' limit).
    min_elevation_rad : scalar
        Staring starts when the target is this high above its horizon.
    reference : int scalar
        Index of the reference spacecraft.
    period_s : scalar
        Control period, s (the time stamp of the next outbox).
    cooperative : bool
        Static: followers fly law 23.
    wheels : bool
        Static: the run has reaction wheels (their momentum enters the laws).
    dump : bool
        Static: command magnetorquers (reads the magnetometer's ``b_b``).
    """

    q_sun_bi: jnp.ndarray
    target_ecef_m: jnp.ndarray
    up_ecef: jnp.ndarray
    earth: EarthOrientation
    mu_m3_s2: jnp.ndarray
    inertia_kgm2: jnp.ndarray
    k1: jnp.ndarray
    k2: jnp.ndarray
    torque_max_nm: jnp.ndarray
    dump_gain_1_s: jnp.ndarray
    dipole_max_am2: jnp.ndarray
    min_elevation_rad: jnp.ndarray
    reference: jnp.ndarray
    period_s: jnp.ndarray
    cooperative: bool = True
    wheels: bool = True
    dump: bool = False

    local = True
    commands = ("torque_b", "dipole_b")

    @property
    def reads(self):
        return ("q", "omega", "r_eci", "v_eci") + (("h_wheels",) if self.wheels else ()) + (("b_b",) if self.dump else ())

    def init(self, n):
        return {"t_next": jnp.zeros((n,))}

    def _h(self, y_i):
        return y_i["h_wheels"] if self.wheels else jnp.zeros(3)

    def outbox_one(self, i, y_i, state_i):
        """What spacecraft i measured at the start of this period, and when."""
        return {
            "q": y_i["q"], "omega": y_i["omega"], "h": self._h(y_i), "r": y_i["r_eci"], "v": y_i["v_eci"],
            "t": state_i["t_next"], "sender": jnp.asarray(i, dtype=float),
        }

    def geometry(self, k, t, r_eci, v_eci):
        """Spacecraft k's desired motion at time t from its position and velocity.

        Returns (q_d, omega_d, omega_dot_d, elevation_rad, staring, los_unit_eci).
        """
        r_g, v_g, a_g = earth_fixed_point_gcrf(self.target_ecef_m, t, self.earth)
        up = itrf_to_gcrf(self.up_ecef, t, self.earth)
        los = r_g - r_eci
        accel = -self.mu_m3_s2 * r_eci / dot(r_eci, r_eci) ** 1.5
        elevation = elevation_rad(r_eci, r_g, up)
        staring = elevation >= self.min_elevation_rad
        q_s = self.q_sun_bi[:, k]
        q_d, w_d, w_dot_d = desired_motion(los, v_g - v_eci, a_g - accel, q_s)
        return (
            jnp.where(staring, q_d, q_s), jnp.where(staring, w_d, 0.0), jnp.where(staring, w_dot_d, 0.0),
            elevation, staring, _unit(los),
        )

    def _law8(self, k, q, w, h, desired):
        tau = law8_torque(q, w, h, *desired, self.inertia_kgm2[:, :, k], self.k1, self.k2)
        return jnp.clip(tau, -self.torque_max_nm, self.torque_max_nm)

    def step_one(self, i, t, y_i, inbox_i, state_i, key):
        """Spacecraft i's body torque and dipole commands, its new state and its record."""
        q, w, h = y_i["q"], y_i["omega"], self._h(y_i)
        q_d, w_d, w_dot_d, elevation, staring, los = self.geometry(i, t, y_i["r_eci"], y_i["v_eci"])
        own = self._law8(i, q, w, h, (q_d, w_d, w_dot_d))
        torque = own
        cooperating = jnp.zeros(())
        if self.cooperative:
            from_ref = (inbox_i.weight > 0.0) & (jnp.round(inbox_i.msg["sender"]) == self.reference)
            count = jnp.sum(from_ref)
            msg = jax.tree_util.tree_map(lambda m: jnp.sum(m * from_ref, axis=-1) / jnp.maximum(count, 1.0), inbox_i.msg)
            ref = self.reference
            q_rd, w_rd, w_dot_rd, _, ref_staring, _ = self.geometry(ref, msg["t"], msg["r"], msg["v"])
            tau_r = self._law8(ref, msg["q"], msg["omega"], msg["h"], (q_rd, w_rd, w_dot_rd))
            w_dot_r = angular_acceleration(msg["omega"], msg["h"], tau_r, self.inertia_kgm2[:, :, ref])
            target = cooperative_target(q_d, w_d, w_dot_d, body_error(msg["q"], q_rd), msg["omega"], w_dot_r, w_rd, w_dot_rd)
            coop = law23_torque(q, w, h, *target, self.inertia_kgm2[:, :, i], self.k1, self.k2)
            use = (i != ref) & (count > 0) & staring & ref_staring
            torque = jnp.where(use, jnp.clip(coop, -self.torque_max_nm, self.torque_max_nm), own)
            cooperating = use.astype(float)
        wheel_torque, dipole = torque, jnp.zeros(3)
        if self.dump:
            dipole = jnp.clip(self.dump_gain_1_s * dumping_dipole(h, y_i["b_b"]), -self.dipole_max_am2, self.dipole_max_am2)
            # The wheels give the law's torque less the magnetic torque expected from the
            # measured field, so dumping moves momentum from the wheels without turning the body.
            wheel_torque = torque - cross(dipole, y_i["b_b"])
        record = {
            "q_desired": q_d, "omega_desired": w_d, "target_elevation": elevation, "staring": staring.astype(float),
            "target_los": los, "torque_command": torque, "dipole_command": dipole, "cooperating": cooperating,
        }
        return {"torque_b": wheel_torque, "dipole_b": dipole}, {"t_next": t + self.period_s}, record

    def output_specs(self):
        return {
            "q_desired": OutputSpec(("q_component",), "1", "ECI", "desired attitude (sun-pointing, or staring at the target)"),
            "omega_desired": OutputSpec(("component",), "rad/s", "desired", "desired body rate, desired-frame components"),
            "target_elevation": OutputSpec((), "rad", "", "elevation of the spacecraft above the target's horizon"),
            "staring": OutputSpec((), "1", "", "1 while the software stares at the target, 0 while it points at the Sun"),
            "target_los": OutputSpec(("component",), "1", "ECI", "unit line of sight from the spacecraft to the target"),
            "torque_command": OutputSpec(
                ("component",), "N m", "body",
                "body torque the law commands (after the software's clip); the wheels are asked for it less the "
                "expected magnetorquer torque",
            ),
            "dipole_command": OutputSpec(("component",), "A m2", "body", "magnetic dipole commanded for momentum dumping"),
            "cooperating": OutputSpec((), "1", "", "1 when this period's command came from the cooperative law (23)"),
        }
