"""Magnetorquers: three coils along the body axes whose dipole turns in the Earth's field
(SPEC §5, momentum dumping).

The commanded dipole ``m`` (A·m², body axes) is clipped per coil at ``dipole_max_am2`` and held
over the control period; the body feels ``L = m × B`` with ``B`` the tilted-dipole field
(:mod:`coopsat.astro.magnetic`) at the period's start. Over a period of 0.1–1 s the body field
turns by less than ω·T ≈ 1e-4 rad in inertial pointing, so holding it is exact to that order.
"""


import jax.numpy as jnp

from coopsat.core.parts import OutputSpec, part
from coopsat.actuators.pulses import Pulse
from coopsat.astro.earth_orientation import EarthOrientation
from coopsat.astro.magnetic import dipole_field_gcrf
from coopsat.geometry.quaternion import cross, quat_rotate_inverse


def magnetorquer_torque_b(dipole_b_am2, field_b_t, dipole_max_am2):
    """Torque of three body-axis coils, ``L = sat(m) × B``, N·m.

    Parameters
    ----------
    dipole_b_am2 : (3, n)
        Commanded dipole, body axes, A·m².
    field_b_t : (3, n)
        Geomagnetic field, body axes, T.
    dipole_max_am2 : scalar or (3, 1)
        Saturation of each coil, A·m².

    Returns
    -------
    (torque (3, n) N·m, applied dipole (3, n) A·m²)
    """
    m = jnp.clip(dipole_b_am2, -dipole_max_am2, dipole_max_am2)
    return cross(m, field_b_t, 0), m


@part(static=("command",))
class Magnetorquers:
    """Magnetorquer part: the commanded dipole, saturated per coil, turned into a body torque.

    Attributes
    ----------
    dipole_max_am2 : scalar
        Saturation of each coil, A·m².
    earth : EarthOrientation
        The Earth's orientation over the run (the field turns with the Earth).
    command : str
        Static: the controller command it executes (the dipole wanted, A·m², body axes).

    Notes
    -----
    The state is the dipole applied over the period that ends at the sample (recorded).
    """

    dipole_max_am2: jnp.ndarray
    earth: EarthOrientation
    command: str = "dipole_b"

    channel = "torque_b"
    pulsed = False
    mean_output = ("magnetic_torque", "magnetic_angular_impulse")

    def init(self, n):
        return jnp.zeros((3, n))

    def plan(self, command, x, state, period_s, key, t=0.0):
        field_eci = dipole_field_gcrf(x.r_eci, t, self.earth, 0)
        field_b = quat_rotate_inverse(x.q_bi, field_eci, 0)
        torque, dipole = magnetorquer_torque_b(command, field_b, self.dipole_max_am2)
        return Pulse(torque, jnp.full_like(torque, period_s)), dipole

    def record(self, x, state):
        return {"magnetorquer_dipole": state}

    def account(self, pulse):
        return {"magnetic_angular_impulse": pulse.level_nm * pulse.t_off_s}

    def output_specs(self):
        return {
            "magnetorquer_dipole": OutputSpec(
                ("component",), "A m2", "body", "dipole applied by the magnetorquers over the control period ending at the sample"
            ),
            "magnetic_angular_impulse": OutputSpec(
                ("component",), "N m s", "body", "cumulative angular impulse of the magnetorquers, from t = 0 to the sample"
            ),
            "magnetic_torque": OutputSpec(
                ("component",), "N m", "body", "mean magnetorquer torque over the record interval starting at the sample"
            ),
        }
