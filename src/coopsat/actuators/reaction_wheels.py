"""Reaction wheels as an in-loop part (SPEC §5): momentum exchange with the body.

The controller commands the torque ``u`` it wants on the body (``torque_b``); each wheel's
motor torque ``τ`` is the minimum-norm solution of ``−G τ = u`` within the torque limit
(:func:`~coopsat.actuators.wheels.wheel_motor_torque`), held over the control period, and cut
by the drive where it would take the wheel past its rated speed by the end of the period
(:func:`~coopsat.actuators.wheels.speed_limited_torque`; the output
``wheel_speed_limited_time`` counts how long).
The part acts through the channel ``wheel_torque_b`` with level ``G τ`` (the rate of the
wheels' momentum in body axes): the plant integrates ``h_wheels_b`` and the body feels
``−G τ`` (``I ω̇ + ω × (I ω + h_w) = τ_ext − ḣ_w``), so the formation's inertial angular
momentum ``C(q)(I ω + h_w)`` is untouched by the wheels.

Sign conventions: ``h_k`` (N·m·s) is wheel k's angular momentum about its spin axis ``g_k`` in
inertial space, ``h_k = I_k (Ω_k + g_k·ω)`` with ``Ω_k`` its speed relative to the body (rad/s,
positive when the wheel turns right-handed about ``g_k``): the motor torque changes exactly
that, ``ḣ_k = τ_k`` (``τ_k > 0`` spins wheel k up along ``g_k``). The body inertia of the run
is then the spacecraft's *without* the wheels' spin-axis inertia (Basilisk's ``IHubPntBc_B``
minus ``Σ I_k g_k g_kᵀ``; checked against Basilisk's reaction wheels,
tests/reference/test_basilisk_wheels.py). The speed limit applies to ``Ω_k``: the drive
measures the wheel's speed against the body, and the record's ``wheel_speed`` is that speed.

Speed-control error (SPEC §5: 5 rpm, 3σ): each wheel's speed loop leaves an error ``δΩ_k`` on
top of the speed the commanded torque would give, a first-order Gauss–Markov process with
stationary standard deviation σ and correlation time τ_c (``δΩ ← φ δΩ + σ √(1 − φ²) ν``,
``φ = exp(−T/τ_c)`` per control period T, drawn from the run's key). The wheel's momentum then
changes by ``I_k (δΩ_new − δΩ_old)`` more than commanded over the period: an extra motor torque
the body feels as a disturbance the attitude law must reject. The speed limit bounds the sum:
a speed loop never drives its wheel past the rated speed, error or not.

State: per-wheel momentum (m, n), advanced exactly by ``τ·T`` each period (with the speed
error: ``{"h": …, "speed_error": δΩ (m, n)}``). It starts at
``G⁺ h_wheels_b_nms`` of each spacecraft (``G⁺`` the Moore–Penrose pseudo-inverse: the
smallest per-wheel momenta that make up the body-axis momentum; ``G G⁺ = 1`` since ``G`` has
rank 3, so the part and the plant agree).
"""

from typing import NamedTuple


import jax.numpy as jnp

from coopsat.core.parts import OutputSpec, part, per_spacecraft_normal
from coopsat.actuators.pulses import IMPULSE_OUTPUTS
from coopsat.actuators.wheels import speed_limited_torque, wheel_motor_torque


class WheelPulse(NamedTuple):
    """A :class:`~coopsat.actuators.pulses.Pulse` (same first two fields, so the engine reads
    it as one) that also carries each wheel's motor torque for the counters.

    Attributes
    ----------
    level_nm : (3, n)
        ``G τ``, rate of the wheels' momentum in body axes, N·m.
    t_off_s : (3, n)
        The control period (the torque is held over it).
    tau_nm : (m, n)
        Motor torque of each wheel, N·m.
    limited : (m, n)
        1.0 where the drive cut the wheel's torque at its speed limit this period, else 0.0.
    """

    level_nm: jnp.ndarray
    t_off_s: jnp.ndarray
    tau_nm: jnp.ndarray
    limited: jnp.ndarray


def wheel_labels(m):
    """Labels of the ``wheel`` dimension: ``w1`` … ``wm`` in the order of ``spin_axes_b``."""
    return tuple(f"w{k + 1}" for k in range(m))


