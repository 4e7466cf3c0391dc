"""Relative navigation in each spacecraft's flight software: an extended Kalman filter of its
state relative to the chief, in the chief's LVLH frame.

State ``x = [ρ, ρ̇]`` (6,): position (m) and rotating-frame velocity (m/s) relative to the chief,
the chief's LVLH axes (:mod:`coopsat.geometry.frames`), as the ``x_lvlh`` a law reads. Every
spacecraft runs its own copy (``vmap`` in the compiled loop, one process each in software in the
loop); the chief's estimate of itself is zero, exactly.

Per control period of length T, at its start t (``update_one``):

1. **Differential GNSS** (``gnss`` sensor): the chief broadcasts its own fix with the time it
   was taken; the network delivers it (late, lost, held); the receiver pairs it with its own fix
   of the same instant (``inbox.own``) and measures ``z = eci_to_lvlh(chief fix, own fix)``, the
   whole relative state (H = I). The receivers' common errors cancel in this difference.
   A fix τ = j T old (j ≤ the table's ``max_age_s / T``) is processed at its time stamp: it is
   carried forward with the filter's own model and its own known commands,
   ``z' = Φ_j (z − c_s) + c_t``, where ``c`` is the response of the filter's model to the
   spacecraft's own commands since t = 0 (each spacecraft broadcasts its ``c``, so the network
   returns the value of the fix's instant with it), and its noise is inflated to
   ``Φ_j R Φ_jᵀ + Q_j`` (Q_j: the process noise over j periods). Exact for the linear model and
   known commands; the correlation between ``Q_j`` and the present estimate's error is neglected
   (a small over-confidence for long delays). Older fixes, and fixes already used (a held
   message), are dropped.
2. **Inter-satellite range and range-rate** to the chief (``isl`` sensor):
   ``h(x) = [|ρ|, ρ·ρ̇/|ρ|]`` (the frame's rotation does not change a range), linearised about
   the prior (the EKF's only nonlinearity).

3. **Camera bearing** to the chief (``bearing`` sensor): the unit line of sight ``u`` the camera
   measures in body axes, turned into ECI with the spacecraft's measured attitude (``q``: a star
   tracker's, or the truth when no sensor measures it) and into LVLH axes with
   :func:`lvlh_dcm` of the spacecraft's OWN GNSS fix (which is why the bearing needs ``gnss``).
   Its own LVLH axes differ from the chief's by about ``|ρ|/r`` rad (1.5e-5 rad at 100 m in
   LEO), below a camera's noise. The model is the direction to the chief, ``h(x) = −ρ/|ρ|``;
   the residual is taken in a basis ``(e₁, e₂)`` across the predicted direction,
   ``z = [e₁·u, e₂·u]`` predicted ``[0, 0]`` (a 3-vector residual of a unit vector would have a
   singular 3×3 R), with ``H = [e₁; e₂] ∂h/∂x``, ``∂h/∂ρ = −(I − ĥĥᵀ)/|ρ|``, ``∂h/∂ρ̇ = 0``, and
   ``R = σ² I₂``. The update is invariant to the basis chosen across ``ĥ`` (R is isotropic).

All updates in Joseph form. Then the law reads the posterior, and the estimate is carried to
the next period with the Clohessy–Wiltshire model (``x⁺ = Φ x + Γ u``, ``P⁺ = Φ P Φᵀ + Q``),
``u`` the law's commanded ``force_lvlh`` over the spacecraft's mass (the thrusters' dead zone
and saturation are not modelled: process noise).

Notes
-----
Φ, Γ and Q are the exact zero-order-hold discretisation of the CW equations (SPEC §2 eq. 1)
with continuous white acceleration noise of spectral density ``q`` (Van Loan), computed at
design time (:func:`coopsat.plugins.navigation.relative_model`).
"""

import jax
import jax.numpy as jnp
import numpy as np
from jax.scipy.linalg import cho_factor, cho_solve

from coopsat.core.parts import OutputSpec, part
from coopsat.geometry.frames import eci_to_lvlh, lvlh_dcm
from coopsat.geometry.quaternion import quat_rotate

