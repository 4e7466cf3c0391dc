"""In-loop sensor parts: star tracker, rate gyro and navigation (position / velocity) noise.

Each part replaces one quantity of the measurement dictionary the controller sees (the engine's
sensor protocol, docs/architecture.md §4):

* ``quantity`` (class attribute, or a static field): the key it replaces, ``"q"`` (4, n),
  ``"omega"`` (3, n), ``"r_eci"`` or ``"v_eci"`` (3, n);
* ``every`` (static int ≥ 1): the reading updates every ``every`` control periods and is held
  in between (the engine holds it; ``measure`` is still called every period, so a state such
  as the gyro bias advances every control period);
* ``init(truth_value, n) -> state`` and ``measure(truth_value, x, state, key) -> (value,
  state)``, component-major ``(k, n)``; ``key`` is already specific to this sensor and period.

Every noise term comes from :mod:`coopsat.sensors.noise` (spacecraft i draws from
``fold_in(key, i)``), so a run replays bit for bit from its seed.
"""

from coopsat import _jax  # noqa: F401

import jax.numpy as jnp

from coopsat._parts import part
from coopsat.sensors.noise import gyro_bias_step, gyro_measure, star_tracker_measure, white_noise


@part(static=("every",))
class StarTracker:
    """Star tracker: the attitude ``q_bi ⊗ δq`` with a small error rotation in the body frame.

    Attributes
    ----------
    sigma_rad : array, shape (3,)
        Standard deviation of the error rotation δθ about each body axis, rad
        (10 arcsec = 4.848e-5 rad); ``δq = exp(½ [0, δθ])``.
    every : int
        Static: control periods between updates (the reading is held in between).
    """

    sigma_rad: jnp.ndarray
    every: int = 1

    quantity = "q"

    def init(self, truth_value, n):
        return ()

    def measure(self, truth_value, x, state, key):
        """Measured unit quaternions (4, n), on the hemisphere of the true ones.

        With ``sigma_rad`` zero on every axis the reading is the true quaternion itself (no
        renormalisation rounding), so a perfect star tracker replays the sensor-free run exactly.
        """
        measured = star_tracker_measure(truth_value, key, self.sigma_rad)
        return jnp.where(jnp.all(self.sigma_rad == 0.0), truth_value, measured), state

    def output_specs(self):
        return {}


@part(static=("every",))
class Gyro:
    """Rate gyro: the body rate plus a random-walk bias plus white noise, rad/s, body frame.

    ``ω_meas = ω + b + σ ν`` with ``ν ~ N(0, 1)`` per axis and sample; the bias starts at
    ``bias0_rad_s`` and walks ``b ← b + σ_rw √Δt ν'`` each time ``measure`` is called
    (after the reading is taken), so after a time t it has spread ``σ_rw √t`` per axis.

    Attributes
    ----------
    sigma_rad_s : array, shape (3,)
        Standard deviation of the rate noise of one reading, rad/s, per body axis.
    bias_rw_rad_s_sqrt_s : array, shape (3,)
        Bias random walk σ_rw, rad/s/√s (rad·s^-3/2), per body axis; 0: constant bias.
    bias0_rad_s : array, shape (3,)
        Bias at t = 0, rad/s, body frame (the same for every spacecraft).
    step_s : scalar
        Time between two calls of ``measure``, s: the control period (the engine calls
        ``measure`` every period and holds the reading between updates, so the bias walks every
        control period whatever ``every`` is).
    every : int
        Static: control periods between updates of the reading.
    """

    sigma_rad_s: jnp.ndarray
    bias_rw_rad_s_sqrt_s: jnp.ndarray
    bias0_rad_s: jnp.ndarray
    step_s: jnp.ndarray
    every: int = 1

    quantity = "omega"

    def init(self, truth_value, n):
        """The bias of every spacecraft, (3, n), rad/s."""
        return jnp.zeros((3, n)) + self.bias0_rad_s[:, None]

    def measure(self, truth_value, x, state, key):
        """Measured body rate (3, n), rad/s, and the bias of the next call."""
        value = gyro_measure(truth_value, state, key, self.sigma_rad_s)
        return value, gyro_bias_step(state, key, self.bias_rw_rad_s_sqrt_s, self.step_s)

    def output_specs(self):
        return {}


@part(static=("quantity", "every"))
class NavigationNoise:
    """Navigation error: the ECI position or velocity plus white Gaussian noise.

    Attributes
    ----------
    sigma : array, shape (3,)
        Standard deviation per ECI axis: m for ``"r_eci"``, m/s for ``"v_eci"``.
    quantity : {"r_eci", "v_eci"}
        Static: the quantity it replaces (present only when the run has an orbit).
    every : int
        Static: control periods between updates (the reading is held in between).
    """

    sigma: jnp.ndarray
    quantity: str = "r_eci"
    every: int = 1

    def init(self, truth_value, n):
        return ()

    def measure(self, truth_value, x, state, key):
        """Measured position (m) or velocity (m/s), ECI, (3, n)."""
        return white_noise(truth_value, key, self.sigma), state

    def output_specs(self):
        return {}