@part(static=("command", "speed_noise"))
class ReactionWheels:
    """Reaction-wheel part: m wheels with spin axes ``G`` (3, m), the same on every spacecraft.

    Attributes
    ----------
    spin_axes_b : (3, m)
        ``G``: unit spin axes as columns, body components.
    spin_axes_pinv : (m, 3)
        ``G⁺``.
    inertia_kgm2 : (m, 1)
        Each wheel's inertia about its spin axis, kg·m².
    torque_max_nm : (m, 1)
        Motor torque limit per wheel, N·m.
    h_max_nms : (m, 1)
        Momentum limit per wheel, ``I_k ω_max,k``, N·m·s.
    h0_nms : (m, n)
        Initial momentum of each wheel, N·m·s.
    speed_sigma_rad_s : (m, 1)
        Stationary standard deviation of the speed-control error, rad/s.
    speed_phi : scalar
        ``exp(−T/τ_c)``: the error's correlation over one control period.
    command : str
        Static: the controller command it executes (body torque, N·m).
    speed_noise : bool
        Static: model the speed-control error.
    """

    spin_axes_b: jnp.ndarray
    spin_axes_pinv: jnp.ndarray
    inertia_kgm2: jnp.ndarray
    torque_max_nm: jnp.ndarray
    h_max_nms: jnp.ndarray
    h0_nms: jnp.ndarray
    speed_sigma_rad_s: jnp.ndarray
    speed_phi: jnp.ndarray
    command: str = "torque_b"
    speed_noise: bool = False

    channel = "wheel_torque_b"
    pulsed = False
    mean_output = ("torque", "angular_impulse")

    def init(self, n):
        return {"h": self.h0_nms, "speed_error": jnp.zeros_like(self.h0_nms)} if self.speed_noise else self.h0_nms

    def _momentum(self, state):
        return state["h"] if self.speed_noise else state

    def _relative_momentum(self, x, state):
        """``I_k Ω_k``: each wheel's momentum relative to the body (what its speed limit bounds)."""
        return self._momentum(state) - self.inertia_kgm2 * jnp.einsum("im,in->mn", self.spin_axes_b, x.omega_b)

    def plan(self, command, x, state, period_s, key, t=0.0):
        tau = wheel_motor_torque(command, self.spin_axes_pinv, self.torque_max_nm)
        h = self._momentum(state)
        h_new = h + tau * period_s
        if self.speed_noise:
            err = state["speed_error"]
            new_err = self.speed_phi * err + self.speed_sigma_rad_s * jnp.sqrt(1.0 - self.speed_phi**2) * (
                per_spacecraft_normal(key, err.shape[0], err.shape[1]))
            tau = tau + self.inertia_kgm2 * (new_err - err) / period_s
            h_new = h_new + self.inertia_kgm2 * (new_err - err)
        # The drive limits the speed the wheel actually reaches, speed-loop error included.
        limited_tau, limited = speed_limited_torque(tau, self._relative_momentum(x, state), self.h_max_nms, period_s)
        # Where nothing is cut, h_new keeps the unlimited arithmetic (a run that never reaches
        # the limit is bit for bit what it was before the drive limited speed).
        h_new = jnp.where(limited, h + limited_tau * period_s, h_new)
        h_dot_b = self.spin_axes_b @ limited_tau
        pulse = WheelPulse(h_dot_b, jnp.full_like(h_dot_b, period_s), limited_tau, limited.astype(h.dtype))
        return pulse, ({"h": h_new, "speed_error": new_err} if self.speed_noise else h_new)

    def record(self, x, state):
        """Each wheel's speed relative to the body at the sample, rad/s."""
        return {"wheel_speed": self._relative_momentum(x, state) / self.inertia_kgm2}

    def account(self, pulse):
        """The body's angular impulse (it feels ``−G τ``), each wheel's motor impulse, and how
        long the drive held each wheel at its speed limit."""
        body = -pulse.level_nm * pulse.t_off_s
        wheel = pulse.tau_nm * pulse.t_off_s[:1]
        return {
            "angular_impulse": body,
            "impulse": jnp.abs(body),
            "wheel_angular_impulse": wheel,
            "wheel_speed_limited_time": pulse.limited * pulse.t_off_s[:1],
        }

    def output_specs(self):
        wheels = (("wheel", wheel_labels(self.spin_axes_b.shape[-1])),)
        return {
            **IMPULSE_OUTPUTS,
            "wheel_angular_impulse": OutputSpec(
                ("wheel",), "N m s", "",
                "cumulative motor torque impulse of each wheel (= change of its momentum along its spin axis), "
                "from t = 0 to the sample",
                coords=wheels,
            ),
            "wheel_speed": OutputSpec(
                ("wheel",), "rad/s", "", "speed of each wheel relative to the body at the sample", coords=wheels
            ),
            "wheel_speed_limited_time": OutputSpec(
                ("wheel",), "s", "",
                "cumulative time during which the drive cut each wheel's torque at its rated speed, from t = 0 to "
                "the sample",
                coords=wheels,
            ),
        }
