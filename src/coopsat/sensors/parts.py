"""In-loop sensor parts: star tracker, rate gyro, navigation (position / velocity) noise, and
relative position.

Each part replaces one quantity of the measurement dictionary the controller sees (the engine's
sensor protocol, docs/architecture.md §4):

* ``quantity`` (class attribute, or a static field): the key it replaces, ``"q"`` (4, n),
  ``"omega"`` (3, n), ``"r_eci"`` or ``"v_eci"`` (3, n); or a quantity the sensor derives from
  the plant state (``"rho"``, the relative positions, (4, n, n));
* ``needs`` (the state quantities its truth comes from) and ``truth(y, x)`` (the true value of
  what it reads, from the true quantities ``y`` or the plant state ``x``): a state quantity's
  sensor takes it from ``y`` (:class:`_StateSensor`);
* ``every`` (static int ≥ 1): the reading updates every ``every`` control periods and is held
  in between (the engine holds it; ``measure`` is still called every period, so a state such
  as the gyro bias advances every control period);
* ``init(truth_value, n) -> state`` and ``measure(truth_value, x, state, key) -> (value,
  state)``, component-major ``(k, n)``; ``key`` is already specific to this sensor and period.

Every noise term comes from :mod:`coopsat.sensors.noise` (spacecraft i draws from
``fold_in(key, i)``), so a run replays bit for bit from its seed.
"""


import jax.numpy as jnp

from coopsat.core.parts import OutputSpec, part
from coopsat.geometry.frames import eci_to_lvlh
from coopsat.sensors.noise import gyro_bias_step, gyro_measure, per_spacecraft_normal, star_tracker_measure, white_noise


class _StateSensor:
    """What a sensor of one plant state quantity shares: it needs that quantity and reads its
    true value."""

    @property
    def needs(self):
        return (self.quantity,)

    def truth(self, y, x, t=0.0):
        return y[self.quantity]


@part(static=("every",))
class StarTracker(_StateSensor):
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
class Gyro(_StateSensor):
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
class NavigationNoise(_StateSensor):
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


def relative_positions(r_eci):
    """Every spacecraft's view of every other: ``rho[:, j, i] = r_j − r_i``, m.

    Parameters
    ----------
    r_eci : (3, n)
        Positions, component-major.

    Returns
    -------
    jax.Array, (3, n, n)
        Component, target j, observer i (the observer last, as every per-spacecraft array in
        the loop).
    """
    return r_eci[:, :, None] - r_eci[:, None, :]


