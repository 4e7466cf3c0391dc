"""Cartwheel formation keeping (SPEC §2): ring-topology target estimation, discrete LQR on the
CW error, and on-board PSO re-allocation of the formation's phase ψ. One computer per
spacecraft (``local`` flight software, :mod:`coopsat.sim.flight_software`).

Every spacecraft reads its own state relative to the chief in the chief's LVLH frame
(``x_lvlh``, from :class:`~coopsat.sensors.parts.RelativeNavigation`) and broadcasts it with
its time tag and the phase ψ it holds. The chief is uncontrolled; it plans ψ. A deputy i
takes its target state either from the plan (the circle at ``θ = n t + ψ + φ_i``, the targets
"planned on the ground"), or from the ring (eqs. 7–11): each source j it listens to gives a
candidate (the chief: the planned circle point with the chief's ψ; a deputy: j's state,
brought to the present with its known delay, rotated in the formation plane by ``φ_i − φ_j``,
with velocity ``ω × R``), and the target is their weighted mean. The command is
``F = −m K (x_i − x_target)`` with the discrete LQR gain K of the CW model, executed as whole
impulse bits by the thrusters (:mod:`coopsat.actuators.impulse_bits`).

Formation plane: :data:`coopsat.dynamics.cw.PLANE_AXES_LVLH` (``e1 = x̂``, ``e2 = (0, √3/2,
−1/2)``, ``e3 = e1 × e2``); the circle is ``ρ (cos θ e1 + sin θ e2)`` and turns at ``ω = n e3``.
"""


import jax
import jax.numpy as jnp

from coopsat.core.parts import OutputSpec, part
from coopsat.control.pso import pso_minimize
from coopsat.dynamics.cw import PLANE_AXES_LVLH, cartwheel_state, cw_stm, transfer_impulse_l1


def plane_rotation(delta_rad):
    """Rotation by ``delta`` about the formation plane's normal, LVLH components, (..., 3, 3)
    (eqs. 7–8: a point of the circle to the point ``delta`` further on)."""
    c, s = jnp.cos(delta_rad), jnp.sin(delta_rad)
    zero, one = jnp.zeros_like(c), jnp.ones_like(c)
    r_plane = jnp.stack([jnp.stack([c, -s, zero], -1), jnp.stack([s, c, zero], -1), jnp.stack([zero, zero, one], -1)], -2)
    return PLANE_AXES_LVLH @ r_plane @ PLANE_AXES_LVLH.T


def compensate_delay(x_lvlh, age_s, n_rad_s, method):
    """A received relative state brought to the present.

    Parameters
    ----------
    x_lvlh : (..., 6)
        State when it was sent, m and m/s.
    age_s : (...)
        Time since it was sent, s.
    n_rad_s : scalar
    method : {"none", "linear", "cw"}
        Static. ``linear``: the paper's ``R + δt V`` (velocity unchanged; its error is about
        ``½ n² ρ δt²``, 0.9 µm on the 1.5 m circle at 1 s); ``cw``: the CW state-transition
        matrix, exact for the design model.

    Returns
    -------
    jax.Array (..., 6)
    """
    if method == "none":
        return x_lvlh
    if method == "linear":
        return jnp.concatenate([x_lvlh[..., :3] + age_s[..., None] * x_lvlh[..., 3:], x_lvlh[..., 3:]], axis=-1)
    return jnp.einsum("...ij,...j->...i", cw_stm(n_rad_s, age_s), x_lvlh)


def neighbour_candidate(x_j_lvlh, delta_rad, n_rad_s):
    """Target state of spacecraft i implied by neighbour j's state (eqs. 7–9).

    Parameters
    ----------
    x_j_lvlh : (..., 6)
        Neighbour's state at the present, m and m/s.
    delta_rad : (...)
        ``φ_i − φ_j``, rad.
    n_rad_s : scalar

    Returns
    -------
    jax.Array (..., 6)
        Position ``M(δ) R_j`` (the neighbour's position turned by δ in the formation plane);
        velocity ``ω × R`` with ``ω = n e3`` (eq. 9).
    """
    r = jnp.einsum("...ij,...j->...i", plane_rotation(delta_rad), x_j_lvlh[..., :3])
    v = jnp.cross(n_rad_s * PLANE_AXES_LVLH[:, 2], r)
    return jnp.concatenate([r, v], axis=-1)


