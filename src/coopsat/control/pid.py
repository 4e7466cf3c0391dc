"""Single-spacecraft feedback laws with state: an attitude PID and an LVLH station-keeping PD.

Flight software: each spacecraft sees only its own measurements (plus, for station keeping,
the chief's measured orbit: the chief's GPS fix as the formation shares it). Neither law uses
the network: their outboxes are empty.
"""


import jax.numpy as jnp

from coopsat.core.parts import OutputSpec, part
from coopsat.geometry.frames import eci_to_lvlh
from coopsat.geometry.quaternion import quat_error, quat_positive, quat_vector

CHIEF = 0
"""Index of the chief spacecraft (the first ``[[spacecraft]]``), as the plant's ``force_lvlh``
channel (:class:`~coopsat.dynamics.plant.PlantParams` ``chief``)."""


def attitude_error_vector(q_bi, q_target, axis=-1):
    """``vec(q_t* ⊗ q)`` on the ``q0 ≥ 0`` hemisphere (the short way round); (..., 4) -> (..., 3).

    Parameters
    ----------
    q_bi : array_like, shape (n, 4)
        Attitudes, body relative to inertial ((4, n) with ``axis=0``).
    q_target : array_like, shape broadcastable against ``q_bi``
        Target attitude.
    axis : {-1, 0}

    Returns
    -------
    jax.Array
        Body components; ``sin(θ/2)·n̂`` for a rotation by θ ∈ [0, π] about n̂ from the target to
        the body.
    """
    return quat_vector(quat_positive(quat_error(q_bi, q_target, axis), axis), axis)


def pid_torque(e, omega_b, integral, k_p, k_d, k_i):
    """``u = −K_p e − K_d ω − K_i ∫e dt``, N·m (any shape; the arguments broadcast).

    Parameters
    ----------
    e : array_like
        Attitude error vector ``vec(q_t* ⊗ q)``.
    omega_b : array_like
        Body rate, rad/s (the target's rate is zero).
    integral : array_like
        ``∫ e dt``, s.
    k_p, k_d, k_i : scalar
        N·m, N·m·s/rad, N·m/s.
    """
    return -k_p * e - k_d * omega_b - k_i * integral


def integrate_error(integral, e, period_s, integral_max):
    """The integral one period later: ``clip(∫e + T e, ±integral_max)`` (the error held over the
    period, as the controller sampled it; the clip is the anti-windup)."""
    return jnp.clip(integral + period_s * e, -integral_max, integral_max)


def lvlh_pd_force(rho_lvlh, rho_dot_lvlh, rho_target_lvlh, k_p, k_d):
    """``f = −K_p (ρ − ρ_t) − K_d ρ̇``, N, LVLH axes (any shape; the arguments broadcast).

    Parameters
    ----------
    rho_lvlh, rho_dot_lvlh : array_like
        Position (m) and rotating-frame velocity (m/s) relative to the chief, LVLH.
    rho_target_lvlh : array_like
        Wanted position relative to the chief, m, LVLH.
    k_p, k_d : scalar
        N/m and N·s/m.
    """
    return -k_p * (rho_lvlh - rho_target_lvlh) - k_d * rho_dot_lvlh


@part()
class AttitudePid:
    """Attitude hold: PID on the error quaternion to a constant target, body torque command.

    Attributes
    ----------
    k_p, k_d, k_i : scalar
        N·m, N·m·s/rad, N·m/s.
    q_target : (4,)
        Target attitude (unit), scalar first.
    period_s : scalar
        Control period T, s (the integral's step).
    integral_max : scalar
        Anti-windup clamp on each component of ``∫e dt``, s (``inf``: none).

    Notes
    -----
    State: ``∫e dt`` (3, n), the integral of the sampled error held over each period, from
    t = 0 to the current sample: the command at sample k uses ``T Σ_{j<k} e_j``, then adds
    ``T e_k`` for the next period.
    """

    k_p: jnp.ndarray
    k_d: jnp.ndarray
    k_i: jnp.ndarray
    q_target: jnp.ndarray
    period_s: jnp.ndarray
    integral_max: jnp.ndarray

    commands = ("torque_b",)

    def init(self, n):
        return jnp.zeros((3, n))

    def outbox(self, y, state):
        return {}

    def step(self, t, y, inbox, state, key):
        """Body torque ``torque_b`` (3, n); records it and the integral it used."""
        e = attitude_error_vector(y["q"], self.q_target[:, None], 0)
        u = pid_torque(e, y["omega"], state, self.k_p, self.k_d, self.k_i)
        new_state = integrate_error(state, e, self.period_s, self.integral_max)
        return {"torque_b": u}, new_state, {"torque_command": u, "attitude_error_integral": state}

    # The per-spacecraft form (the protocol of a LocalController, without ``local``: the
    # compiled loop keeps the formation-wide step above; software in the loop runs one
    # spacecraft per process, docs/sil.md). The law reads only its own spacecraft's column.
    reads = ("q", "omega")

    def outbox_one(self, i, y_i, state_i):
        """Spacecraft i broadcasts nothing."""
        return {}

    def step_one(self, i, t, y_i, inbox_i, state_i, key_i):
        """Spacecraft i's body torque ``torque_b`` (3,) N·m from its attitude (4,) and rate (3,)
        and its integral ``state_i`` (3,) s; records as :meth:`step`. The same elementwise
        arithmetic as :meth:`step`'s column i: equal bit for bit."""
        e = attitude_error_vector(y_i["q"], self.q_target)
        u = pid_torque(e, y_i["omega"], state_i, self.k_p, self.k_d, self.k_i)
        new_state = integrate_error(state_i, e, self.period_s, self.integral_max)
        return {"torque_b": u}, new_state, {"torque_command": u, "attitude_error_integral": state_i}

    def output_specs(self):
        return {
            "torque_command": OutputSpec(("component",), "N m", "body", "torque commanded by the control law at the sample"),
            "attitude_error_integral": OutputSpec(
                ("component",), "s", "body",
                "integral from t = 0 to the sample of the attitude error vec(q_target* x q) (sampled, held over "
                "each period, clamped to integral_max), as the PID used it",
            ),
        }


