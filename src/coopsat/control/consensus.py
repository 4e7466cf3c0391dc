"""Consensus attitude synchronisation and tracking laws (2010 consensus paper, SPEC §1).

Flight software: each spacecraft i sees its own measured attitude and rate and the messages of
the spacecraft it hears; the sums run over the edges of the graph (segment sums over the
receiver index), never over a dense n×n matrix, so the law scales to thousands of spacecraft.
"""


import jax
import jax.numpy as jnp

from coopsat.core.parts import OutputSpec, part
from coopsat.geometry.quaternion import quat_error, quat_exp_rate, quat_multiply, quat_positive, quat_vector


def _vec_error(q_i, q_j, short_way, axis):
    """``H(q_j* ⊗ q_i)``, optionally taken on the ``q0 ≥ 0`` hemisphere; (..., 4) -> (..., 3)."""
    q_e = quat_error(q_i, q_j, axis)
    if short_way:
        q_e = quat_positive(q_e, axis)
    return quat_vector(q_e, axis)


def own_at_links(own, dst, axis):
    """Each link's receiver's own value: (k, n) -> (k, E) or (k, 1, n) (padded table)."""
    if dst.ndim == 2:  # padded table: the receiver of column i is i
        return own[:, None, :] if axis == 0 else own[None]
    return jnp.take(own, dst, axis=-1 if axis == 0 else 0)


def per_receiver_sum(per_link, dst, n, axis):
    """Σ over the links into each spacecraft (edge list sorted by receiver, or padded table)."""
    if dst.ndim == 2:
        return per_link.sum(axis=-2 if axis == 0 else 0)
    if axis == 0:  # (k, E) -> (k, n)
        return jax.ops.segment_sum(per_link.T, dst, num_segments=n, indices_are_sorted=True).T
    return jax.ops.segment_sum(per_link, dst, num_segments=n, indices_are_sorted=True)


def consensus_sync_torque(q_own, omega_own, q_msg, omega_msg, dst, weight, alpha, beta, short_way=False, axis=-1):
    """Synchronisation law (3): ``u_i = −Σ_j a_ij [α H(q_j* ⊗ q_i) + β (ω_i − ω_j)]``.

    Parameters
    ----------
    q_own : (n, 4)
        Each spacecraft's own attitude ``q_bi``.
    omega_own : (n, 3)
        Each spacecraft's own body rate, rad/s.
    q_msg, omega_msg : (E, 4), (E, 3)
        What the receiver of each link heard from its transmitter (links as
        :class:`~coopsat.network.topology.Links`: an edge list (E,), or a padded table (d, n)
        in the component-major layout, giving (4, d, n) and (3, d, n)).
    dst : int (E,) or (d, n)
        Receiver of each link.
    weight : (E,) or (d, n)
        ``a_ij`` of each link.
    alpha : scalar
        Attitude gain α, N·m (per unit of quaternion vector part).
    beta : scalar
        Rate gain β, N·m·s/rad.
    short_way : bool
        Static. Take the error quaternion on the ``q0 ≥ 0`` hemisphere. The paper's law and its
        Lyapunov function (8) use the raw product (False).
    axis : {-1, 0}
        Component axis: (n, 4) arrays, or component-major (4, n) in the compiled loop.

    Returns
    -------
    jax.Array, shape (n, 3)
        Commanded torque, body axes, N·m.

    Notes
    -----
    2010 consensus paper, eq. (3); reduces the tracking law (4) with K = D = 0.
    """
    w = weight if axis == 0 else weight[..., None]
    e_q = _vec_error(own_at_links(q_own, dst, axis), q_msg, short_way, axis)
    per_link = w * (alpha * e_q + beta * (own_at_links(omega_own, dst, axis) - omega_msg))
    return -per_receiver_sum(per_link, dst, q_own.shape[-1 if axis == 0 else 0], axis)


def consensus_sync_torque_one(q_i, omega_i, q_msg, omega_msg, weight, alpha, beta, short_way=False):
    """Law (3) of one spacecraft: ``u_i`` from its own attitude and rate and its links.

    Parameters
    ----------
    q_i : (4,)
    omega_i : (3,)
        Rad/s.
    q_msg, omega_msg : (4, E), (3, E)
        What spacecraft i heard on each link (component-major, one flat link axis).
    weight : (E,)
        ``a_ij`` of each link; 0 for a link not addressed to i, absent or lost.
    alpha, beta, short_way
        As :func:`consensus_sync_torque`.

    Returns
    -------
    jax.Array, shape (3,)
        N·m, body axes. With at most two links of nonzero weight it equals
        :func:`consensus_sync_torque`'s column i bit for bit (adding the zero terms is exact);
        with more, to rounding (the sum's order).
    """
    # The formation-wide law's arithmetic, in its order, on this spacecraft's links.
    e_q = _vec_error(q_i[:, None], q_msg, short_way, 0)
    per_link = weight * (alpha * e_q + beta * (omega_i[:, None] - omega_msg))
    return -per_link.sum(axis=-1)


def reference_attitude(q_ref0, omega_ref_b, t_s):
    """Reference ``q_r(t) = q_r(0) ⊗ exp(½ [0, ω_r] t)`` for a constant body rate ω_r.

    Parameters
    ----------
    q_ref0 : (4,)
    omega_ref_b : (3,)
        Reference body rate, rad/s.
    t_s : scalar

    Returns
    -------
    jax.Array, shape (4,)

    Notes
    -----
    The exact solution of ``q̇_r = ½ q_r ⊗ [0, ω_r]`` (SPEC §1: "q_r propagated by the
    kinematics"), so the reference carries no integration error.
    """
    return quat_multiply(q_ref0, quat_exp_rate(omega_ref_b, t_s))