def weighted_target(candidates, weights, fallback):
    """Weighted mean of candidate targets (eq. 10); ``fallback`` when no weight is positive.

    Parameters
    ----------
    candidates : (m, 6)
    weights : (m,)
    fallback : (6,)

    Returns
    -------
    (target (6,), total weight ())
    """
    total = jnp.sum(weights)
    mean = jnp.sum(candidates * weights[:, None], axis=0) / jnp.maximum(total, 1e-300)
    return jnp.where(total > 0.0, mean, fallback), total


def allocation_cost_ns(psi_rad, x_now, phase_rad, mass_kg, use, t_s, rho_m, n_rad_s, horizon_s):
    """Total impulse the deputies need to reach the circle of phase ψ (eq. 16), N·s.

    Parameters
    ----------
    psi_rad : (P,)
        Candidate phases.
    x_now : (m, 6)
        Each deputy's present state (as received and brought to the present).
    phase_rad : (m,)
        Each deputy's offset on the circle, ``2π(k − 1)/K``.
    mass_kg : (m,)
    use : (m,)
        1.0 for a deputy whose state is known, else 0.0.
    t_s, rho_m, n_rad_s, horizon_s : scalar
        Present time; circle; the transfer time of the two-impulse manoeuvre (not a whole
        number of orbits).

    Returns
    -------
    jax.Array (P,)
        ``Σ_k m_k (‖Δv₁‖₁ + ‖Δv₂‖₁)`` of the CW two-impulse transfer from the present state
        to the circle point at ``t + horizon``: the thrusters fire per LVLH axis, so L1.
    """
    target = cartwheel_state(rho_m, n_rad_s, t_s + horizon_s, psi_rad[:, None] + phase_rad[None, :])  # (P, m, 6)
    impulse = transfer_impulse_l1(jnp.broadcast_to(x_now, target.shape), target, n_rad_s, horizon_s, mass_kg)
    return jnp.sum(impulse * use, axis=-1)


