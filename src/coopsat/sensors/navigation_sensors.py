"""Navigation sensors of an orbit: a GNSS receiver, an inter-satellite range / range-rate link and
a camera's bearing to another spacecraft.

Each reads a derived quantity (sensor protocol as in :mod:`coopsat.sensors.parts`), its truth
computed from the plant state, component-major ``(k, n)``, spacecraft last:

* ``"gnss"`` (6, n): each spacecraft's own absolute fix, ECI (GCRF): rows ``x, y, z`` (m) and
  ``vx, vy, vz`` (m/s);
* ``"isl"`` (3, n): each spacecraft's range (m) and range-rate (m/s) to one target spacecraft
  and whether the link is valid (1/0);
* ``"bearing"`` (4, n): each spacecraft's unit line of sight to one target spacecraft in its
  own body axes and whether the target is in the camera's view (1/0).

GNSS error model, per component::

    reading_i = truth_i + common(t) + own_i(t) + white_i

``white_i`` is white Gaussian noise; ``own_i`` is a first-order Gauss–Markov process per
receiver; ``common`` is one Gauss–Markov process shared by every receiver of the run (the
errors of nearby receivers: ephemeris, clock, atmosphere). The difference of two receivers'
readings taken at the same instant therefore has no common error at all: relative navigation
by differencing two fixes sees only the own and white errors.

Noise comes only from the key given to ``measure``: every term folds its own tag into it,
spacecraft i draws from ``fold_in(key, i)`` (:func:`coopsat.core.parts.per_spacecraft_normal`)
so its draws do not depend on the formation size, and the common term is drawn once per call,
not per spacecraft. A run replays bit for bit from its seed.
"""

from typing import NamedTuple

import jax
import jax.numpy as jnp

from coopsat.core.parts import OutputSpec, part, per_spacecraft_normal
from coopsat.geometry.quaternion import cross, quat_rotate_inverse
from coopsat.sensors.noise import white_noise

# Tags folded into the sensor's key, one per noise term, so the terms never share draws.
_WHITE = 1
_OWN = 2
_COMMON = 3


class GnssState(NamedTuple):
    """The GNSS receiver's Gauss–Markov errors as of its last call.

    Attributes
    ----------
    common : (6,)
        The error every receiver shares: position (m) and velocity (m/s), ECI.
    own : (6, n)
        Each receiver's own error, m and m/s, ECI.
    started : bool scalar
        Whether ``measure`` has been called: the first call draws the errors from their
        stationary distribution instead of stepping them.
    """

    common: jax.Array
    own: jax.Array
    started: jax.Array


def gauss_markov_step(e, nu, sigma, tau_s, step_s, started):
    """One step of a stationary first-order Gauss–Markov process.

    ``e ← φ e + σ √(1 − φ²) ν`` with ``φ = exp(−T/τ)``, or ``e = σ ν`` (a draw from the
    stationary distribution) when the process has not ``started``.

    Parameters
    ----------
    e : (6,) or (6, n)
        Error at the previous step, in the units of ``sigma``.
    nu : same shape as ``e``
        Standard normal draws of this step.
    sigma : (6,)
        Stationary standard deviation per component (broadcast over any spacecraft axis).
    tau_s : scalar
        Correlation time τ, s (> 0).
    step_s : scalar
        Step T, s.
    started : bool scalar

    Returns
    -------
    jax.Array, shape of ``e``
    """
    sigma = jnp.reshape(sigma, sigma.shape + (1,) * (e.ndim - 1))
    phi = jnp.exp(-step_s / tau_s)
    # 1 − φ² as −expm1(−2T/τ): exact to rounding when T ≪ τ, where 1 − φ² would cancel.
    stepped = phi * e + sigma * jnp.sqrt(-jnp.expm1(-2.0 * step_s / tau_s)) * nu
    return jnp.where(started, stepped, sigma * nu)