_STATE = ("x", "y", "z", "vx", "vy", "vz")
_DRAW = 17  # tag of the initial-error draw in the filter's key
_MEASUREMENTS = ("gnss", "isl", "bearing")  # the recorded nav_measurement coordinate


def joseph_update(x, p, residual, h, r):
    """One Kalman measurement update in Joseph form.

    Parameters
    ----------
    x : (6,), p : (6, 6)
        Prior estimate and covariance.
    residual : (m,)
        Measurement minus its prediction.
    h : (m, 6)
        Measurement Jacobian.
    r : (m, m)
        Measurement noise covariance.

    Returns
    -------
    x, p : the posterior; nis : scalar, ``νᵀ S⁻¹ ν`` (normalised innovation squared, χ²(m)).

    Notes
    -----
    S is symmetric positive definite: solved by its Cholesky factor (cheaper to compile and
    run than a pivoted LU, measured 15 % off a short navigated run's build).
    """
    s = h @ p @ h.T + r
    factor = cho_factor(s)
    gain = cho_solve(factor, h @ p).T  # P Hᵀ S⁻¹ (S and P symmetric)
    i_kh = jnp.eye(6) - gain @ h
    p_new = i_kh @ p @ i_kh.T + gain @ r @ gain.T
    return x + gain @ residual, 0.5 * (p_new + p_new.T), residual @ cho_solve(factor, residual)


def range_model(x):
    """Range (m) and range-rate (m/s) of a relative state (6,) and their Jacobian (2, 6).

    ``r = |ρ|``, ``ṙ = ρ·ρ̇/|ρ|``; ``∂ṙ/∂ρ = ρ̇/r − ṙ ρ/r²``, ``∂ṙ/∂ρ̇ = ρ/r``.
    """
    rho, rho_dot = x[:3], x[3:]
    rng = jnp.sqrt(rho @ rho)
    rate = rho @ rho_dot / rng
    h = jnp.concatenate([
        jnp.concatenate([rho / rng, jnp.zeros(3)])[None],
        jnp.concatenate([rho_dot / rng - rate * rho / rng**2, rho / rng])[None],
    ])
    return jnp.stack([rng, rate]), h


def bearing_model(x):
    """A basis across the predicted direction to the chief and the Jacobian of the bearing
    residual in it.

    Parameters
    ----------
    x : (6,)
        Relative state ``[ρ, ρ̇]``, m and m/s, LVLH.

    Returns
    -------
    basis : (2, 3)
        Rows ``e₁, e₂``: orthonormal, perpendicular to ``ĥ = −ρ/|ρ|`` (LVLH components).
    h : (2, 6)
        ``[e₁; e₂] ∂ĥ/∂x``: ``∂ĥ/∂ρ = −(I − ĥĥᵀ)/|ρ|`` (1/m), zero for ``ρ̇``.
    """
    rho = x[:3]
    rng = jnp.sqrt(rho @ rho)
    # The chief's own ρ is zero (its update is never used): divide by 1 there, not by 0.
    rng = jnp.where(rng > 0.0, rng, 1.0)
    h_hat = -rho / rng
    # e₁ from the LVLH axis least along ĥ: never parallel to it, so the basis is well conditioned.
    axis = jnp.eye(3)[jnp.argmin(jnp.abs(h_hat))]
    e1 = axis - (axis @ h_hat) * h_hat
    e1 = e1 / jnp.sqrt(e1 @ e1)
    basis = jnp.stack([e1, jnp.cross(h_hat, e1)])
    dh_drho = -(jnp.eye(3) - jnp.outer(h_hat, h_hat)) / rng
    return basis, jnp.concatenate([basis @ dh_drho, jnp.zeros((2, 3))], axis=1)


def bearing_in_lvlh(u_b, q_bi, own_fix):
    """A line of sight measured in body axes, in the LVLH axes of the spacecraft's own fix.

    Parameters
    ----------
    u_b : (3,)
        Unit line of sight, body axes.
    q_bi : (4,)
        The spacecraft's attitude (scalar-first, body to inertial).
    own_fix : (6,)
        Its own GNSS fix, ECI: position (m) and velocity (m/s).

    Returns
    -------
    jax.Array, (3,)
        ``C_lvlh_eci(own fix) q_bi ⊗ u_b ⊗ q_bi*``.
    """
    return lvlh_dcm(own_fix[:3], own_fix[3:]) @ quat_rotate(q_bi, u_b)


