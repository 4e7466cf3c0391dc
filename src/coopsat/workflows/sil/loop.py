"""The simulator's side of a SIL run: the closed loop one control period at a time, with the
flight software in other processes.

A period is the compiled loop's period, made of the engine's own stages
(:mod:`coopsat.sim.stepping`), cut where the flight software runs:

    begin (jitted: sense, the period's keys) → each process: ``sense`` → ``outbox``
    → deliver (jitted: the network part's own ``deliver``) → each process: ``inbox`` → ``command``
    → end (jitted: actuate, account, integrate the period)

Records are taken as the compiled loop takes them (:func:`~coopsat.sim.stepping.sample` at a
record interval's start, with the actuators' means over the interval;
:func:`~coopsat.sim.stepping.final_sample` after the last period) and assembled by the engine
(:func:`~coopsat.sim.engine.run_output`), so the run's dataset is built as ``coopsat run``'s is.
With every process answering, the result equals ``coopsat run``'s (the same functions on the
same numbers; docs/sil.md says to what precision and why).

A spacecraft whose process is killed or paused is *silent*: the simulator executes its last
command (or zero), records its controller's last record (or zeros), and the links it
transmits on are lost from that period on, by the network's rule for a lost message: held
(the last message each receiver got on the link) where the network part declares that it loses
messages and holds them (``lossy`` and ``hold``, :data:`coopsat.plugins.protocols.OPTIONAL`:
``kind = "delayed"`` with drop-outs and ``on_loss = "hold"``), else dropped (weight 0). Its slot
in the network's history keeps its last broadcast.

With ``realtime`` a period starts every ``period_s / realtime`` seconds of wall time, and every
flight software must answer both of its rounds within that slot. One that misses is *late* for
the period: late with its ``outbox``, its broadcast is lost as a silent spacecraft's and it gets
no ``inbox``; late with its ``command``, its actuators hold its last command (as actuators hold a
command until the next one comes: zero before its first). Its late answer is discarded when it
comes. Every miss is counted (:class:`Timing`).
"""

import math
import pickle
import time
from dataclasses import dataclass, field
from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from coopsat.plugins.protocols import optional
from coopsat.sim import stepping
from coopsat.sim.engine import output_shapes, run_output
from coopsat.workflows import interrupt
from coopsat.workflows.sil import protocol, schema


@dataclass
class Fault:
    """One injected fault: ``kind`` "kill" (for good) or "pause" (for ``duration_s``) of the
    flight software of ``name`` from ``t_s`` (s of simulated time; it takes effect at the
    first control period that starts at or after it)."""

    kind: str
    name: str
    t_s: float
    duration_s: float = 0.0


