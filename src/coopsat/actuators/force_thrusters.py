"""Force actuators of the formation-flying papers as in-loop parts: impulse-bit MEMS thrusters
(SPEC §2) and proportional thrusters with a dead zone (SPEC §4).

Both act through a force channel of :data:`coopsat.dynamics.plant.WRENCH_CHANNELS`: the chief's
LVLH axes (``force_lvlh``: thrusters kept aligned with the chief's LVLH frame by the attitude
control), the body axes (``force_b``), or inertial axes (``force_eci``: thrusters held fixed in
inertial space, the deep-space formation's assumption, SPEC §4). A :class:`~coopsat.actuators.pulses.Pulse` carries a
force here: its field ``level_nm`` holds newtons.

Counters (cumulative from t = 0, per axis of the actuator's frame): ``force_impulse``, the signed
impulse ``∫ F dt`` (N·s), and ``abs_force_impulse``, ``∫ |F| dt`` (N·s, proportional to the
propellant used); the impulse-bit thrusters also count ``impulse_bits``, the number of bits fired.
The mean output ``force`` is the mean force applied over the record interval (from
``force_impulse``).
"""


import jax.numpy as jnp

from coopsat.core.parts import OutputSpec, part
from coopsat.actuators.impulse_bits import bits_pulse, quantise_impulse
from coopsat.actuators.pulses import Pulse
from coopsat.actuators.smooth import soft_clip, soft_deadzone
from coopsat.actuators.thrusters import deadzone_thrust

FRAMES = {"lvlh": ("force_lvlh", "LVLH"), "body": ("force_b", "body"), "inertial": ("force_eci", "ECI")}
"""Scenario ``frame`` -> (wrench channel, frame label of the recorded vectors)."""


def force_outputs(frame):
    """Recorded outputs shared by every force actuator, vectors in ``frame`` (``"lvlh"``/``"body"``/``"inertial"``).

    Returns
    -------
    dict of str -> OutputSpec
        ``force_impulse``, ``abs_force_impulse`` (cumulative, N s) and ``force`` (mean, N).
    """
    label = FRAMES[frame][1]
    return {
        "force_impulse": OutputSpec(
            ("component",), "N s", label,
            "cumulative signed impulse of the force actuators per axis, from t = 0 to the sample",
        ),
        "abs_force_impulse": OutputSpec(
            ("component",), "N s", label,
            "cumulative absolute impulse of the force actuators per axis (propellant effort), from t = 0 to the sample",
        ),
        "force": OutputSpec(
            ("component",), "N", label,
            "mean force actually applied over the record interval starting at the sample "
            "(last sample: over the control period that would follow)",
        ),
    }


def force_impulse_increments(pulse):
    """Per-period increments of a force pulse's counters, N·s, (3, n) each."""
    return {"force_impulse": pulse.level_nm * pulse.t_off_s, "abs_force_impulse": jnp.abs(pulse.level_nm) * pulse.t_off_s}


class _ForceActuator:
    """What every force actuator part shares: its channel follows its ``frame``, its mean output
    is the force (from the signed impulse), and it records nothing at the sample."""

    mean_output = ("force", "force_impulse")

    @property
    def channel(self):
        return FRAMES[self.frame][0]

    def record(self, x, state):
        return {}


