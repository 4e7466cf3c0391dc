"""Absolute orbit navigation in each spacecraft's flight software: an extended Kalman filter of
its own ECI position and velocity on its GNSS fixes.

State ``x = [r_eci, v_eci]`` (6,), m and m/s, GCRF axes, as the ``r_eci`` and ``v_eci`` a law
reads (the observation law points at a ground target from them). Per control period of length T,
at its start:

1. **GNSS update** (the spacecraft's own fix, H = I) when the receiver read this period. The
   measurement noise is the receiver's whole error, white, own and common (a single receiver
   sees all of it), each taken as white: the Gauss–Markov terms are correlated over their τ, which
   the filter does not model (its NEES shows it).
2. The law reads the posterior; the estimate is carried to the next period by ``substeps`` RK4
   steps of two-body + J2 gravity under the law's commanded ``force_eci`` (none for a law that
   commands only torques), the covariance by the Jacobian of that same discrete map
   (``jax.jacfwd``: the propagator's exact state-transition matrix) and the process noise of a
   white acceleration of spectral density ``q`` per ECI axis,
   ``Q = q [[T³/3 I, T²/2 I], [T²/2 I, T I]]`` (the double integrator's, made at design time by
   :func:`coopsat.design.riccati.sampled_noise`).

Notes
-----
The filter's dynamics are the design model of the papers' orbits (SPEC §5: two-body with J2);
drag, the field beyond J2 and the Sun and Moon are left to the process noise.
"""

import jax
import jax.numpy as jnp
import numpy as np

from coopsat.control.relative_ekf import drawn_initial, joseph_update, sensor_due
from coopsat.core.parts import OutputSpec, part
from coopsat.dynamics.translational import j2_accel, two_body_accel

_STATE = ("x", "y", "z", "vx", "vy", "vz")
_DRAW = 19  # tag of the initial-error draw in the filter's key


