"""Formation keeping by consensus on relative positions over the network, in low orbit.

Each spacecraft i holds its slot ``δ_i`` relative to the spacecraft it hears, not relative to a
chief: with ``ρ_ij`` and ``ρ̇_ij`` the position and rotating-frame velocity of neighbour j seen
in i's own LVLH frame (:mod:`coopsat.geometry.frames`, x along-track, y against the orbit
normal, z to nadir),

    f_i = k_p Σ_j a_ij (ρ_ij − R_i (δ_j − δ_i)) + k_d Σ_j a_ij ρ̇_ij,

which is ``f_i = −k_p Σ_j a_ij ((ρ_i − ρ_j) − (δ_i − δ_j)) − k_d Σ_j a_ij (ρ̇_i − ρ̇_j)`` written
in the quantities one spacecraft can form: its own measured orbit and the orbits its neighbours
broadcast. The slots ``δ`` are given in one common LVLH frame (the first spacecraft's at t = 0);
``R_i`` turns that frame into the LVLH frame of slot i (:func:`slot_frame_turns`), so that a
train along one orbit is held on the orbit's curve, not on the common frame's straight x axis
(for 10 m gaps 990 m down a 500 km orbit the difference is 1.4 mm a gap, 7 cm at the tail).

Nobody is the reference: the formation's mean drifts freely (the common drag decays every orbit
alike), the spacing is what is kept. Each message is compared with the receiver's own orbit of
the instant it was sent (``inbox.own``: a relative state from two fixes of one time), so a delay
delays the relative state as a whole. The force is computed in i's LVLH axes and commanded in
ECI (``force_eci``: its own frame, not the first spacecraft's, whatever the formation's size).
"""


import jax.numpy as jnp

from coopsat.control.consensus import per_receiver_sum
from coopsat.core.parts import OutputSpec, part
from coopsat.geometry.frames import eci_to_lvlh, lvlh_dcm, lvlh_to_eci, lvlh_vector_to_eci


def slot_frame_turns(r_ref_eci, v_ref_eci, slot_lvlh_m):
    """``R_i``: components in the reference LVLH frame -> components in slot i's LVLH frame.

    Parameters
    ----------
    r_ref_eci, v_ref_eci : (3,)
        The reference orbit (the first spacecraft at t = 0), m and m/s, ECI.
    slot_lvlh_m : (n, 3)
        The slots in the reference LVLH frame, at rest in it, m.

    Returns
    -------
    ndarray, shape (n, 3, 3)
        ``C_lvlh_eci(slot i) · C_lvlh_eci(reference)ᵀ``; the identity for a slot at the origin.
        A slot along-track at arc θ from the reference turns by θ about the orbit normal.
    """
    import numpy as np

    r_ref, v_ref = np.asarray(r_ref_eci, dtype=float), np.asarray(v_ref_eci, dtype=float)
    slots = np.asarray(slot_lvlh_m, dtype=float)
    r_slot, v_slot = lvlh_to_eci(r_ref[None], v_ref[None], slots, np.zeros_like(slots))
    return np.asarray(lvlh_dcm(r_slot, v_slot)) @ np.asarray(lvlh_dcm(r_ref, v_ref)).T


_UNIT_ORBIT = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))
"""A harmless orbit (m, m/s) put where a link carries nothing: its weight is 0, but a zeroed
message would make the LVLH axes 0/0, and NaN times 0 is NaN."""


def _heard(weight, r_eci, v_eci):
    """``(r, v)`` of each link, :data:`_UNIT_ORBIT` where the link's weight is 0."""
    unit = [jnp.asarray(u).reshape((3,) + (1,) * (r_eci.ndim - 1)) for u in _UNIT_ORBIT]
    return jnp.where(weight > 0.0, r_eci, unit[0]), jnp.where(weight > 0.0, v_eci, unit[1])


def relative_orbit_lvlh(r_own_eci, v_own_eci, r_msg_eci, v_msg_eci, weight):
    """Per link, the transmitter's position (m) and rotating-frame velocity (m/s) in the
    receiver's LVLH frame; zero on a link of weight 0. Shapes (3, ...) -> (3, ...)."""
    own, msg = _heard(weight, r_own_eci, v_own_eci), _heard(weight, r_msg_eci, v_msg_eci)
    return eci_to_lvlh(*own, *msg, 0)