@dataclass
class Timing:
    """How a realtime run kept its schedule: the periods each spacecraft missed, and the
    simulator's own lag.

    Attributes
    ----------
    misses : list of (int, int)
        (period, spacecraft index) of every late answer (one per period at most).
    overruns : int
        Periods that started a whole slot or more behind their schedule (the simulator and the
        processes together did not keep up).
    max_lag_s : float
        Largest delay of a period's start behind its schedule, s of wall time.
    """

    misses: list = field(default_factory=list)
    overruns: int = 0
    max_lag_s: float = 0.0

    def counts(self, n_records, periods_per_record, n):
        """Late periods per record interval and spacecraft, (n_records + 1, n) (the last row:
        the final sample's period)."""
        counts = np.zeros((n_records + 1, n), np.int64)
        p, i = np.asarray(self.misses, np.int64).reshape(-1, 2).T
        np.add.at(counts, (np.minimum(p // periods_per_record, n_records), i), 1)
        return counts


@dataclass
class Events:
    """What happened to the processes, in simulated time (the run folder records it)."""

    rows: list = field(default_factory=list)

    def add(self, name, what, t_s):
        self.rows.append({"spacecraft": name, "event": what, "t_s": t_s, "wall_utc": time.time()})


class _Begun(NamedTuple):
    """A period once sensed (:func:`_begin`)."""

    sensed: stepping.Sensed
    """As :func:`~coopsat.sim.stepping.sense` returns it, ``y`` only the quantities the flight
    software reads (``{quantity: (k, n)}``)."""
    keys: jax.Array
    """Each spacecraft's controller key, ``fold_in(controller key, i)``, (n, 2)."""


@partial(jax.jit, static_argnames=("reads",))
def _begin(system, state, reads):
    """Sense at the start of the period of ``state`` (a :class:`~coopsat.sim.stepping.PeriodState`)."""
    sensed = stepping.sense(system, state.x, state.parts, state.tick)
    ctrl_key = stepping.controller_key(sensed.key)
    keys = jax.vmap(lambda i: jax.random.fold_in(ctrl_key, i))(jnp.arange(system.structure.n_spacecraft))
    return _Begun(sensed._replace(y={q: sensed.y[q] for q in reads}), keys)


def _host(tree):
    """The tree's arrays as NumPy arrays (``jax.device_get`` costs ten times more per leaf)."""
    return jax.tree_util.tree_map(np.asarray, tree)


@jax.jit
def _network_init(system, outbox):
    return system.network.init(outbox)


@partial(jax.jit, static_argnames=("own",))
def _deliver(system, tick, outbox, net_state, key, own=False):
    """The network part's ``deliver`` in the period whose key is ``key``, its links flat (as the
    compiled loop flattens them for per-spacecraft flight software,
    :mod:`coopsat.sim.flight_software`): messages ``{name: (k, E)}``, weights (E,), and with
    ``own`` each link's receiver's own outbox of the instant its message was sent
    (``{name: (k, E)}``; else ``{}``)."""
    inbox, net_state, record = stepping.deliver(system, tick, outbox, net_state, key)
    links = inbox.weight.ndim
    flat = lambda m: m.reshape(m.shape[: m.ndim - links] + (-1,))  # noqa: E731
    mine = jax.tree_util.tree_map(flat, inbox.own) if own else {}
    return jax.tree_util.tree_map(flat, inbox.msg), inbox.weight.reshape(-1), mine, net_state, record


@partial(jax.jit, static_argnames=("reads",))
def _end_begin(system, state, sensed, cmd, record, reads):
    """Actuate, account and integrate the period of ``state`` (sensed as ``sensed``) under the
    commands ``cmd``, then begin the next one (one program, not two: a dispatch costs more than
    the period's arithmetic). Returns the next :class:`~coopsat.sim.stepping.PeriodState`, the
    period's record and the next period's :class:`_Begun`."""
    pulses, parts, record = stepping.actuate(system, state.x, sensed.parts, sensed.t, sensed.key, cmd, record)
    state = stepping.advance(system, state, parts, pulses, stepping.account(system, pulses))
    return state, record, _begin(system, state, reads)


@jax.jit
def _final(system, state, sensed, cmd, record):
    """The last sample: the period that would follow actuated under ``cmd``, then
    :func:`~coopsat.sim.stepping.final_sample` (as the compiled loop's last sample)."""
    pulses, _, record = stepping.actuate(system, state.x, sensed.parts, sensed.t, sensed.key, cmd, record)
    return stepping.final_sample(system, state, pulses, record)


_interval_means = jax.jit(lambda system, before, after: stepping.interval_means(
    system, before, after, system.period_s * system.structure.periods_per_record))


def setup_messages(built, system, controller, y0, replies):
    """Each spacecraft's ``setup`` message (protocol version 1; docs/sil.md); ``replies``: the
    schema of its replies (:func:`~coopsat.workflows.sil.schema.replies_schema`), which the
    simulator holds it to."""
    names = list(built.names)
    dst = np.asarray(system.network.dst).reshape(-1)
    src = np.asarray(system.network.src).reshape(-1)
    part = pickle.dumps(jax.tree_util.tree_map(np.asarray, controller))
    table = built.scenario.controller.model_dump(mode="json")
    common = {
        "type": protocol.SETUP, "version": protocol.VERSION, "names": names,
        "period_s": float(system.period_s), "reads": {q: list(np.shape(y0[q])[:-1]) for q in controller.reads},
        "commands": list(replies[protocol.COMMAND]["commands"]), "replies": replies, "controller": table,
        "part": part,
    }
    messages = {}
    for i, name in enumerate(names):
        mine = np.flatnonzero(dst == i)
        messages[name] = {**common, "name": name, "index": i,
                          "links": {"dst": dst.tolist(), "mine": mine.tolist(), "from": [names[s] for s in src[mine]]}}
    return messages


def _period_of(t_s, period_s):
    """The first control period that starts at or after ``t_s``."""
    return math.ceil(t_s / period_s - 1e-9)


def _schedule(faults, period_s):
    """The faults as (period, action, name, fault) in period order: kill, pause, resume."""
    plan = []
    for f in faults:
        plan.append((_period_of(f.t_s, period_s), f.kind, f.name, f))
        if f.kind == "pause":
            plan.append((_period_of(f.t_s + f.duration_s, period_s), "resume", f.name, f))
    return sorted(plan, key=lambda row: row[0])


def blank_outbox(controller, y0, n):
    """Spacecraft 0's broadcast as the law makes it, in zeros: ``{name: (k,)}`` (its shapes,
    found without running the law)."""
    state_0 = jax.tree_util.tree_map(lambda a: a[..., 0], controller.init(n))
    y_0 = {q: y0[q][..., 0] for q in controller.reads}
    shapes = jax.eval_shape(lambda y, s: controller.outbox_one(0, y, s), y_0, state_0)
    return {k: np.zeros(v.shape) for k, v in shapes.items()}


class _Silence:
    """What stands in for a silent spacecraft: its last broadcast, and its last command and
    record (or zeros, without ``hold_commands``)."""

    def __init__(self, names, hold_commands, blank):
        self.names = names
        self.hold_commands = hold_commands
        self.blank = blank  # a broadcast of zeros: a spacecraft silent before its first one
        self.msg, self.cmd, self.record = {}, {}, {}

    def outbox(self, replies):
        """``{name: (k, n)}``: each spacecraft's broadcast (``replies``: the ``outbox`` replies,
        checked against the schema), or its last one when silent."""
        for name, r in replies.items():
            self.msg[name] = {k: np.asarray(v, np.float64) for k, v in r["msg"].items()}
        return {k: np.stack([self.msg.get(n, self.blank)[k] for n in self.names], axis=-1) for k in self.blank}

    def commands(self, replies, shapes, record_specs, late=frozenset()):
        """The commands ``{name: (3, n)}`` and the controller's record, silent ones standing in
        (``late``: names whose command is held whatever ``hold_commands`` says)."""
        for name, r in replies.items():
            self.cmd[name] = {k: np.asarray(v, np.float64) for k, v in r["commands"].items()}
            self.record[name] = {k: np.asarray(v, np.float64) for k, v in r["record"].items()}
        cmd = {k: np.stack([self._value(self.cmd, n, k, shape, replies, late) for n in self.names], axis=-1)
               for k, shape in shapes.items()}
        record = {}
        for k, (shape, per_spacecraft) in record_specs.items():
            if per_spacecraft:
                record[k] = np.stack([self._value(self.record, n, k, shape, replies, late) for n in self.names],
                                     axis=-1)
            else:  # one value per instant (a reference): any answering process's
                record[k] = next((self.record[n][k] for n in self.names if n in replies), np.zeros(shape))
        return cmd, record

    def _value(self, table, name, k, shape, replies, late):
        if name in replies or ((self.hold_commands or name in late) and name in table):
            return table[name][k]
        return np.zeros(shape)


class _Links:
    """Which flat links each spacecraft hears and which it transmits on, and what a silent
    transmitter's links carry (held or dropped: the module docstring)."""

    def __init__(self, network, n):
        self.src = np.asarray(network.src).reshape(-1)
        self.mine = [np.flatnonzero(np.asarray(network.dst).reshape(-1) == i) for i in range(n)]
        self.hold = optional(network, "lossy") and optional(network, "hold")
        self.held = None

    def silence(self, msg, weight, own, live):
        """The delivered ``msg`` ``{name: (k, E)}``, ``weight`` (E,) and ``own`` (as ``msg``, or
        empty) with the links of the spacecraft not in ``live`` (indices) lost (a held message
        keeps the ``own`` it came with, as the network holds both)."""
        silent = ~np.isin(self.src, live) if len(live) < len(self.mine) else None
        if silent is not None and silent.any():
            if self.hold and self.held is not None:
                held_msg, held_own = self.held
                msg = {k: np.where(silent, held_msg[k], m) for k, m in msg.items()}
                own = {k: np.where(silent, held_own[k], m) for k, m in own.items()}
            else:
                weight = np.where(silent, 0.0, weight)
        self.held = msg, own
        return msg, weight, own


class _Loop:
    """The SIL closed loop of one run (:func:`run_loop` says what it takes)."""

    def __init__(self, built, system, fleet, controller, hold_commands, blank):
        self.names = list(built.names)
        self.view = stepping.engine_view(system)
        self.fleet = fleet
        self.reads = tuple(controller.reads)
        self.reads_own = optional(controller, "reads_own")
        self.links = _Links(system.network, len(self.names))
        recorded = output_shapes(system)  # interface layout: (n, k…) per spacecraft
        self.record_specs = {k: (recorded[k][1:] if spec.per_spacecraft else recorded[k], spec.per_spacecraft)
                             for k, spec in controller.output_specs().items()}
        self.command_shapes = {c: (3,) for c in controller.commands}
        self.replies = schema.replies_schema({k: v.shape for k, v in blank.items()}, self.command_shapes,
                                             {k: shape for k, (shape, _) in self.record_specs.items()})
        self.silence = _Silence(self.names, hold_commands, blank)
        self.net_state = None
        self.timing = Timing()

    def live(self):
        """Indices of the spacecraft whose flight software answers this period."""
        gone = self.fleet.killed | self.fleet.paused
        return [i for i, n in enumerate(self.names) if n not in gone]

    def control(self, p, tick, begun, due=None):
        """Both rounds of period ``p`` with the processes that answer, and the network between
        them; ``begun``: the period's :class:`_Begun`; ``due``: realtime, the instant
        (``time.monotonic()``) by which both rounds must be answered (the module docstring).
        Returns the commands and the record so far."""
        sensed = begun.sensed
        y, keys, t_s = _host((sensed.y, begun.keys, sensed.t))
        t_s, live = float(t_s), self.live()
        replies = self.fleet.exchange({self.names[i]: {"type": protocol.SENSE, "k": p, "t": t_s,
                                                       "y": {q: y[q][..., i].tolist() for q in y}} for i in live},
                                      protocol.OUTBOX, p, due)
        late = [i for i in live if self.names[i] not in replies]
        live = [i for i in live if self.names[i] in replies]
        outbox = self.silence.outbox(replies)
        if self.net_state is None:  # the history before t = 0 is the first outbox
            self.net_state = _network_init(self.view, outbox)
        msg, weight, own, self.net_state, net_record = _deliver(self.view, tick, outbox, self.net_state, sensed.key,
                                                                own=self.reads_own)
        msg, weight, own = self.links.silence(*_host((msg, weight, own)), live)
        mine = self.links.mine

        def inbox(i):
            message = {"type": protocol.INBOX, "k": p, "t": t_s, "msg": {k: m[..., mine[i]].tolist() for k, m in msg.items()},
                       "weight": weight[mine[i]].tolist(), "key": keys[i].tolist()}
            if self.reads_own:
                message["own"] = {k: m[..., mine[i]].tolist() for k, m in own.items()}
            return message

        replies = self.fleet.exchange({self.names[i]: inbox(i) for i in live}, protocol.COMMAND, p, due)
        late += [i for i in live if self.names[i] not in replies]
        self.timing.misses += [(p, i) for i in sorted(late)]
        cmd, ctrl_record = self.silence.commands(replies, self.command_shapes, self.record_specs,
                                                 {self.names[i] for i in late})
        return cmd, {**sensed.measured, **net_record, **ctrl_record}


def _apply_faults(plan, p, period_s, fleet, events):
    """Carry out the faults due at period ``p`` (``plan``: :func:`_schedule`'s, consumed)."""
    while plan and plan[0][0] <= p:
        _, action, name, _ = plan.pop(0)
        if action == "kill" and name not in fleet.killed:
            fleet.kill(name)
        elif action == "pause" and name not in fleet.killed:
            fleet.pause(name)
        elif action == "resume" and name in fleet.paused:
            fleet.resume(name)
        else:
            continue
        events.add(name, {"kill": "killed", "pause": "paused", "resume": "resumed"}[action], p * period_s)


def run_loop(built, system, fleet, controller, n_records, *, handshake_s, faults=(), hold_commands=True, realtime=None,
             progress=None):
    """Run the SIL closed loop; returns (RunOutput, Events, Timing).

    Parameters
    ----------
    built : coopsat.scenarios.build.Built
    system : System
        The run's system, the native kernels decided (:func:`~coopsat.sim.engine.with_native_decided`).
    fleet : coopsat.workflows.sil.processes.Fleet
        Started, its handshake not yet made.
    controller : part
        The controller's per-spacecraft form (``reads``, ``outbox_one``, ``step_one``).
    n_records : int
    handshake_s : float
        Longest wait for every process's handshake, s.
    faults : sequence of Fault
    hold_commands : bool
        A silent spacecraft's actuators execute its last command (else zero).
    realtime : float, optional
        Pace the run at this many simulated seconds per wall second, with deadlines (the module
        docstring; default: lockstep, as fast as the processes answer). The schedule starts
        after period 0, which compiles the simulator's programs.
    progress : callable, optional
        Called with the records done so far after each record.
    """
    state, y0 = jax.jit(stepping.initial_parts)(system)
    loop = _Loop(built, system, fleet, controller, hold_commands, blank_outbox(controller, y0, len(built.names)))
    view, ppr = loop.view, system.structure.periods_per_record
    period_s = float(system.period_s)
    fleet.handshake(setup_messages(built, system, controller, y0, loop.replies), handshake_s)
    plan, events, chunks = _schedule(faults, period_s), Events(), []
    begun = _begin(view, state, loop.reads)
    t0, compile_s = time.perf_counter(), 0.0
    slot_s, due = (period_s / realtime if realtime else None), None
    for p in range(n_records * ppr + 1):
        interrupt.check()
        _apply_faults(plan, p, period_s, fleet, events)
        if slot_s and p == 1:
            schedule = time.monotonic() - slot_s  # period p starts at schedule + p slots
        if slot_s and p >= 1:
            due = _pace(schedule + p * slot_s, slot_s, loop.timing)
        cmd, record = loop.control(p, state.tick, begun, due)
        if p == n_records * ppr:
            last = _host(_final(view, state, begun.sensed, cmd, record))
            break
        before = state
        state, record, begun = _end_begin(view, state, begun.sensed, cmd, record, loop.reads)
        if p % ppr == 0:  # a record interval starts: its state and first record make its sample
            start, start_record = before, record
        if p % ppr == ppr - 1:
            means = _interval_means(view, start.counters, state.counters)
            chunks.append(_host(stepping.sample(stepping.truth(view, start.x), start.counters, start_record, means)))
            if progress is not None:
                progress(len(chunks))
        if p == 0:
            compile_s = time.perf_counter() - t0
    out = _output(built, system, chunks, last, n_records, compile_s, time.perf_counter() - t0 - compile_s)
    return out, events, loop.timing


def _pace(start, slot_s, timing):
    """Wait for a period's scheduled ``start`` (``time.monotonic()``); returns the instant its
    answers are due: one slot after it began (a period that begins late, because the one before
    overran, still gives the flight software a whole slot). Counts the simulator's lag."""
    lag_s = time.monotonic() - start
    if lag_s < 0.0:
        time.sleep(-lag_s)
    timing.max_lag_s = max(timing.max_lag_s, lag_s)
    timing.overruns += lag_s >= slot_s
    return max(start, time.monotonic()) + slot_s


def _output(built, system, chunks, last, n_records, compile_s, run_s):
    """The samples as the engine returns them (:class:`~coopsat.sim.engine.RunOutput`),
    checked for non-finite states."""
    stacked = {k: np.stack([c[k] for c in chunks]) for k in chunks[0]}
    t_samples = np.arange(n_records + 1) * float(built.record_interval_s)
    return run_output(system, stacked, last, t_samples, compile_s=compile_s, run_s=run_s, names=list(built.names))