@part(static=("every",))
class Gnss:
    """GNSS receiver: each spacecraft's own ECI position and velocity with white noise, its own
    Gauss–Markov error and a Gauss–Markov error common to every receiver of the run.

    The reading is ``(6, n)``: rows ``x, y, z`` (m) and ``vx, vy, vz`` (m/s), ECI (GCRF).
    Each call of ``measure`` (every control period, also between the updates of a slow
    receiver) steps both Gauss–Markov processes by ``step_s`` and reads
    ``truth + common + own + white``; the first call draws them from their stationary
    distribution, so the errors are stationary from t = 0.

    Attributes
    ----------
    sigma : (6,)
        Standard deviation of the white noise, m (position) and m/s (velocity), per ECI axis.
    own_sigma : (6,)
        Stationary standard deviation of each receiver's own Gauss–Markov error, m and m/s.
    own_tau_s : scalar
        Correlation time of the own error, s (> 0).
    common_sigma : (6,)
        Stationary standard deviation of the common Gauss–Markov error, m and m/s.
    common_tau_s : scalar
        Correlation time of the common error, s (> 0).
    step_s : scalar
        Time between two calls of ``measure``, s: the control period.
    every : int
        Static: control periods between updates (the reading is held in between).
    """

    sigma: jnp.ndarray
    own_sigma: jnp.ndarray
    own_tau_s: jnp.ndarray
    common_sigma: jnp.ndarray
    common_tau_s: jnp.ndarray
    step_s: jnp.ndarray
    every: int = 1

    quantity = "gnss"
    needs = ("r_eci", "v_eci")

    def truth(self, y, x, t=0.0):
        """True ECI position (m) and velocity (m/s) from the plant state, (6, n)."""
        return jnp.concatenate([x.r_eci, x.v_eci], axis=0)

    def init(self, truth_value, n):
        """Zero errors, not yet started (:class:`GnssState`)."""
        return GnssState(jnp.zeros(6), jnp.zeros((6, n)), jnp.zeros((), dtype=bool))

    def measure(self, truth_value, x, state, key):
        """The fixes (6, n), m and m/s, ECI, and the errors after this call."""
        n = truth_value.shape[-1]
        # One draw for the whole run's receivers: the common error is the same for all.
        nu_common = jax.random.normal(jax.random.fold_in(key, _COMMON), (6,))
        common = gauss_markov_step(
            state.common, nu_common, self.common_sigma, self.common_tau_s, self.step_s, state.started
        )
        nu_own = per_spacecraft_normal(jax.random.fold_in(key, _OWN), 6, n)
        own = gauss_markov_step(state.own, nu_own, self.own_sigma, self.own_tau_s, self.step_s, state.started)
        value = white_noise(truth_value + common[:, None] + own, jax.random.fold_in(key, _WHITE), self.sigma)
        return value, GnssState(common, own, jnp.ones((), dtype=bool))

    def output_specs(self):
        return {
            "measured_gnss": OutputSpec(
                ("gnss_component",), "m, m/s", "ECI",
                "position (x, y, z in m) and velocity (vx, vy, vz in m/s) as fixed by the spacecraft's GNSS receiver, "
                "at the sample",
                coords=(("gnss_component", ("x", "y", "z", "vx", "vy", "vz")),),
            )
        }


def _to_target(r_eci, target):
    """Every spacecraft's vector to one target (3, n), m, its length (n,), m, and which column
    is the target itself (n,). The target's own vector is zero: its length is taken as 1 there,
    so that neither a division by it nor its gradient is NaN."""
    rho = r_eci[:, target][:, None] - r_eci
    is_target = jnp.arange(r_eci.shape[-1]) == target
    return rho, jnp.sqrt(jnp.where(is_target, 1.0, jnp.sum(rho**2, axis=0))), is_target