@part(static=("substeps", "gnss_every", "draw_initial"))
class OrbitEkf:
    """One spacecraft's absolute orbit EKF (see the module docstring).

    Attributes
    ----------
    q_d : (6, 6)
        Process noise over one control period.
    x0_eci : (6, n)
        Each spacecraft's initial estimate (the scenario's initial state), m, m/s.
    sigma0 : (6,)
        Initial standard deviation per state, m, m/s.
    r_gnss_eci : (6,)
        Variance of one fix's error per ECI axis, m², m²/s².
    mass_kg : (n,)
    mu_m3_s2, j2, r_body_m : scalar
        The filter's gravity model.
    period_s : scalar
    substeps : int
        Static: RK4 steps per control period.
    gnss_every : int
        Static: control periods between fixes.
    draw_initial : bool
        Static: start from ``x0 + σ₀ ν`` (ν from the spacecraft's key), not from ``x0``.
    """

    q_d: jnp.ndarray
    x0_eci: jnp.ndarray
    sigma0: jnp.ndarray
    r_gnss_eci: jnp.ndarray
    mass_kg: jnp.ndarray
    mu_m3_s2: jnp.ndarray
    j2: jnp.ndarray
    r_body_m: jnp.ndarray
    period_s: jnp.ndarray
    substeps: int = 4
    gnss_every: int = 1
    draw_initial: bool = True

    provides = ("r_eci", "v_eci")
    reads = ("gnss",)
    reads_own = False

    def init(self, n):
        """Every spacecraft's filter before its first period: the prior and the clock (s)."""
        p0 = jnp.diag(self.sigma0**2)
        return {"x": jnp.asarray(self.x0_eci), "p": jnp.broadcast_to(p0[:, :, None], (6, 6, n)), "clock_s": jnp.zeros(n)}

    def check_law(self, law, kind):
        """A law that commands a force other than ``force_eci`` moves the orbit in a way this
        filter does not propagate."""
        moving = [c for c in law.commands if c.startswith("force") and c != "force_eci"]
        return (f"the orbit filter propagates force_eci; controller kind '{kind}' commands {', '.join(moving)}"
                if moving else None)

    def estimate_of(self, i, state_i):
        """``{"r_eci": (3,), "v_eci": (3,)}`` of the estimate in ``state_i``."""
        return {"r_eci": state_i["x"][:3], "v_eci": state_i["x"][3:]}

    def outbox_one(self, i, y_i, state_i):
        """An orbit filter needs nothing from the others."""
        return {}

    def update_one(self, i, t, y_i, inbox_i, state_i, key_i):
        """Spacecraft i's posterior at t: (state, ``estimate_of`` it, record)."""
        if self.draw_initial:
            state_i = drawn_initial(state_i, key_i, self.sigma0, _DRAW)
        use = sensor_due(t, self.period_s, self.gnss_every)
        x, p, nis = joseph_update(state_i["x"], state_i["p"], y_i["gnss"] - state_i["x"], jnp.eye(6),
                                  jnp.diag(self.r_gnss_eci))
        state_i = {**state_i, "x": jnp.where(use, x, state_i["x"]), "p": jnp.where(use, p, state_i["p"])}
        record = {"nav_estimate_eci": state_i["x"], "nav_covariance_eci": state_i["p"],
                  "nav_nis": jnp.where(use, nis, 0.0)[None], "nav_updated": use.astype(float)[None]}
        return state_i, self.estimate_of(i, state_i), record

    def _propagate(self, x, accel_eci):
        """The filter's model over one control period: RK4, two-body + J2, constant ``accel_eci``."""
        h = self.period_s / self.substeps

        def rate(s):
            r = s[:3]
            return jnp.concatenate([s[3:], two_body_accel(r, self.mu_m3_s2) + j2_accel(r, self.mu_m3_s2, self.j2,
                                                                                      self.r_body_m) + accel_eci])

        def step(s, _):
            k1 = rate(s)
            k2 = rate(s + 0.5 * h * k1)
            k3 = rate(s + 0.5 * h * k2)
            k4 = rate(s + h * k3)
            return s + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4), None

        return jax.lax.scan(step, x, None, length=self.substeps)[0]

    def predict_one(self, i, state_i, commands):
        """The prior at the next period's start under the law's ``force_eci`` (3,), N, if any."""
        accel = commands["force_eci"] / self.mass_kg[i] if "force_eci" in commands else jnp.zeros(3)
        x = state_i["x"]
        phi = jax.jacfwd(self._propagate)(x, accel)
        return {**state_i, "x": self._propagate(x, accel), "p": phi @ state_i["p"] @ phi.T + self.q_d,
                "clock_s": state_i["clock_s"] + self.period_s}

    def true_state(self, r_eci, v_eci):
        """The truth of the estimate: each spacecraft's ECI state, (T, n, 6) NumPy."""
        return np.concatenate([np.asarray(r_eci), np.asarray(v_eci)], axis=-1)

    def estimated(self, n):
        return list(range(n))

    def output_specs(self):
        state = (("nav_state", _STATE),)
        measurement = (("nav_measurement", ("gnss",)),)
        return {
            "nav_estimate_eci": OutputSpec(
                ("nav_state",), "m, m/s", "ECI",
                "own position and velocity estimated by the spacecraft's orbit filter, after the period's fix, at the sample",
                coords=state,
            ),
            "nav_covariance_eci": OutputSpec(
                ("nav_state", "nav_state_col"), "m2, m2/s, m2/s2", "ECI",
                "covariance of the orbit filter's estimate at the sample", coords=(("nav_state", _STATE), ("nav_state_col", _STATE)),
            ),
            "nav_nis": OutputSpec(("nav_measurement",), "1", "",
                                  "normalised innovation squared of the period's fix (chi-square with 6 dof; 0 when none)",
                                  coords=measurement),
            "nav_updated": OutputSpec(("nav_measurement",), "1", "", "1 when the filter used a fix this period, else 0",
                                      coords=measurement),
        }
