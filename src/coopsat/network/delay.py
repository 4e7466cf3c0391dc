"""A network that delays, loses and relays messages, inside the compiled loop.

Every control period each spacecraft's outbox is written into a ring buffer of the last
``D + 1`` outboxes (D: the largest delay the scenario allows, in periods). The message on a
link at period f is the transmitter's outbox of period ``f − d``, with

    d = c_route + m · τ(f)

(c_route: the fixed per-hop delays summed along the route; m: its hops; τ: the random
single-hop delay, piecewise constant and redrawn at random instants, SPEC §3). Before t = 0
the history is the first outbox. A message is lost with probability ``1 − (1 − p)^m``
(each hop drops it with probability p); the receiver then holds the last message it got on
that link, or drops the term (weight 0) for that period. With each message the inbox carries
the receiver's own outbox of the same past period (for protocols that delay the whole
relative state). Routes, hops and fixed delays per
topology epoch are computed at design time (:mod:`coopsat.network.routing`).

Memory: the buffer holds ``(D + 1) · n`` values of every outbox field; for N = 1000
spacecraft broadcasting attitude and rate (7 numbers) with 2 s of delay at a 1 ms period,
2001 × 1000 × 7 × 8 B = 112 MB.
"""


import jax
import jax.numpy as jnp

from coopsat.core.parts import OutputSpec, part
from coopsat.network.delivery import Inbox, active_row


@part(static=("period_ticks", "buffer_periods", "random", "lossy", "hold"))
class DelayedNetwork:
    """Network part with per-route delays, a random single-hop delay, drop-outs and relaying.

    Attributes
    ----------
    src, dst : int (E,) or (d, n)
        Heard pairs (transmitter, receiver; the union over topology epochs), as
        :class:`~coopsat.network.topology.Links`.
    weight : (G, E) or (G, d, n)
        Weight of each pair in each epoch (0: not heard then).
    hops : int (G, E) or (G, d, n)
        Hops of each pair's route in each epoch.
    delay_periods : int (G, E) or (G, d, n)
        Fixed delay of each pair's route in each epoch, control periods.
    loss_probability : (G, E) or (G, d, n)
        Probability that a pair's message is lost in one period.
    switch_ticks : int (G,)
        First tick of each epoch.
    tau_min, tau_max : int scalars
        Bounds of the random single-hop delay τ, control periods (inclusive).
    hold_min, hold_max : int scalars
        Bounds of the time between two draws of τ, control periods (inclusive, ≥ 1).
    period_ticks : int
        Static: base ticks per control period.
    buffer_periods : int
        Static: D + 1, the periods of history kept (D the largest possible delay).
    random, lossy, hold : bool
        Static: τ is random; messages can be lost; a lost message is replaced by the last one
        received (else its term is dropped).
    """

    src: jnp.ndarray
    dst: jnp.ndarray
    weight: jnp.ndarray
    hops: jnp.ndarray
    delay_periods: jnp.ndarray
    loss_probability: jnp.ndarray
    switch_ticks: jnp.ndarray
    tau_min: jnp.ndarray
    tau_max: jnp.ndarray
    hold_min: jnp.ndarray
    hold_max: jnp.ndarray
    period_ticks: int
    buffer_periods: int
    random: bool
    lossy: bool
    hold: bool

    def init(self, outbox0):
        """Ring buffer filled with the first outbox; τ due for a draw at period 0."""
        # Any message shape (..., n): the history of the spacecraft axis lies along it.
        buffer = jax.tree_util.tree_map(lambda v: jnp.tile(v, (1,) * (v.ndim - 1) + (self.buffer_periods,)), outbox0)
        state = {"buffer": buffer, "tau": jnp.zeros((), jnp.int64), "next_draw": jnp.zeros((), jnp.int64)}
        if self.lossy and self.hold:
            state["last"] = jax.tree_util.tree_map(
                lambda v: jnp.take(v, self.src, axis=-1), outbox0
            ), jax.tree_util.tree_map(lambda v: jnp.take(v, self.dst, axis=-1), outbox0)
        return state

    def _tau(self, frame, state, key):
        """τ at this period and the next draw instant (piecewise constant, redrawn at random)."""
        k_tau, k_hold = jax.random.split(key)
        draw = frame >= state["next_draw"]
        tau = jax.random.randint(k_tau, (), self.tau_min, self.tau_max + 1)
        hold = jax.random.randint(k_hold, (), self.hold_min, self.hold_max + 1)
        return jnp.where(draw, tau, state["tau"]), jnp.where(draw, frame + hold, state["next_draw"])

    def deliver(self, tick, outbox, state, key):
        """Write this period's outbox, read each link's delayed message, apply losses."""
        leaves = jax.tree_util.tree_leaves(outbox)
        n = leaves[0].shape[-1] if leaves else 0  # a controller that sends nothing (kind "none"): nothing buffered
        frame = tick // self.period_ticks
        slot = frame % self.buffer_periods
        buffer = jax.tree_util.tree_map(
            lambda b, v: jax.lax.dynamic_update_slice_in_dim(b, v, slot * n, axis=-1), state["buffer"], outbox
        )
        row = active_row(self.switch_ticks, tick)
        k_tau, k_loss = jax.random.split(key)
        tau, next_draw = self._tau(frame, state, k_tau) if self.random else (state["tau"], state["next_draw"])
        delay = jnp.minimum(self.delay_periods[row] + self.hops[row] * tau, self.buffer_periods - 1)
        slot_then = ((frame - delay) % self.buffer_periods) * n
        index = slot_then + self.src
        msg = jax.tree_util.tree_map(lambda b: jnp.take(b, index, axis=-1), buffer)
        own = jax.tree_util.tree_map(lambda b: jnp.take(b, slot_then + self.dst, axis=-1), buffer)
        weight = self.weight[row]
        source = (buffer, index)
        new_state = {"buffer": buffer, "tau": tau, "next_draw": next_draw}
        if self.lossy:
            lost = jax.random.uniform(k_loss, weight.shape) < self.loss_probability[row]
            if self.hold:
                keep = lambda new, old: jnp.where(lost, old, new)  # noqa: E731
                msg, own = jax.tree_util.tree_map(keep, (msg, own), state["last"])
                new_state["last"] = (msg, own)
                source = None  # a held message is no longer a gather of the buffer
            else:
                weight = jnp.where(lost, 0.0, weight)
        record = {"network_tau_periods": tau} if self.random else {}
        return Inbox(msg, weight, self.dst, own, source), new_state, record

    def output_specs(self):
        if not self.random:
            return {}
        return {
            "network_tau_periods": OutputSpec(
                (), "1", "", "random single-hop delay tau in force at the sample, control periods", False
            )
        }