def range_and_rate(r_eci, v_eci, target):
    """Every spacecraft's range and range-rate to one target spacecraft.

    Parameters
    ----------
    r_eci, v_eci : (3, n)
        Positions (m) and velocities (m/s), ECI.
    target : int scalar
        Index of the target spacecraft.

    Returns
    -------
    range_m : (n,)
        ``|r_target − r_i|``, m; 0 for the target itself.
    range_rate_m_s : (n,)
        ``d|ρ|/dt = ρ · (v_target − v_i) / |ρ|``, m/s; 0 for the target itself.
    """
    rho, distance, is_target = _to_target(r_eci, target)
    rho_dot = v_eci[:, target][:, None] - v_eci
    rate = jnp.sum(rho * rho_dot, axis=0) / distance
    return jnp.where(is_target, 0.0, distance), jnp.where(is_target, 0.0, rate)


@part(static=("every",))
class IslRange:
    """Inter-satellite link: each spacecraft's range and range-rate to one target spacecraft,
    with constant biases and white noise.

    The reading is ``(3, n)``: rows range (m), range-rate (m/s) and ``valid`` (1/0). The link is
    invalid (its row zero) for the target itself and beyond ``max_range_m``.

    Attributes
    ----------
    sigma : (2,)
        Standard deviation of the white noise of the range (m) and range-rate (m/s).
    bias : (2,)
        Constant bias of the range (m) and range-rate (m/s), every spacecraft.
    target : int scalar
        Index of the target spacecraft.
    max_range_m : scalar
        Longest range of a valid link, m (``inf``: no limit).
    every : int
        Static: control periods between updates.
    """

    sigma: jnp.ndarray
    bias: jnp.ndarray
    target: jnp.ndarray
    max_range_m: jnp.ndarray
    every: int = 1

    quantity = "isl"
    needs = ("r_eci", "v_eci")

    def truth(self, y, x, t=0.0):
        """True range (m), range-rate (m/s) and ``valid`` from the plant state, (3, n); zero
        where the link is invalid."""
        distance, rate = range_and_rate(x.r_eci, x.v_eci, self.target)
        n = distance.shape[-1]
        valid = ((jnp.arange(n) != self.target) & (distance <= self.max_range_m)).astype(distance.dtype)
        return jnp.stack([distance * valid, rate * valid, valid])

    def init(self, truth_value, n):
        return ()

    def measure(self, truth_value, x, state, key):
        """The noisy range and range-rate where the link is valid, (3, n)."""
        valid = truth_value[2:]
        noisy = white_noise(truth_value[:2] + self.bias[:, None], key, self.sigma)
        # where, not a product: an invalid link reads +0.0, not the noise's sign of zero.
        return jnp.concatenate([jnp.where(valid > 0.0, noisy, 0.0), valid], axis=0), state

    def output_specs(self):
        return {
            "measured_isl": OutputSpec(
                ("isl_component",), "m, m/s, 1", "",
                "range (m) and range-rate (m/s) to the target spacecraft as measured over the inter-satellite link, "
                "and whether the link was valid (1/0), at the sample",
                coords=(("isl_component", ("range", "range_rate", "valid")),),
            )
        }


def line_of_sight(r_eci, q_bi, target):
    """Every spacecraft's unit line of sight to one target spacecraft, in its own body axes.

    Parameters
    ----------
    r_eci : (3, n)
        Positions, m, ECI.
    q_bi : (4, n)
        Attitudes (scalar-first, body to inertial).
    target : int scalar
        Index of the target spacecraft.

    Returns
    -------
    los_b : (3, n)
        ``q_bi* ⊗ (r_target − r_i)/|r_target − r_i| ⊗ q_bi``; zero for the target itself.
    distance_m : (n,)
        ``|r_target − r_i|``, m; 0 for the target itself.
    """
    rho, distance, is_target = _to_target(r_eci, target)
    los_b = quat_rotate_inverse(q_bi, rho / distance, 0)
    return jnp.where(is_target, 0.0, los_b), jnp.where(is_target, 0.0, distance)


