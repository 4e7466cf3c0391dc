"""A saturated consensus attitude law over the communication graph (the controller part).

For spacecraft i, with the sum over the links j → i that it hears (weights ``a_ij``)::

    s_i = Σ_j a_ij [α H(q_j* ⊗ q_i) + β (ω_i − ω_j)] + γ ω_i
    τ_i = −τ_max tanh(s_i / τ_max)                               (per body axis)

``H(·)`` is the vector part of the error quaternion (taken on the ``q0 ≥ 0`` hemisphere with
``short_way``, so that a spacecraft turns the short way round); the first two terms are the
consensus law (3) of the 2010 consensus paper (coopsat's ``consensus-sync``), the third an
absolute rate damping that brings the synchronised formation to rest. The hyperbolic tangent
bounds each axis's command by ``τ_max`` (chosen at or below the thrusters' torque, so that the
thrusters never clip) and leaves small errors in the linear law: a bounded-control consensus
in the manner of Ren (2007).

Vectorised over spacecraft and links: the per-link terms are one array ``(3, E)`` (edge list)
or ``(3, d, n)`` (padded in-neighbour table), summed per receiver; no Python loop runs inside
the compiled loop.
"""

import jax
import jax.numpy as jnp

from coopsat.plugins import OutputSpec, part


def error_vector(q_own, q_msg, short_way=True):
    """``H(q_j* ⊗ q_i)``: vector part of the error of ``q_own`` (i) relative to ``q_msg`` (j).

    Parameters
    ----------
    q_own, q_msg : array (4, ...)
        Scalar-first unit quaternions, component-major, broadcastable against each other.
    short_way : bool
        Negate the vector where the error's scalar part is negative (the same rotation the
        short way round).

    Returns
    -------
    jax.Array, shape (3, ...)
    """
    q_own, q_msg = jnp.broadcast_arrays(q_own, q_msg)
    w_i, v_i, w_j, v_j = q_own[0], q_own[1:], q_msg[0], q_msg[1:]
    scalar = w_j * w_i + jnp.sum(v_j * v_i, axis=0)
    vector = w_j * v_i - w_i * v_j - jnp.cross(v_j, v_i, axis=0)
    return jnp.where(scalar < 0.0, -vector, vector) if short_way else vector


def at_links(own, dst):
    """Each link's receiver's own value: ``(k, n)`` → ``(k, E)``, or ``(k, 1, n)`` for a padded
    table (whose column i is received by i)."""
    return own[:, None, :] if dst.ndim == 2 else jnp.take(own, dst, axis=-1)


def per_receiver(per_link, dst, n):
    """Σ over the links into each spacecraft: ``(k, E)`` or ``(k, d, n)`` → ``(k, n)``."""
    if dst.ndim == 2:
        return per_link.sum(axis=-2)
    return jax.ops.segment_sum(per_link.T, dst, num_segments=n).T


def saturated_consensus_torque(q, omega, q_msg, omega_msg, dst, weight, alpha, beta, gamma, torque_max_nm, short_way=True):
    """The law's body torque command, N·m, shape (3, n).

    Parameters
    ----------
    q, omega : (4, n), (3, n)
        Each spacecraft's own measured attitude and body rate (rad/s).
    q_msg, omega_msg : (4, E), (3, E) or (4, d, n), (3, d, n)
        What the receiver of each link heard.
    dst, weight : (E,) or (d, n)
        Receiver and weight ``a_ij`` of each link (weight 0: no link now).
    alpha : scalar
        Attitude gain α, N·m per unit of quaternion vector part.
    beta, gamma : scalar
        Relative and absolute rate gains, N·m·s/rad.
    torque_max_nm : scalar
        Bound of the command per axis, N·m.
    short_way : bool
        Static: error quaternions on the ``q0 ≥ 0`` hemisphere.
    """
    per_link = weight * (alpha * error_vector(at_links(q, dst), q_msg, short_way) + beta * (at_links(omega, dst) - omega_msg))
    s = per_receiver(per_link, dst, q.shape[-1]) + gamma * omega
    return -torque_max_nm * jnp.tanh(s / torque_max_nm)


@part(static=("short_way",))
class SaturatedConsensus:
    """Flight software of the saturated consensus law: stateless; each spacecraft broadcasts
    its measured attitude and rate.

    Attributes
    ----------
    alpha : scalar
        α, N·m.
    beta, gamma : scalar
        β and γ, N·m·s/rad.
    torque_max_nm : scalar
        Bound of the command per body axis, N·m.
    short_way : bool
        Static: error quaternions on the ``q0 ≥ 0`` hemisphere.
    """

    alpha: jnp.ndarray
    beta: jnp.ndarray
    gamma: jnp.ndarray
    torque_max_nm: jnp.ndarray
    short_way: bool = True

    commands = ("torque_b",)

    def init(self, n):
        return ()

    def outbox(self, y, state):
        return {"q": y["q"], "omega": y["omega"]}

    def step(self, t, y, inbox, state, key):
        u = saturated_consensus_torque(
            y["q"], y["omega"], inbox.msg["q"], inbox.msg["omega"], inbox.dst, inbox.weight,
            self.alpha, self.beta, self.gamma, self.torque_max_nm, self.short_way,
        )
        return {"torque_b": u}, state, {"torque_command": u}

    def output_specs(self):
        return {
            "torque_command": OutputSpec(("component",), "N m", "body", "torque commanded by the saturated consensus law at the sample")
        }