@part(static=("frame", "command", "carry"))
class ImpulseBitThrusters(_ForceActuator):
    """MEMS thrusters firing whole impulse bits, one ± pair per axis (SPEC §2).

    Each period the commanded force ``f`` (N, per axis) is turned into the wanted impulse
    ``f·T``, quantised to whole bits with the rounding error carried to the next period
    (:func:`~coopsat.actuators.impulse_bits.quantise_impulse`), and the bits are fired as one
    pulse of ``±thrust_n`` from the period start, ``|bits|·bit/thrust`` long
    (:func:`~coopsat.actuators.impulse_bits.bits_pulse`). Pulsed: the engine integrates the
    switch-off exactly.

    Attributes
    ----------
    bit_ns : scalar
        Impulse of one bit, N·s.
    thrust_n : scalar
        Force of one firing thruster, N.
    max_bits : scalar
        Most bits one axis fires per period (float; ``max_bits·bit/thrust ≤ T``).
    frame : {"lvlh", "body", "inertial"}
        Static: the axes of the thrusters (channel ``force_lvlh``, ``force_b`` or ``force_eci``).
    command : str
        Static: the controller command it executes (a force, N, in ``frame``).
    carry : bool
        Static: carry the rounding remainder to the next period (first-order sigma-delta:
        the delivered impulse follows the commanded one to within half a bit over any run of
        periods), or drop it (plain rounding each period: a command below half a bit per
        period never fires, a dead band of ``bit/(2T)`` in force).

    Notes
    -----
    State: the carried remainder (3, n), N·s, within ±bit/2 (zero when dropped).
    """

    bit_ns: jnp.ndarray
    thrust_n: jnp.ndarray
    max_bits: jnp.ndarray
    frame: str = "lvlh"
    command: str = "force_lvlh"
    carry: bool = True

    pulsed = True

    def init(self, n):
        return jnp.zeros((3, n))

    def plan(self, command, x, state, period_s, key, t=0.0):
        bits, remainder = quantise_impulse(command * period_s, state, self.bit_ns, self.max_bits)
        level, t_on = bits_pulse(bits, self.bit_ns, self.thrust_n)
        return Pulse(level, t_on), remainder if self.carry else jnp.zeros_like(remainder)

    def account(self, pulse):
        """Impulse counters, and the whole bits fired per axis (either sign)."""
        # level·t_on = bits·bit to the last bit of the mantissa, so rounding recovers the count.
        bits = jnp.round(jnp.abs(pulse.level_nm) * pulse.t_off_s / self.bit_ns)
        return {**force_impulse_increments(pulse), "impulse_bits": bits}

    def output_specs(self):
        return {
            **force_outputs(self.frame),
            "impulse_bits": OutputSpec(
                ("component",), "1", FRAMES[self.frame][1],
                "cumulative number of impulse bits fired per axis (either direction), from t = 0 to the sample",
            ),
        }


@part(static=("frame", "command"))
class ProportionalThrusters(_ForceActuator):
    """Proportional thrusters with a dead zone, one per axis (SPEC §4: 1–100 mN).

    The commanded force per axis is held over the period: zero when ``|f| < force_min_n``,
    clipped to ``±force_max_n`` (:func:`~coopsat.actuators.thrusters.deadzone_thrust`).

    Attributes
    ----------
    force_min_n, force_max_n : scalar
        Smallest and largest force per axis, N.
    frame : {"lvlh", "body", "inertial"}
        Static: the axes of the thrusters.
    command : str
        Static: the controller command it executes (a force, N, in ``frame``).
    """

    force_min_n: jnp.ndarray
    force_max_n: jnp.ndarray
    frame: str = "lvlh"
    command: str = "force_lvlh"

    pulsed = False

    def init(self, n):
        return ()

    def plan(self, command, x, state, period_s, key, t=0.0):
        level = deadzone_thrust(command, self.force_min_n, self.force_max_n)
        return Pulse(level, jnp.full_like(level, period_s)), state

    def account(self, pulse):
        """Impulse counters, and ``∫‖F‖₂ dt`` (the force is held over the whole period)."""
        sq = jnp.sum(pulse.level_nm**2, axis=0)
        # The inner where keeps the derivative of the norm finite at zero force (a gradient
        # through the run would otherwise meet 0·∞).
        norm = jnp.where(sq > 0.0, jnp.sqrt(jnp.where(sq > 0.0, sq, 1.0)), 0.0) * pulse.t_off_s[0]
        return {**force_impulse_increments(pulse), "norm_force_impulse": norm}

    def surrogate(self):
        """The smooth stand-in used for gradients (:mod:`coopsat.actuators.smooth`), and what it is."""
        return SmoothProportionalThrusters(self.force_min_n, self.force_max_n, self.frame, self.command), (
            "proportional thrusters: dead zone smoothed by a logistic step 0.25·force_min_n wide, "
            "limit rounded over 0.01·force_max_n (softplus)"
        )

    def output_specs(self):
        return {
            **force_outputs(self.frame),
            "norm_force_impulse": OutputSpec(
                (), "N s", "", "cumulative ∫‖F‖₂ dt of the thrusters (the 2-norm fuel measure), from t = 0 to the sample"
            ),
        }


@part(static=("frame", "command"))
class SmoothProportionalThrusters(ProportionalThrusters):
    """:class:`ProportionalThrusters` with the dead zone and the limit smoothed, for gradients
    only (``coopsat tune``; :func:`~coopsat.actuators.smooth.soft_deadzone` 0.25·force_min_n
    wide, :func:`~coopsat.actuators.smooth.soft_clip` over 0.01·force_max_n)."""

    def plan(self, command, x, state, period_s, key, t=0.0):
        level = soft_clip(soft_deadzone(command, self.force_min_n, 0.25 * self.force_min_n), self.force_max_n, 0.01 * self.force_max_n)
        return Pulse(level, jnp.full_like(level, period_s)), state