def rotate_across(u, dtheta):
    """Unit vectors ``u`` turned by small rotations across themselves, renormalised.

    Parameters
    ----------
    u : (3, n)
        Unit vectors.
    dtheta : (3, n)
        Rotation vectors, rad; their components along ``u`` are removed first, so a rotation
        about the line of sight (which leaves it unchanged) does not count.

    Returns
    -------
    jax.Array, (3, n)
        ``normalise(cos|δ| u + sin|δ| δ̂ × u)`` with ``δ = dθ − (dθ·u) u`` (Rodrigues' formula
        for δ ⊥ u).
    """
    across = dtheta - jnp.sum(dtheta * u, axis=0) * u
    angle = jnp.sqrt(jnp.sum(across**2, axis=0))
    # sin|δ|/|δ| → 1 as |δ| → 0, without dividing by zero.
    sinc = jnp.sinc(angle / jnp.pi)
    turned = jnp.cos(angle) * u + sinc * cross(across, u, 0)
    return turned / jnp.linalg.norm(turned, axis=0)


@part(static=("every",))
class CameraBearing:
    """Camera: each spacecraft's unit line of sight to one target spacecraft in its body axes,
    turned by a small random rotation across the line of sight.

    The reading is ``(4, n)``: rows ``x, y, z`` (body axes, unit) and ``valid`` (1/0). The line of
    sight is valid when the target is within ``fov_half_angle`` of the boresight and no further
    than ``max_range_m``; an invalid column (and the target's own) is zero.

    Attributes
    ----------
    sigma_rad : scalar
        Standard deviation of the angular error about each axis across the line of sight, rad.
    boresight_b : (3,)
        The camera's axis, body frame, unit.
    cos_half_fov : scalar
        Cosine of the field of view's half angle.
    target : int scalar
        Index of the target spacecraft.
    max_range_m : scalar
        Farthest target seen, m (``inf``: no limit).
    every : int
        Static: control periods between updates.
    """

    sigma_rad: jnp.ndarray
    boresight_b: jnp.ndarray
    cos_half_fov: jnp.ndarray
    target: jnp.ndarray
    max_range_m: jnp.ndarray
    every: int = 1

    quantity = "bearing"
    needs = ("q", "r_eci")

    def truth(self, y, x, t=0.0):
        """True line of sight in body axes and ``valid`` from the plant state, (4, n); zero where
        invalid."""
        los_b, distance = line_of_sight(x.r_eci, x.q_bi, self.target)
        n = distance.shape[-1]
        in_view = self.boresight_b @ los_b >= self.cos_half_fov
        valid = (jnp.arange(n) != self.target) & in_view & (distance <= self.max_range_m)
        return jnp.concatenate([jnp.where(valid, los_b, 0.0), valid[None].astype(los_b.dtype)], axis=0)

    def init(self, truth_value, n):
        return ()

    def measure(self, truth_value, x, state, key):
        """The noisy line of sight where valid, (4, n); the truth itself when ``sigma_rad`` is 0."""
        n = truth_value.shape[-1]
        valid = truth_value[3:]
        dtheta = self.sigma_rad * per_spacecraft_normal(key, 3, n)
        # An invalid column's zero vector would turn into NaN: turn a unit vector there instead.
        u = jnp.where(valid > 0.0, truth_value[:3], jnp.array([1.0, 0.0, 0.0])[:, None])
        noisy = jnp.where(self.sigma_rad == 0.0, truth_value[:3], rotate_across(u, dtheta))
        return jnp.concatenate([jnp.where(valid > 0.0, noisy, 0.0), valid], axis=0), state

    def output_specs(self):
        return {
            "measured_bearing": OutputSpec(
                ("bearing_component",), "1", "body",
                "unit line of sight to the target spacecraft as measured by the spacecraft's camera, and whether the "
                "target was in view (valid, 1/0), at the sample",
                coords=(("bearing_component", ("x", "y", "z", "valid")),),
            )
        }