def sensor_due(t_s, period_s, every):
    """Whether a sensor updating every ``every`` control periods of ``period_s`` read at
    ``t_s`` (it holds its reading in between, and a held reading is not a new measurement)."""
    return jnp.round(t_s / period_s).astype(jnp.int64) % every == 0


def drawn_initial(state_i, key_i, sigma0, tag):
    """``state_i`` with its estimate ``x`` moved by an initial error ``σ₀ ν`` (ν standard normal
    from ``fold_in(key_i, tag)``) in the filter's first period (``clock_s == 0``), so that the
    error a filter starts with is drawn from the covariance it claims."""
    nu = jax.random.normal(jax.random.fold_in(key_i, tag), sigma0.shape)
    first = state_i["clock_s"] == 0.0
    return {**state_i, "x": jnp.where(first, state_i["x"] + sigma0 * nu, state_i["x"])}


def _select(use, new, old):
    """``new`` where ``use`` else ``old``, leaf by leaf."""
    return jax.tree_util.tree_map(lambda a, b: jnp.where(use, a, b), new, old)


@part(static=("gnss_every", "isl_every", "bearing_every", "draw_initial"))
class RelativeEkf:
    """One spacecraft's relative-navigation EKF (see the module docstring).

    Attributes
    ----------
    phi_k, q_k : (J + 2, 6, 6)
        Transition and accumulated process noise over j periods
        (:func:`coopsat.plugins.navigation.relative_model`).
    gamma : (6, 3)
        One period's ZOH input matrix.
    x0_lvlh : (6, n)
        Each spacecraft's initial estimate (the scenario's initial relative state), m, m/s.
    sigma0 : (6,)
        Initial standard deviation per state, m, m/s (``P₀ = diag(σ₀²)``).
    r_gnss_eci : (6,)
        Variance of the difference of two receivers' fixes per ECI axis, m², m²/s².
    r_isl : (2,)
        Variance of range (m²) and range-rate (m²/s²).
    r_bearing : scalar
        Variance of the bearing's angular error about each axis across the line of sight, rad².
    mass_kg : (n,)
    chief : int scalar
    period_s : scalar
    gnss_every, isl_every, bearing_every : int
        Static: control periods between fixes / ranges / bearings; 0 when the filter does not use it.
    draw_initial : bool
        Static: start from ``x0 + σ₀ ν`` (ν drawn from the spacecraft's key), not from ``x0``.
    """

    phi_k: jnp.ndarray
    q_k: jnp.ndarray
    gamma: jnp.ndarray
    x0_lvlh: jnp.ndarray
    sigma0: jnp.ndarray
    r_gnss_eci: jnp.ndarray
    r_isl: jnp.ndarray
    r_bearing: jnp.ndarray
    mass_kg: jnp.ndarray
    chief: jnp.ndarray
    period_s: jnp.ndarray
    gnss_every: int = 0
    isl_every: int = 0
    bearing_every: int = 0
    draw_initial: bool = True

    provides = ("x_lvlh",)

    @property
    def reads(self):
        """The measured quantities the filter reads."""
        quantities = (("gnss",) if self.gnss_every else ()) + (("isl",) if self.isl_every else ())
        # The bearing is turned into LVLH axes with the attitude and the spacecraft's own fix.
        quantities += ("bearing", "q", "gnss") if self.bearing_every else ()
        return tuple(dict.fromkeys(quantities))

    @property
    def reads_own(self):
        """A fix is differenced with the receiver's own fix of the same instant."""
        return bool(self.gnss_every)

    def init(self, n):
        """Every spacecraft's filter before its first period: the prior (x, P), the model's
        response to its own commands ``c``, the clock (s), the time of the last fix used (s)."""
        p0 = jnp.diag(self.sigma0**2)
        return {
            "x": jnp.asarray(self.x0_lvlh), "p": jnp.broadcast_to(p0[:, :, None], (6, 6, n)),
            "c": jnp.zeros((6, n)), "clock_s": jnp.zeros(n), "last_fix_s": jnp.full(n, -1.0),
        }

    def check_law(self, law, kind):
        """Why ``law`` cannot fly on this filter (its chief differs, it commands no
        ``force_lvlh``), or None."""
        if "force_lvlh" not in law.commands:
            return f"the filter carries its estimate under force_lvlh, which controller kind '{kind}' does not command"
        chief = getattr(law, "chief", None)
        if chief is not None and int(chief) != int(self.chief):
            return f"controller kind '{kind}' keeps spacecraft {int(chief) + 1} as its chief, the filter spacecraft {int(self.chief) + 1}"
        return None

    def estimate_of(self, i, state_i):
        """What the law reads of spacecraft i's estimate in ``state_i``: ``{"x_lvlh": (6,)}``,
        zero for the chief."""
        return {"x_lvlh": jnp.where(i == self.chief, 0.0, state_i["x"])}

    def outbox_one(self, i, y_i, state_i):
        """Spacecraft i's fix (6,) when it is fresh this period, when it was taken (s), and its
        ``c`` (6,) of this instant."""
        if not self.gnss_every:
            return {}
        return {
            "nav_fix": y_i["gnss"], "nav_fix_s": state_i["clock_s"], "nav_c": state_i["c"],
            "nav_fresh": sensor_due(state_i["clock_s"], self.period_s, self.gnss_every).astype(float), "nav_from": jnp.asarray(i, dtype=float),
        }

    def _initial(self, state_i, key_i):
        """The first period's prior: ``x0`` plus a drawn initial error, when chosen."""
        return drawn_initial(state_i, key_i, self.sigma0, _DRAW) if self.draw_initial else state_i

    def _gnss(self, state_i, t, y_i, inbox_i):
        """The differential-GNSS update from the freshest usable fix of the chief."""
        msg, own = inbox_i.msg, inbox_i.own
        age = jnp.round((t - msg["nav_fix_s"]) / self.period_s).astype(jnp.int64)
        usable = ((inbox_i.weight != 0.0) & (msg["nav_from"] == self.chief) & (msg["nav_fresh"] > 0.0)
                  & (msg["nav_fix_s"] > state_i["last_fix_s"]) & (age <= self.phi_k.shape[0] - 2))
        link = jnp.argmax(jnp.where(usable, msg["nav_fix_s"], -jnp.inf))
        j = jnp.clip(age[link], 0, self.phi_k.shape[0] - 2)
        chief_fix, own_fix = msg["nav_fix"][:, link], own["nav_fix"][:, link]
        rho, rho_dot = eci_to_lvlh(chief_fix[:3], chief_fix[3:], own_fix[:3], own_fix[3:])
        # The fix's noise in LVLH axes (the chief's fix defines them), carried to now.
        turn = jnp.kron(jnp.eye(2), lvlh_dcm(chief_fix[:3], chief_fix[3:]))
        r_now = self.phi_k[j] @ (turn @ jnp.diag(self.r_gnss_eci) @ turn.T) @ self.phi_k[j].T + self.q_k[j]
        z_now = self.phi_k[j] @ (jnp.concatenate([rho, rho_dot]) - own["nav_c"][:, link]) + state_i["c"]
        x, p, nis = joseph_update(state_i["x"], state_i["p"], z_now - state_i["x"], jnp.eye(6), r_now)
        use = jnp.any(usable)
        new = {**state_i, "x": x, "p": p, "last_fix_s": msg["nav_fix_s"][link]}
        return _select(use, new, state_i), jnp.where(use, nis, 0.0), use

    def _isl(self, state_i, t, y_i):
        """The range and range-rate update, when the sensor read this period and saw the chief."""
        z = y_i["isl"]
        use = sensor_due(t, self.period_s, self.isl_every) & (z[2] > 0.0)
        predicted, h = range_model(state_i["x"])
        x, p, nis = joseph_update(state_i["x"], state_i["p"], z[:2] - predicted, h, jnp.diag(self.r_isl))
        return _select(use, {**state_i, "x": x, "p": p}, state_i), jnp.where(use, nis, 0.0), use

    def _bearing(self, state_i, t, y_i):
        """The camera-bearing update, when the camera read this period and saw the chief."""
        z = y_i["bearing"]
        use = sensor_due(t, self.period_s, self.bearing_every) & (z[3] > 0.0)
        basis, h = bearing_model(state_i["x"])
        residual = basis @ bearing_in_lvlh(z[:3], y_i["q"], y_i["gnss"])  # predicted: [0, 0]
        x, p, nis = joseph_update(state_i["x"], state_i["p"], residual, h, self.r_bearing * jnp.eye(2))
        return _select(use, {**state_i, "x": x, "p": p}, state_i), jnp.where(use, nis, 0.0), use

    def update_one(self, i, t, y_i, inbox_i, state_i, key_i):
        """Spacecraft i's posterior at t: (state, ``{"x_lvlh": (6,)}``, record). The chief's
        estimate (and recorded covariance) is zero."""
        state_i = self._initial(state_i, key_i)
        nis, used = jnp.zeros(len(_MEASUREMENTS)), jnp.zeros(len(_MEASUREMENTS))
        if self.gnss_every:
            state_i, nis_g, use_g = self._gnss(state_i, t, y_i, inbox_i)
            nis, used = nis.at[0].set(nis_g), used.at[0].set(use_g.astype(float))
        if self.isl_every:
            state_i, nis_r, use_r = self._isl(state_i, t, y_i)
            nis, used = nis.at[1].set(nis_r), used.at[1].set(use_r.astype(float))
        if self.bearing_every:
            state_i, nis_b, use_b = self._bearing(state_i, t, y_i)
            nis, used = nis.at[2].set(nis_b), used.at[2].set(use_b.astype(float))
        estimate = self.estimate_of(i, state_i)
        record = {"nav_estimate_lvlh": estimate["x_lvlh"], "nav_covariance_lvlh": jnp.where(i == self.chief, 0.0, state_i["p"]),
                  "nav_nis": nis, "nav_updated": used}
        return state_i, estimate, record

    def predict_one(self, i, state_i, commands):
        """The prior at the next period's start under the law's commanded ``force_lvlh`` (3,), N."""
        u = commands["force_lvlh"] / self.mass_kg[i]
        phi = self.phi_k[1]
        return {
            **state_i,
            "x": phi @ state_i["x"] + self.gamma @ u, "c": phi @ state_i["c"] + self.gamma @ u,
            "p": phi @ state_i["p"] @ phi.T + self.q_k[1], "clock_s": state_i["clock_s"] + self.period_s,
        }

    def true_state(self, r_eci, v_eci):
        """The truth of what the filter estimates, from recorded ECI states (T, n, 3): each
        spacecraft's state relative to the chief, its LVLH frame, (T, n, 6) NumPy."""
        c = slice(int(self.chief), int(self.chief) + 1)
        rho, rho_dot = eci_to_lvlh(r_eci[:, c], v_eci[:, c], r_eci, v_eci)
        return np.concatenate([np.asarray(rho), np.asarray(rho_dot)], axis=-1)

    def estimated(self, n):
        """The spacecraft whose estimates are judged (the chief's is zero by construction)."""
        return [k for k in range(n) if k != int(self.chief)]

    def output_specs(self):
        state = (("nav_state", _STATE),)
        return {
            "nav_estimate_lvlh": OutputSpec(
                ("nav_state",), "m, m/s", "LVLH",
                "relative state estimated by the spacecraft's navigation filter (x, y, z in m; vx, vy, vz in m/s, "
                "rotating-frame rates; the chief's LVLH), after the period's measurements, at the sample",
                coords=state,
            ),
            "nav_covariance_lvlh": OutputSpec(
                ("nav_state", "nav_state_col"), "m2, m2/s, m2/s2", "LVLH",
                "covariance of the navigation filter's estimate at the sample (0 for the chief)",
                coords=(("nav_state", _STATE), ("nav_state_col", _STATE)),
            ),
            "nav_nis": OutputSpec(
                ("nav_measurement",), "1", "",
                "normalised innovation squared of the period's update (chi-square with 6 dof for gnss, 2 for isl and "
                "bearing; 0 when there was none)",
                coords=(("nav_measurement", _MEASUREMENTS),),
            ),
            "nav_updated": OutputSpec(
                ("nav_measurement",), "1", "", "1 when the filter used that measurement this period, else 0",
                coords=(("nav_measurement", _MEASUREMENTS),),
            ),
        }