@part(static=("names", "every"))
class RelativePosition:
    """Relative-position sensor (SPEC §4): each spacecraft measures the vector to every other
    it has a line of sight to, in inertial axes, with white noise; no absolute position.

    The reading is ``(4, n, n)``: rows x, y, z (m) and ``valid`` (1 when the line of sight is
    open, else 0, with the vector zeroed), target j, observer i. A line of sight is blocked in
    both directions during each of its windows ``[t_start, t_end)``.

    Attributes
    ----------
    sigma_m : (3,)
        Standard deviation per inertial axis, m (each observer draws its own noise).
    blocked_pairs : int (B, 2)
        Spacecraft indices of each blocked line of sight (B ≥ 1; a dummy window that never
        opens when none is blocked).
    blocked_windows_s : (B, 2)
        Start and end of each blockage, s.
    step_s : scalar
        Time between two calls of ``measure`` (the control period), s.
    names : tuple of str
        Static: spacecraft names (the ``target`` coordinate of the recorded reading).
    every : int
        Static: control periods between updates.

    Notes
    -----
    The sensor's state is the time of its next reading, s: it advances ``step_s`` per call.
    """

    sigma_m: jnp.ndarray
    blocked_pairs: jnp.ndarray
    blocked_windows_s: jnp.ndarray
    step_s: jnp.ndarray
    names: tuple = ()
    every: int = 1

    quantity = "rho"
    needs = ("r_eci",)

    def truth(self, y, x, t=0.0):
        """True vectors (from the plant state, not another sensor's reading) and ``valid = 1``."""
        n = x.r_eci.shape[-1]
        return jnp.concatenate([relative_positions(x.r_eci), jnp.ones((1, n, n))], axis=0)

    def init(self, truth_value, n):
        return jnp.zeros(())

    def open_lines(self, t_s, n):
        """(n, n) 1.0 where the line of sight between j and i is open at ``t_s``, else 0.0."""
        a, b = self.blocked_pairs[:, 0], self.blocked_pairs[:, 1]
        active = (t_s >= self.blocked_windows_s[:, 0]) & (t_s < self.blocked_windows_s[:, 1])
        hit = jnp.zeros((n, n)).at[a, b].max(active.astype(float)).at[b, a].max(active.astype(float))
        return 1.0 - hit

    def measure(self, truth_value, x, state, key):
        """The noisy vectors where the line of sight is open, (4, n, n), and the next time."""
        n = truth_value.shape[-1]
        noise = per_spacecraft_normal(key, 3 * n, n).reshape(3, n, n) * self.sigma_m[:, None, None]
        # A spacecraft knows its own position relative to itself exactly.
        noise = noise * (1.0 - jnp.eye(n))
        valid = self.open_lines(state, n)
        rho = (truth_value[:3] + noise) * valid
        return jnp.concatenate([rho, valid[None]], axis=0), state + self.step_s

    def output_specs(self):
        return {
            "measured_rho": OutputSpec(
                ("rel_component", "target"), "m", "ECI",
                "relative position of each target as measured by the spacecraft (r_target - r_spacecraft), "
                "and whether its line of sight was open (valid, 1/0), at the sample",
                coords=(("rel_component", ("x", "y", "z", "valid")), ("target", self.names)),
            )
        }


@part(static=("every",))
class RelativeNavigation:
    """Relative navigation (SPEC §2): each spacecraft's state relative to a reference spacecraft
    (the chief), in the chief's LVLH frame, with white noise per axis.

    The reading is ``(6, n)``: rows ``x, y, z`` (m) and ``ẋ, ẏ, ż`` (m/s, as seen in the
    rotating frame), :func:`coopsat.geometry.frames.eci_to_lvlh` of the true ECI states. The
    reference spacecraft's own column is zero and exact: its state relative to itself is known.

    Attributes
    ----------
    sigma : (6,)
        Standard deviation of the position (m) and velocity (m/s) error per LVLH axis.
    chief : int scalar
        Index of the reference spacecraft.
    every : int
        Static: control periods between updates.
    """

    sigma: jnp.ndarray
    chief: jnp.ndarray
    every: int = 1

    quantity = "x_lvlh"
    needs = ("r_eci", "v_eci")

    def truth(self, y, x, t=0.0):
        """True relative states (from the plant state), (6, n)."""
        r_c, v_c = x.r_eci[:, self.chief][:, None], x.v_eci[:, self.chief][:, None]
        rho, rho_dot = eci_to_lvlh(r_c, v_c, x.r_eci, x.v_eci, axis=0)
        return jnp.concatenate([rho, rho_dot], axis=0)

    def init(self, truth_value, n):
        return ()

    def measure(self, truth_value, x, state, key):
        """The noisy relative states (6, n); the reference spacecraft's column exactly zero."""
        n = truth_value.shape[-1]
        noisy = white_noise(truth_value, key, self.sigma)
        return jnp.where(jnp.arange(n) == self.chief, 0.0, noisy), state

    def output_specs(self):
        return {
            "measured_x_lvlh": OutputSpec(
                ("lvlh_state",), "m, m/s", "LVLH",
                "state relative to the chief in its LVLH frame as measured by the spacecraft's relative navigation "
                "(x, y, z in m; vx, vy, vz in m/s, rotating-frame rates), at the sample",
                coords=(("lvlh_state", ("x", "y", "z", "vx", "vy", "vz")),),
            )
        }
