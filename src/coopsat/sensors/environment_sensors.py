"""Sensors of the orbital environment (SPEC §5): a sun sensor and a three-axis magnetometer.

Both read a derived quantity (sensor protocol as in :mod:`coopsat.sensors.parts`): the truth is
computed from the plant state and the time, component-major ``(k, n)``:

* ``"sun_b"`` (4, n): the unit vector to the Sun in body axes and whether the Sun is seen
  (``valid`` 1/0; 0 in the Earth's shadow, the vector then zero);
* ``"b_b"`` (3, n): the geomagnetic field in body axes, T (tilted dipole).
"""


import jax.numpy as jnp

from coopsat.core.parts import OutputSpec, part
from coopsat.astro.earth_orientation import EarthOrientation
from coopsat.astro.magnetic import dipole_field_gcrf
from coopsat.astro.sun import sun_position_eci_m, sunlit
from coopsat.geometry.quaternion import quat_rotate_inverse
from coopsat.sensors.noise import white_noise



@part(static=("every",))
class SunSensor:
    """Sun sensor: the direction to the Sun in body axes with a small angular error.

    ``ŝ_meas = normalise(ŝ + σ ν)``, ``ν ~ N(0, I₃)``: to first order an error rotation of
    standard deviation σ about each of the two axes across the line of sight. The field of
    view is taken as the whole sphere (a set of coarse sun sensors).

    Attributes
    ----------
    sigma_rad : (3,)
        Standard deviation per body axis, rad.
    jd0 : scalar
        Julian date of t = 0.
    every : int
        Static: control periods between updates.
    """

    sigma_rad: jnp.ndarray
    jd0: jnp.ndarray
    every: int = 1

    quantity = "sun_b"
    needs = ("q", "r_eci")

    def truth(self, y, x, t=0.0):
        """True direction to the Sun (parallax included) and whether it is lit, (4, n)."""
        to_sun = sun_position_eci_m(self.jd0 + t / 86400.0)[:, None] - x.r_eci
        s_eci = to_sun / jnp.linalg.norm(to_sun, axis=0)
        lit = sunlit(x.r_eci, s_eci, 0)
        return jnp.concatenate([quat_rotate_inverse(x.q_bi, s_eci, 0) * lit, lit[None]], axis=0)

    def init(self, truth_value, n):
        return ()

    def measure(self, truth_value, x, state, key):
        noisy = white_noise(truth_value[:3], key, self.sigma_rad)
        lit = truth_value[3:]
        # In shadow the vector is zero (and with σ = 0 so is its norm): divide by 1 there, not 0.
        norm = jnp.where(lit[0] > 0.0, jnp.linalg.norm(noisy, axis=0), 1.0)
        direction = noisy / norm * lit
        return jnp.concatenate([direction, lit], axis=0), state

    def output_specs(self):
        return {
            "measured_sun_b": OutputSpec(
                ("sun_component",), "1", "body",
                "unit vector to the Sun as measured by the sun sensor, and whether the Sun is seen (valid, 1/0), at the sample",
                coords=(("sun_component", ("x", "y", "z", "valid")),),
            )
        }


@part(static=("every",))
class Magnetometer:
    """Three-axis magnetometer: the geomagnetic field in body axes plus a constant bias and
    white noise, T.

    Attributes
    ----------
    sigma_t : (3,)
        Standard deviation of the noise per body axis, T.
    bias_t : (3,)
        Constant bias, body axes, T.
    earth : EarthOrientation
        The Earth's orientation over the run.
    every : int
        Static: control periods between updates.
    """

    sigma_t: jnp.ndarray
    bias_t: jnp.ndarray
    earth: EarthOrientation
    every: int = 1

    quantity = "b_b"
    needs = ("q", "r_eci")

    def truth(self, y, x, t=0.0):
        """True field in body axes, (3, n), T."""
        return quat_rotate_inverse(x.q_bi, dipole_field_gcrf(x.r_eci, t, self.earth, 0), 0)

    def init(self, truth_value, n):
        return ()

    def measure(self, truth_value, x, state, key):
        return white_noise(truth_value + self.bias_t[:, None], key, self.sigma_t), state

    def output_specs(self):
        return {
            "measured_b_b": OutputSpec(
                ("component",), "T", "body", "geomagnetic field as measured by the magnetometer, at the sample"
            )
        }