@part(static=("period_s", "targets", "compensation", "replan_every", "particles", "iterations", "check_points"))
class CartwheelKeeping:
    """One spacecraft's cartwheel keeping software (chief: planner only; deputies: keeping).

    Attributes
    ----------
    rho_m, n_rad_s : scalar
        Circle radius, m; the chief's mean motion, rad/s.
    phase_rad : (n,)
        Each spacecraft's offset on the circle ``2π(k − 1)/K`` (chief: 0).
    deputy : (n,)
        1.0 for a deputy (controlled), 0.0 for the chief.
    chief : int scalar
    source_weight : (n, n)
        ``[i, j]``: weight of source j in deputy i's target (eq. 10; 0: not a source).
    gain : (n, 3, 6)
        Discrete LQR gain of each spacecraft, specific force per unit state error (s⁻², s⁻¹).
    mass_kg : (n,)
    psi0_rad, psi_bound_rad : scalar
        Planned phase ψ and the half-width of the interval the planner searches, rad.
    horizon_s : scalar
        Transfer time of the planner's cost, s.
    period_s : float
        Static: control period, s (the planner's schedule depends on time alone, so it stays
        a branch in a batch of runs).
    targets : {"planned", "ring"}
        Static: the deputies' targets from the plan, or estimated from the ring (eqs. 7–11).
    compensation : {"none", "linear", "cw"}
        Static: delay compensation of received states (:func:`compensate_delay`).
    replan_every : int
        Static: control periods between the chief's PSO solves (0: never, ψ stays ψ₀).
    particles, iterations : int
        Static: PSO swarm size and iterations.
    check_points : int
        Static: points of the grid over the same interval on which the cost is also evaluated
        at every solve (recorded, so the PSO's answer is checked in every run).
    """

    rho_m: jnp.ndarray
    n_rad_s: jnp.ndarray
    phase_rad: jnp.ndarray
    deputy: jnp.ndarray
    chief: jnp.ndarray
    source_weight: jnp.ndarray
    gain: jnp.ndarray
    mass_kg: jnp.ndarray
    psi0_rad: jnp.ndarray
    psi_bound_rad: jnp.ndarray
    horizon_s: jnp.ndarray
    period_s: float = 1.0
    targets: str = "ring"
    compensation: str = "cw"
    replan_every: int = 0
    particles: int = 16
    iterations: int = 30
    check_points: int = 201

    local = True
    reads = ("x_lvlh",)
    commands = ("force_lvlh",)

    def init(self, n):
        return {"clock_s": jnp.zeros((n,)), "psi_rad": jnp.zeros((n,)) + self.psi0_rad, "plan_cost_ns": jnp.zeros((3, n))}

    def outbox_one(self, i, y_i, state_i):
        """Spacecraft i broadcasts its relative state, the time it was taken, its ψ, and who it is."""
        return {"x": y_i["x_lvlh"], "t": state_i["clock_s"], "psi": state_i["psi_rad"], "sender": jnp.asarray(i, dtype=float)}

    def _plan(self, i, t, x_now, senders, alive, key):
        """The chief's PSO over ψ on the deputies' present states: (ψ, [J_pso, J_grid_min, J_grid_max])."""
        use = alive * self.deputy[senders]
        cost = lambda psi: allocation_cost_ns(  # noqa: E731
            psi[:, 0], x_now, self.phase_rad[senders], self.mass_kg[senders], use, t, self.rho_m, self.n_rad_s, self.horizon_s
        )
        lo, hi = self.psi0_rad - self.psi_bound_rad, self.psi0_rad + self.psi_bound_rad
        psi, j_pso = pso_minimize(cost, lo[None], hi[None], key, particles=self.particles, iterations=self.iterations)
        grid = jnp.linspace(lo, hi, self.check_points)[:, None]
        j_grid = cost(grid)
        return psi[0], jnp.stack([j_pso, jnp.min(j_grid), jnp.max(j_grid)])

    def step_one(self, i, t, y_i, inbox_i, state_i, key):
        """Deputy i's ``force_lvlh`` (3,), N; the chief's ψ when a solve is due."""
        x_i = y_i["x_lvlh"]
        msg = inbox_i.msg
        senders = jnp.round(msg["sender"]).astype(int)
        alive = (inbox_i.weight > 0.0).astype(float)
        x_now = compensate_delay(msg["x"].T, t - msg["t"], self.n_rad_s, self.compensation)  # (m, 6)
        from_chief = alive * (senders == self.chief)
        heard_chief = jnp.sum(from_chief) > 0.0
        psi_chief = jnp.sum(msg["psi"] * from_chief) / jnp.maximum(jnp.sum(from_chief), 1.0)
        psi = jnp.where(heard_chief, psi_chief, state_i["psi_rad"])

        plan_cost = state_i["plan_cost_ns"]
        if self.replan_every > 0:
            # The predicate depends on time only, so under vmap the solve stays a branch taken
            # once per replanning interval (every spacecraft computes it; the chief's is kept).
            is_chief = i == self.chief
            k = jnp.round(t / self.period_s).astype(int)
            planned = jax.lax.cond(
                k % self.replan_every == 0,
                lambda: self._plan(i, t, x_now, senders, alive, key),
                lambda: (state_i["psi_rad"], state_i["plan_cost_ns"]),
            )
            psi = jnp.where(is_chief, planned[0], psi)
            plan_cost = jnp.where(is_chief, planned[1], plan_cost)

        plan = cartwheel_state(self.rho_m, self.n_rad_s, t, psi + self.phase_rad[i])
        if self.targets == "planned":
            target = plan
        else:
            chief_candidate = jnp.broadcast_to(plan, x_now.shape)
            candidates = jnp.where(
                (senders == self.chief)[:, None], chief_candidate,
                neighbour_candidate(x_now, self.phase_rad[i] - self.phase_rad[senders], self.n_rad_s),
            )
            target, _ = weighted_target(candidates, alive * self.source_weight[i, senders], plan)
        force = -self.mass_kg[i] * self.deputy[i] * (self.gain[i] @ (x_i - target))
        record = {"target_lvlh": target, "psi_rad": psi, "plan_cost_ns": plan_cost, "force_command": force}
        new_state = {"clock_s": t + self.period_s, "psi_rad": psi, "plan_cost_ns": plan_cost}
        return {"force_lvlh": force}, new_state, record

    def output_specs(self):
        return {
            "target_lvlh": OutputSpec(
                ("lvlh_state",), "m, m/s", "LVLH", "target state the flight software steers to (planned or estimated from the ring)",
                coords=(("lvlh_state", ("x", "y", "z", "vx", "vy", "vz")),),
            ),
            "psi_rad": OutputSpec((), "rad", "", "formation phase ψ the spacecraft holds (the chief's plan)"),
            "plan_cost_ns": OutputSpec(
                ("plan_cost",), "N·s", "",
                "chief's last allocation: total impulse at the PSO's ψ, and the least and largest on a grid over the interval",
                coords=(("plan_cost", ("pso", "grid_min", "grid_max")),),
            ),
            "force_command": OutputSpec(("component",), "N", "LVLH", "force commanded by the spacecraft's flight software"),
        }