def spacing_error_lvlh(r_own_eci, v_own_eci, r_msg_eci, v_msg_eci, slot_own_m, slot_msg_m, dst, weight, turn, n):
    """Each spacecraft's weighted slot errors to the neighbours it hears, own LVLH frame.

    Parameters
    ----------
    r_own_eci, v_own_eci : (3, E) or (3, d, n)
        Per link, the receiver's own measured orbit of the instant the message was sent, m, m/s.
    r_msg_eci, v_msg_eci : (3, E) or (3, d, n)
        Per link, the transmitter's broadcast orbit, m, m/s.
    slot_own_m, slot_msg_m : (3, E) or (3, d, n)
        Per link, the receiver's and the transmitter's slots, reference LVLH, m.
    dst : int (E,) or (d, n)
        Receiver of each link.
    weight : (E,) or (d, n)
        ``a_ij`` of each link (0: absent, failed or lost).
    turn : (3, 3, n)
        ``R_i`` of every spacecraft (:func:`slot_frame_turns`, component-major).
    n : int
        Number of spacecraft (static).

    Returns
    -------
    (e_pos (3, n), e_vel (3, n))
        ``Σ_j a_ij (ρ_ij − R_i (δ_j − δ_i))``, m, and ``Σ_j a_ij ρ̇_ij``, m/s, LVLH of i.
    """
    rho, rho_dot = relative_orbit_lvlh(r_own_eci, v_own_eci, r_msg_eci, v_msg_eci, weight)
    seen = per_receiver_sum(weight * rho, dst, n, 0)
    wanted = per_receiver_sum(weight * (slot_msg_m - slot_own_m), dst, n, 0)
    e_pos = seen - jnp.einsum("abn,bn->an", turn, wanted)
    return e_pos, per_receiver_sum(weight * rho_dot, dst, n, 0)


@part()
class LvlhConsensus:
    """Flight software of relative-position consensus (see the module notes); command
    ``force_eci``.

    Attributes
    ----------
    k_p, k_d : scalar
        N/m and N·s/m, per unit of link weight.
    slot_lvlh_m : (3, n)
        Each spacecraft's slot, reference LVLH, m (what it broadcasts beside its orbit).
    turn : (3, 3, n)
        ``R_i`` (:func:`slot_frame_turns`).
    start_s : scalar
        The law commands nothing before this time, s (free drift until then).
    """

    k_p: jnp.ndarray
    k_d: jnp.ndarray
    slot_lvlh_m: jnp.ndarray
    turn: jnp.ndarray
    start_s: jnp.ndarray

    commands = ("force_eci",)
    reads = ("r_eci", "v_eci")
    reads_own = True

    def init(self, n):
        return ()

    def outbox(self, y, state):
        """Each spacecraft broadcasts its measured orbit and its slot."""
        return {"r_eci": y["r_eci"], "v_eci": y["v_eci"], "slot": self.slot_lvlh_m}

    def step(self, t, y, inbox, state, key):
        """Force ``force_eci`` (3, n), N; records it and the spacing error."""
        n = y["r_eci"].shape[-1]
        own, msg = inbox.own, inbox.msg
        e_pos, e_vel = spacing_error_lvlh(
            own["r_eci"], own["v_eci"], msg["r_eci"], msg["v_eci"], own["slot"], msg["slot"], inbox.dst, inbox.weight,
            self.turn, n,
        )
        return self._outputs(t, y["r_eci"], y["v_eci"], e_pos, e_vel, state)

    def outbox_one(self, i, y_i, state_i):
        """Spacecraft i's broadcast: its measured orbit (3,), (3,) and its slot (3,)."""
        return {"r_eci": y_i["r_eci"], "v_eci": y_i["v_eci"], "slot": self.slot_lvlh_m[:, i]}

    def step_one(self, i, t, y_i, inbox_i, state_i, key_i):
        """Spacecraft i's force (3,) N from its orbit and the links addressed to it (one flat
        link axis, the others zeroed, ``own`` beside them); records as :meth:`step`."""
        own, msg, w = inbox_i.own, inbox_i.msg, inbox_i.weight
        rho, rho_dot = relative_orbit_lvlh(own["r_eci"], own["v_eci"], msg["r_eci"], msg["v_eci"], w)
        wanted = jnp.sum(w * (msg["slot"] - own["slot"]), axis=-1)
        e_pos = jnp.sum(w * rho, axis=-1) - self.turn[:, :, i] @ wanted
        e_vel = jnp.sum(w * rho_dot, axis=-1)
        return self._outputs(t, y_i["r_eci"], y_i["v_eci"], e_pos, e_vel, state_i)

    def targets_lvlh(self):
        """Where each spacecraft should be relative to the first, in the first's LVLH frame, m,
        (n, 3) NumPy: ``R_0 (δ_i − δ_0)`` (design; for the truth errors of
        :mod:`coopsat.analysis.papers.station_keeping`)."""
        import numpy as np

        slots = np.asarray(self.slot_lvlh_m).T
        return (slots - slots[0]) @ np.asarray(self.turn)[:, :, 0].T

    def _outputs(self, t, r_eci, v_eci, e_pos, e_vel, state):
        f_lvlh = self.k_p * e_pos + self.k_d * e_vel
        f = jnp.where(t >= self.start_s, lvlh_vector_to_eci(r_eci, v_eci, f_lvlh, 0), 0.0)
        return {"force_eci": f}, state, {"force_command": f, "spacing_error_lvlh": e_pos}

    def output_specs(self):
        return {
            "force_command": OutputSpec(("component",), "N", "ECI", "force commanded by the control law at the sample"),
            "spacing_error_lvlh": OutputSpec(
                ("component",), "m", "LVLH",
                "sum over the neighbours heard of the link weight times the slot error (position seen minus slot "
                "difference), in the spacecraft's own LVLH frame, as the control law saw it",
            ),
        }