@part()
class LvlhPd:
    """Formation keeping: each deputy holds a constant offset from the chief, in the chief's LVLH
    frame (PD on the measured relative state); force command ``force_lvlh``.

    Attributes
    ----------
    k_p, k_d : scalar
        N/m and N·s/m.
    rho_target_lvlh : (3, n)
        Offset to hold, m, LVLH (the chief's column is zero).
    start_s : scalar
        The law commands nothing before this time, s (free drift until then).

    Notes
    -----
    Relative state from the measured ECI positions and velocities of the chief (spacecraft
    :data:`CHIEF`) and of the deputy (:func:`~coopsat.geometry.frames.eci_to_lvlh`). The chief
    commands zero force. Stateless.
    """

    k_p: jnp.ndarray
    k_d: jnp.ndarray
    rho_target_lvlh: jnp.ndarray
    start_s: jnp.ndarray

    commands = ("force_lvlh",)
    chief = CHIEF

    def init(self, n):
        return ()

    def outbox(self, y, state):
        return {}

    def step(self, t, y, inbox, state, key):
        """Force ``force_lvlh`` (3, n), N; records it and the relative state.

        The relative state is the measured ``x_lvlh`` where the run measures it (a
        relative-navigation sensor, a navigation filter), else it is formed from the measured
        ECI states of the chief and the deputy."""
        if "x_lvlh" in y:
            rho, rho_dot = y["x_lvlh"][:3], y["x_lvlh"][3:]
        else:
            r, v = y["r_eci"], y["v_eci"]
            c = slice(CHIEF, CHIEF + 1)
            rho, rho_dot = eci_to_lvlh(r[:, c], v[:, c], r, v, 0)
        f = lvlh_pd_force(rho, rho_dot, self.rho_target_lvlh, self.k_p, self.k_d)
        f = jnp.where((jnp.arange(f.shape[-1]) == CHIEF) | (t < self.start_s), 0.0, f)
        return {"force_lvlh": f}, state, {"force_command": f, "rho_lvlh": rho, "rho_dot_lvlh": rho_dot}

    # The per-spacecraft form (software in the loop, a navigation filter): spacecraft i reads its
    # own state relative to the chief, ``x_lvlh`` (6,), which a sensor or a filter provides.
    reads = ("x_lvlh",)

    def outbox_one(self, i, y_i, state_i):
        """Spacecraft i broadcasts nothing."""
        return {}

    def step_one(self, i, t, y_i, inbox_i, state_i, key_i):
        """Spacecraft i's ``force_lvlh`` (3,), N, from its relative state ``x_lvlh`` (6,); records
        as :meth:`step`. The same elementwise arithmetic as :meth:`step`'s column i."""
        rho, rho_dot = y_i["x_lvlh"][:3], y_i["x_lvlh"][3:]
        f = lvlh_pd_force(rho, rho_dot, self.rho_target_lvlh[:, i], self.k_p, self.k_d)
        f = jnp.where((i == CHIEF) | (t < self.start_s), 0.0, f)
        return {"force_lvlh": f}, state_i, {"force_command": f, "rho_lvlh": rho, "rho_dot_lvlh": rho_dot}

    def targets_lvlh(self):
        """Where each spacecraft should be relative to the chief, the chief's LVLH frame, m,
        (n, 3) NumPy (design; for the truth errors of :mod:`coopsat.analysis.papers.station_keeping`)."""
        import numpy as np

        return np.asarray(self.rho_target_lvlh).T

    def output_specs(self):
        return {
            "force_command": OutputSpec(("component",), "N", "LVLH", "force commanded by the control law at the sample"),
            "rho_lvlh": OutputSpec(
                ("component",), "m", "LVLH", "measured position relative to the chief, as the control law saw it"
            ),
            "rho_dot_lvlh": OutputSpec(
                ("component",), "m/s", "LVLH",
                "measured velocity relative to the chief, seen in the rotating LVLH frame, as the control law saw it",
            ),
        }