def consensus_track_torque(
    q_own, omega_own, q_msg, omega_msg, dst, weight, alpha, beta, k_p, k_d, q_ref, omega_ref_b, short_way=False, axis=-1
):
    """Tracking law (4): law (3) plus ``−K H(q_r* ⊗ q_i) − D (ω_i − ω_r)``.

    Parameters
    ----------
    q_own, omega_own, q_msg, omega_msg, dst, weight, alpha, beta, short_way, axis
        As :func:`consensus_sync_torque`.
    k_p : scalar
        K, N·m.
    k_d : scalar
        D, N·m·s/rad.
    q_ref : (4,)
        Reference attitude at this instant.
    omega_ref_b : (3,)
        Reference body rate, rad/s.

    Returns
    -------
    jax.Array, shape (n, 3)

    Notes
    -----
    2010 consensus paper, eq. (4) (printed with a stray dot over u).
    """
    u = consensus_sync_torque(q_own, omega_own, q_msg, omega_msg, dst, weight, alpha, beta, short_way, axis)
    if axis == 0:  # reference vectors broadcast along the spacecraft axis
        q_ref, omega_ref_b = q_ref[:, None], omega_ref_b[:, None]
    e_r = _vec_error(q_own, q_ref, short_way, axis)
    return u - k_p * e_r - k_d * (omega_own - omega_ref_b)


_TORQUE_COMMAND = OutputSpec(("component",), "N m", "body", "torque commanded by the control law at the sample")


@part(static=("track", "short_way"))
class ConsensusLaw:
    """Flight software of laws (3) and (4): stateless, sees its own attitude and rate and the
    attitudes and rates it hears.

    Attributes
    ----------
    alpha, beta : scalar
        α (N·m) and β (N·m·s/rad).
    k_p, k_d : scalar
        K and D of the tracking law (unused by law (3)).
    q_ref0 : (4,)
        Reference attitude at t = 0 (tracking).
    omega_ref_b : (3,)
        Reference body rate, rad/s (tracking).
    track : bool
        Static: law (4) rather than law (3).
    short_way : bool
        Static: error quaternions on the ``q0 ≥ 0`` hemisphere.
    """

    alpha: jnp.ndarray
    beta: jnp.ndarray
    k_p: jnp.ndarray
    k_d: jnp.ndarray
    q_ref0: jnp.ndarray
    omega_ref_b: jnp.ndarray
    track: bool
    short_way: bool

    commands = ("torque_b",)

    def init(self, n):
        return ()

    def outbox(self, y, state):
        """Each spacecraft broadcasts its measured attitude and rate."""
        return {"q": y["q"], "omega": y["omega"]}

    def step(self, t, y, inbox, state, key):
        """Body torque command ``torque_b`` (3, n); records it, and ``q_ref`` (4,) when tracking."""
        return self.outputs(t, self.torque(t, y, inbox), state)

    # The per-spacecraft form (the protocol of a LocalController, without ``local``: the
    # compiled loop keeps the formation-wide step, a sum over the edges that scales to
    # thousands of spacecraft; software in the loop runs one spacecraft per process).
    reads = ("q", "omega")

    def outbox_one(self, i, y_i, state_i):
        """Spacecraft i's broadcast: its measured attitude (4,) and rate (3,)."""
        return {"q": y_i["q"], "omega": y_i["omega"]}

    def step_one(self, i, t, y_i, inbox_i, state_i, key_i):
        """Spacecraft i's torque command (3,) N·m from its readings and the links addressed to
        it (``inbox_i``: one flat link axis, the others zeroed); records as :meth:`step`."""
        q_msg, omega_msg = inbox_i.msg["q"], inbox_i.msg["omega"]
        u = consensus_sync_torque_one(y_i["q"], y_i["omega"], q_msg, omega_msg, inbox_i.weight, self.alpha, self.beta,
                                      self.short_way)
        if self.track:
            q_ref = reference_attitude(self.q_ref0, self.omega_ref_b, t)
            u = u - self.k_p * _vec_error(y_i["q"], q_ref, self.short_way, 0) - self.k_d * (y_i["omega"] - self.omega_ref_b)
        return self.outputs(t, u, state_i)

    def torque(self, t, y, inbox):
        """The command (3, n) N·m of law (3), or (4) when tracking, from ``inbox``'s messages."""
        args = (y["q"], y["omega"], inbox.msg["q"], inbox.msg["omega"], inbox.dst, inbox.weight, self.alpha, self.beta)
        if not self.track:
            return consensus_sync_torque(*args, self.short_way, 0)
        q_ref = reference_attitude(self.q_ref0, self.omega_ref_b, t)
        return consensus_track_torque(*args, self.k_p, self.k_d, q_ref, self.omega_ref_b, self.short_way, 0)

    def outputs(self, t, u, state):
        """What :meth:`step` returns for the command ``u``: (commands, state, record). A native
        kernel that computes ``u`` (:mod:`coopsat.sim.native`) returns this too."""
        if not self.track:
            return {"torque_b": u}, state, {"torque_command": u}
        q_ref = reference_attitude(self.q_ref0, self.omega_ref_b, t)
        return {"torque_b": u}, state, {"torque_command": u, "q_ref": q_ref}

    def output_specs(self):
        specs = {"torque_command": _TORQUE_COMMAND}
        if self.track:
            specs["q_ref"] = OutputSpec(("q_component",), "1", "", "reference attitude quaternion, scalar first", False)
        return specs
