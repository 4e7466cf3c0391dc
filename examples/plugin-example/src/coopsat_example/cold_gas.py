"""Cold-gas attitude thrusters with a minimum impulse bit and a valve opening delay (the
actuator part).

One ± thruster couple per body axis gives ``±τ_max`` while its valve is open. Each control
period of length T the commanded torque u (per axis) asks for the angular impulse ``u·T``:

* below the minimum impulse bit ``J_min`` (the impulse of the shortest valve opening) the
  command is not executed: a dead band ``|u| < J_min / T`` in torque;
* above it the valve opens for ``|u|·T / τ_max`` from the start of the period, at most the
  whole period: the impulse executed is ``sign(u)·min(|u|·T, τ_max·T)``;
* the valve opens ``d`` whole control periods after the command (the opening delay of the
  valve and its driver): the impulse commanded in period k is fired in period k + d. The
  pending impulses wait in a ring buffer of d slots in the part's state.

The engine switches the thrust off at the exact instant inside the period (``pulsed``), so
on-times are not rounded to the base tick.
"""

import jax.numpy as jnp

from coopsat.plugins import OutputSpec, Pulse, part

THRUSTERS = ("+x", "-x", "+y", "-y", "+z", "-z")
"""Order of the ``thruster`` dimension: for each body axis the + couple, then the − couple."""


def executed_impulse(impulse_nms, impulse_bit_nms, impulse_max_nms):
    """The angular impulse the valves deliver for a wanted one, per axis, N·m·s.

    Parameters
    ----------
    impulse_nms : array
        Wanted angular impulse this period (command × period).
    impulse_bit_nms : scalar
        Minimum impulse bit: smaller wanted impulses are not executed.
    impulse_max_nms : scalar
        Impulse of a valve open for the whole period (``τ_max·T``).

    Returns
    -------
    jax.Array, shape of ``impulse_nms``
        0 where ``|impulse| < impulse_bit``; ``sign · min(|impulse|, impulse_max)`` elsewhere.
    """
    size = jnp.abs(impulse_nms)
    return jnp.where(size >= impulse_bit_nms, jnp.sign(impulse_nms) * jnp.minimum(size, impulse_max_nms), 0.0)


@part(static=("command", "delay_periods"))
class ColdGasThrusters:
    """Cold-gas thrusters: minimum impulse bit, saturation, valve opening delay.

    Attributes
    ----------
    torque_max_nm : scalar
        Torque of one open thruster couple, N·m.
    impulse_bit_nms : scalar
        Minimum impulse bit, N·m·s (``τ_max`` × the shortest valve opening).
    command : str
        Static: the controller command executed (body torque, N·m).
    delay_periods : int
        Static: whole control periods from a command to its valve opening.

    Notes
    -----
    State: ``pending`` (d, 3, n), the impulses commanded and not yet fired (N·m·s), in a ring
    buffer whose next slot to fire and refill is ``slot``; ``below_bit`` (3, n), how many
    commands each axis has not executed because they were below the bit (cumulative, recorded
    as ``commands_below_bit``).
    """

    torque_max_nm: jnp.ndarray
    impulse_bit_nms: jnp.ndarray
    command: str = "torque_b"
    delay_periods: int = 0

    channel = "torque_b"
    pulsed = True
    mean_output = ("torque", "angular_impulse")

    def init(self, n):
        return {
            "pending": jnp.zeros((self.delay_periods, 3, n)),
            "slot": jnp.zeros((), jnp.int64),
            "below_bit": jnp.zeros((3, n), jnp.int64),
        }

    def plan(self, command, x, state, period_s, key, t=0.0):
        wanted = command * period_s
        impulse = executed_impulse(wanted, self.impulse_bit_nms, self.torque_max_nm * period_s)
        below = (wanted != 0.0) & (impulse == 0.0)
        state = {**state, "below_bit": state["below_bit"] + below.astype(jnp.int64)}
        if self.delay_periods:
            slot = state["slot"]
            fire = state["pending"][slot]
            state = {
                **state,
                "pending": state["pending"].at[slot].set(impulse),
                "slot": (slot + 1) % self.delay_periods,
            }
        else:
            fire = impulse
        return Pulse(jnp.sign(fire) * self.torque_max_nm, jnp.abs(fire) / self.torque_max_nm), state

    def record(self, x, state):
        return {"commands_below_bit": state["below_bit"]}

    def account(self, pulse):
        """Angular impulse (signed and absolute) per axis, and per thruster couple the on-time
        and the valve openings of this period."""
        plus = jnp.where(pulse.level_nm > 0.0, pulse.t_off_s, 0.0)
        minus = jnp.where(pulse.level_nm < 0.0, pulse.t_off_s, 0.0)
        on = jnp.stack([plus, minus], axis=1).reshape(6, *plus.shape[1:])
        return {
            "angular_impulse": pulse.level_nm * pulse.t_off_s,
            "impulse": jnp.abs(pulse.level_nm) * pulse.t_off_s,
            "thruster_on_time": on,
            "thruster_firings": (on > 0.0).astype(jnp.int64),
        }

    def output_specs(self):
        thrusters = (("thruster", THRUSTERS),)
        return {
            "angular_impulse": OutputSpec(
                ("component",), "N m s", "body", "cumulative signed angular impulse of the cold-gas thrusters, from t = 0 to the sample"
            ),
            "impulse": OutputSpec(
                ("component",), "N m s", "body", "cumulative absolute angular impulse of the cold-gas thrusters, from t = 0 to the sample"
            ),
            "torque": OutputSpec(
                ("component",), "N m", "body", "mean torque of the cold-gas thrusters over the record interval starting at the sample"
            ),
            "thruster_on_time": OutputSpec(
                ("thruster",), "s", "", "cumulative valve-open time of each thruster couple, from t = 0 to the sample", coords=thrusters
            ),
            "thruster_firings": OutputSpec(
                ("thruster",), "1", "", "cumulative valve openings (periods with a pulse) of each thruster couple", coords=thrusters
            ),
            "commands_below_bit": OutputSpec(
                ("component",), "1", "body",
                "cumulative number of nonzero commands per axis not executed (below the minimum impulse bit), before the sample",
            ),
        }
