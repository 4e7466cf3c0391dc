"""Leader–follower consensus under delay (SPEC §3): the paper's law (3) and the classical
protocol, as flight software for the small-angle attitude model.

Per axis each spacecraft is a double integrator, state x = (angle, rate); with unit inertia
the torque is the paper's input u (``ẋ = A x + B u``, A = [[0, 1], [0, 0]], B = [0, 1]ᵀ).
Follower i hears agent j (the leader among them) over the network, the message arriving
``m_ji τ`` late:

* law (3): ``u_i = K Σ_j a_ij (x_j(t − m_ji τ) − x_i(t))`` — its own state is current;
* classical: ``u_i = K Σ_j a_ij (x_j(t − m_ji τ) − x_i(t − m_ji τ))`` — the whole relative
  state is delayed (its own state of the same past instant, which the network delivers with
  the message).

The leader (``follower = 0``) flies free. K = [k_angle, k_rate] is the same on every axis.
"""


import jax.numpy as jnp

from coopsat.core.parts import OutputSpec, part
from coopsat.control.consensus import own_at_links, per_receiver_sum

PROTOCOLS = ("law3", "classical")


@part(static=("protocol",))
class LeaderFollower:
    """Leader–follower flight software.

    Attributes
    ----------
    gain : (2,)
        K = [k_angle (N·m/rad), k_rate (N·m·s/rad)], per axis.
    follower : (n,)
        1 for a follower, 0 for the leader (which commands nothing).
    protocol : {"law3", "classical"}
        Static.
    """

    gain: jnp.ndarray
    follower: jnp.ndarray
    protocol: str

    commands = ("torque_b",)

    def init(self, n):
        return ()

    def outbox(self, y, state):
        """Each spacecraft broadcasts its measured angles and rates."""
        return {"angle": y["angle"], "omega": y["omega"]}

    def step(self, t, y, inbox, state, key):
        """Torque command (3, n): K times the weighted sum of the relative states heard."""
        if self.protocol == "classical":
            mine_angle, mine_rate = inbox.own["angle"], inbox.own["omega"]
        else:
            mine_angle, mine_rate = own_at_links(y["angle"], inbox.dst, 0), own_at_links(y["omega"], inbox.dst, 0)
        per_link = inbox.weight * (
            self.gain[0] * (inbox.msg["angle"] - mine_angle) + self.gain[1] * (inbox.msg["omega"] - mine_rate)
        )
        u = self.follower * per_receiver_sum(per_link, inbox.dst, y["omega"].shape[-1], 0)
        return {"torque_b": u}, state, {"torque_command": u}

    # The per-spacecraft form (the protocol of a LocalController, without ``local``: the
    # compiled loop keeps the formation-wide step above; software in the loop runs one
    # spacecraft per process, docs/sil.md).
    reads = ("angle", "omega")

    @property
    def reads_own(self):
        """``step_one`` reads ``inbox_i.own`` (the classical protocol: its own state of the
        instant each message was sent, which the network delivers with the message)."""
        return self.protocol == "classical"

    def outbox_one(self, i, y_i, state_i):
        """Spacecraft i's broadcast: its measured angles (3,) and rates (3,)."""
        return {"angle": y_i["angle"], "omega": y_i["omega"]}

    def step_one(self, i, t, y_i, inbox_i, state_i, key_i):
        """Spacecraft i's torque command (3,) N·m from its readings and the links addressed to
        it (``inbox_i``: one flat link axis (E,), the others zeroed; with the classical protocol
        ``own`` too); records as :meth:`step`. The same arithmetic as :meth:`step`'s column i:
        equal bit for bit with at most two links of nonzero weight into i, else to rounding."""
        if self.protocol == "classical":
            mine_angle, mine_rate = inbox_i.own["angle"], inbox_i.own["omega"]
        else:
            mine_angle, mine_rate = y_i["angle"][:, None], y_i["omega"][:, None]
        per_link = inbox_i.weight * (
            self.gain[0] * (inbox_i.msg["angle"] - mine_angle) + self.gain[1] * (inbox_i.msg["omega"] - mine_rate)
        )
        u = self.follower[i] * per_link.sum(axis=-1)
        return {"torque_b": u}, state_i, {"torque_command": u}

    def output_specs(self):
        return {"torque_command": OutputSpec(("component",), "N m", "body", "torque commanded by the law at the sample")}
