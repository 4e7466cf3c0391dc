"""A scenario run as software in the loop (``coopsat sil``, :func:`coopsat.sil`): checks, the
processes, the loop, and the same :class:`~coopsat.workflows.pipeline.Result` as ``coopsat run``.

The scenario is built and analysed by the pipeline's own functions; only the closed loop is
the SIL's (:mod:`~coopsat.workflows.sil.loop`). The record's attributes say that it was a SIL
run, with which protocol and processes, and every fault injected (``sil_events``: JSON, one
entry per kill, pause and resume, at its simulated time), so the run folder written by
:meth:`Result.save` records when and what. A realtime run also records its deadline misses
(``sil_deadline_misses``, per record interval and spacecraft) and the simulator's lag.
"""

import json
import re

from coopsat.plugins.protocols import optional
from coopsat.workflows import interrupt
from coopsat.workflows.sil.loop import Fault
from coopsat.workflows.sil.processes import builtin_command, external_command
from coopsat.workflows.sil.schema import SILError, SILSetupError

ANSWER_S = 10.0
"""Default longest wait for a flight-software answer in one control period, s."""

HANDSHAKE_S = 120.0
"""Default longest wait for every process to start and finish its handshake, s (twenty JAX
processes starting together on two cores take about a minute)."""

_FAULT = re.compile(r"^(?P<name>[^@]+)@(?P<t>[^:]+)(?::(?P<d>.+))?$")


def per_spacecraft_form(controller, kind, measured=None):
    """The controller as one flight software per spacecraft: the part itself when it is local or
    offers a per-spacecraft form (``reads``, ``outbox_one``, ``step_one``) whose readings the run
    measures (``measured``: the quantities of the run's state and sensors; None: not checked).

    Raises
    ------
    SILSetupError
        A formation-wide law without a per-spacecraft form, saying why, or one that reads what
        nothing in the run measures.
    """
    if all(hasattr(controller, a) for a in ("reads", "outbox_one", "step_one")):
        missing = [q for q in controller.reads if measured is not None and q not in measured]
        if missing:
            raise SILSetupError(
                f"controller kind '{kind}' cannot be split per spacecraft: its per-spacecraft form reads "
                f"{', '.join(missing)}, which nothing in this run measures (a sensor or a [navigation] filter provides it)"
            )
        return controller
    why = optional(controller, "per_spacecraft_refusal") or (
        "its step computes every spacecraft's command at once (sums over the whole formation's links) and it offers "
        "no per-spacecraft form (reads, outbox_one, step_one; docs/sil.md)")
    raise SILSetupError(f"controller kind '{kind}' cannot be split per spacecraft: {why}")


def _measured(built):
    """The quantities a run's flight software may read: its moving state's and its sensors'."""
    from coopsat.scenarios.build import state_quantities_of

    return state_quantities_of(built.scenario, built.system.actuators) | {s.quantity for s in built.system.sensors}


def parse_fault(text, kind):
    """The command line's ``NAME@T_S`` (``--kill``) or ``NAME@T_S:DURATION_S`` (``--pause``) as
    the record :func:`sil` takes: ``(name, t_s)`` or ``(name, t_s, duration_s)``.

    Raises
    ------
    SILSetupError
        Malformed (naming the option as given).
    """
    option = f"--{kind} {text}"
    m = _FAULT.match(text.strip())
    if m is None or (kind == "kill") != (m["d"] is None):
        form = "NAME@T_S" if kind == "kill" else "NAME@T_S:DURATION_S"
        raise SILSetupError(f"{option}: give {form} (e.g. {'sat3@10' if kind == 'kill' else 'sat3@120:30'})")
    try:
        times = (float(m["t"]),) if kind == "kill" else (float(m["t"]), float(m["d"]))
    except ValueError:
        raise SILSetupError(f"{option}: times are numbers of seconds") from None
    return (m["name"], *times)


def check_fault(kind, record, names, t_final_s):
    """A kill ``(name, t_s)`` or pause ``(name, t_s, duration_s)`` record as a :class:`Fault`.

    Raises
    ------
    SILSetupError
        A record of the wrong shape, an unknown spacecraft, a time outside the run, a pause of
        no duration (one line naming the record).
    """
    size = 2 if kind == "kill" else 3
    what = f"{kind} {tuple(record) if isinstance(record, (tuple, list)) else record!r}"
    if isinstance(record, str) or not isinstance(record, (tuple, list)) or len(record) != size:
        form = "(name, t_s)" if kind == "kill" else "(name, t_s, duration_s)"
        raise SILSetupError(f"{what}: give {form}")
    name, t_s, duration_s = (*record, 0.0)[:3]
    if name not in names:
        raise SILSetupError(f"{what}: no spacecraft '{name}' (spacecraft: {', '.join(names)})")
    if not 0.0 <= t_s < t_final_s:
        raise SILSetupError(f"{what}: t = {t_s:g} s is outside the run (0 to {t_final_s:g} s)")
    if kind == "pause" and not duration_s > 0.0:
        raise SILSetupError(f"{what}: the pause must last more than 0 s")
    return Fault(kind, name, float(t_s), float(duration_s))


def _commands(names, externals):
    """Each spacecraft's flight-software command: coopsat's own host, or the external one."""
    unknown = [n for n in externals if n not in names]
    if unknown:
        raise SILSetupError(f"external command of {unknown[0]}: no such spacecraft (spacecraft: {', '.join(names)})")
    return {n: external_command(externals[n], n) if n in externals else builtin_command() for n in names}


def parse_externals(assignments):
    """``--external NAME=COMMAND`` options as ``{name: command}``."""
    externals = {}
    for text in assignments:
        name, sep, command = text.partition("=")
        if not sep or not name.strip():
            raise SILSetupError(f'--external {text}: give NAME="COMMAND" (e.g. sat2="python law3.py")')
        externals[name.strip()] = command
    return externals


def sil_command(scenario, *, out_dir, overrides=(), kill=(), pause=(), externals=None, fault_command=None, realtime=None,
                answer_s=ANSWER_S, handshake_s=HANDSHAKE_S, figures=False, report=True, quiet=False, out=print, err=print):
    """``coopsat sil``: run, write the folder ``out_dir``, report. The options are :func:`sil`'s,
    as the command parsed them (fault records, ``{spacecraft: command}``); ``out``/``err`` print
    a line to stdout/stderr (with ``quiet`` only warnings: errors are the caller's to print).
    Returns the exit status (0)."""
    import jax

    from coopsat.workflows.pipeline import check_run_folder, run_and_save, summary_lines

    # A few small programs per control period: inline on the CPU they cost half as much (set
    # before JAX's CPU client starts; the command's process is coopsat's own).
    jax.config.update("jax_cpu_enable_async_dispatch", False)
    check_run_folder(out_dir)
    on_start = None if quiet else (
        lambda pids: err("sil: flight software " + ", ".join(f"{n} pid {p}" for n, p in pids.items())))
    result = run_and_save(
        lambda: sil(scenario, overrides=overrides, kill=kill, pause=pause, externals=externals,
                    fault_command=fault_command, realtime=realtime, answer_s=answer_s, handshake_s=handshake_s,
                    on_warning=lambda note: err(f"warning: {note}"), on_start=on_start),
        out_dir, figures=figures, report=report)
    if quiet:
        return 0
    out(f"wrote {out_dir}  (compile {result.compile_s:.2f} s, run {result.run_s:.2f} s)")
    for e in json.loads(result.dataset.attrs["sil_events"]):
        out(f"  sil: {e['spacecraft']} {e['event']} at t = {e['t_s']:g} s")
    if "sil_deadline_misses" in result.dataset:
        out("  sil: " + realtime_line(result.dataset))
    for line in summary_lines(_Summary(result, out_dir)):
        out(line)
    return 0


def _with_timing(ds, built, timing, realtime):
    """The record with a realtime run's schedule: misses per record interval and spacecraft,
    the factor, the simulator's overruns and largest lag."""
    counts = timing.counts(built.n_records, built.system.structure.periods_per_record, len(built.names))
    ds["sil_deadline_misses"] = (("time", "spacecraft"), counts, {
        "units": "1", "long_name": "control periods in the record interval whose answer from that spacecraft's flight "
                                   "software came after its realtime deadline (the late command held)"})
    ds.attrs.update(sil_realtime_factor=float(realtime), sil_realtime_overruns=int(timing.overruns),
                    sil_realtime_max_lag_s=float(timing.max_lag_s))
    return ds


class _Summary:
    """What :func:`coopsat.workflows.pipeline.summary_lines` reads of a run."""

    def __init__(self, result, out_dir):
        self.metrics, self.comparison, self.out_dir = result.metrics, result.comparison, out_dir


def realtime_line(ds):
    """One line on how a realtime run kept its schedule (``ds``: its record)."""
    misses = ds["sil_deadline_misses"].sum("time")
    late = ", ".join(f"{n} {int(m)}" for n, m in zip(misses["spacecraft"].values, misses.values) if m) or "none"
    return (f"realtime x{ds.attrs['sil_realtime_factor']:g}: deadline misses (periods): {late}; simulator "
            f"{ds.attrs['sil_realtime_overruns']} periods a slot or more behind, lag at most "
            f"{ds.attrs['sil_realtime_max_lag_s'] * 1e3:.1f} ms")


def sil(scenario, *, overrides=(), seed=None, kill=(), pause=(), externals=None, fault_command=None, realtime=None,
        answer_s=ANSWER_S, handshake_s=HANDSHAKE_S, on_warning=None, on_start=None, progress=None):
    """Run a scenario with one flight-software process per spacecraft; returns a
    :class:`~coopsat.workflows.pipeline.Result` (nothing written; :meth:`Result.save` writes the
    run folder). The arguments are :func:`coopsat.api.sil`'s; ``overrides``: ``key.path=value``
    assignments (``--set``); ``on_start`` is called with ``{spacecraft: pid}`` once the
    processes are started, ``progress`` with the records done.

    Raises
    ------
    SILSetupError, ScenarioError
        The run cannot start as asked.
    SILError
        A flight-software process failed or broke the protocol.
    """
    from coopsat.scenarios.document import with_overrides
    from coopsat.sim.engine import with_native_decided
    from coopsat.workflows.pipeline import analysed_result, prepare, record_dataset
    from coopsat.workflows.sil.processes import Fleet

    doc = with_overrides(scenario, overrides)
    if seed is not None:
        doc = doc.with_seed(seed)
    built = prepare(doc.model)
    names = list(built.names)
    controller = per_spacecraft_form(built.system.controller, built.scenario.controller.kind, _measured(built))
    t_final_s = built.scenario.sim.t_final_s
    faults = [check_fault("kill", f, names, t_final_s) for f in kill] + [check_fault("pause", f, names, t_final_s)
                                                                           for f in pause]
    fault_command = fault_command or built.scenario.sil.fault_command
    if fault_command not in ("hold", "zero"):
        raise SILSetupError(f"fault command '{fault_command}': give hold or zero")
    if realtime is not None and not realtime > 0:
        raise SILSetupError(f"realtime {realtime:g}: give a factor above 0")
    commands = _commands(names, dict(externals or {}))
    for note in built.warnings:
        if on_warning is not None:
            on_warning(note)
    interrupt.check()
    system = with_native_decided(built.system, built.n_records)
    from coopsat.workflows.sil.loop import run_loop

    fleet = Fleet(commands, answer_s)
    try:
        fleet.start()
        if on_start is not None:
            on_start(fleet.pids())
        out, events, timing = run_loop(built, system, fleet, controller, built.n_records, handshake_s=handshake_s,
                                       faults=faults, hold_commands=fault_command == "hold", realtime=realtime,
                                       progress=progress)
    except FileNotFoundError as err:
        raise SILError(f"a flight-software process cannot start: {err}") from None
    finally:
        fleet.close()
    from coopsat.workflows.sil import protocol

    failures = []  # a stage after the loop that raises costs only its own numbers (StageError)
    ds = record_dataset(built, out, failures, sil_protocol_version=protocol.VERSION, sil_transport=fleet.endpoint.split(":")[0],
                        sil_external=json.dumps({n: externals[n] for n in externals or {}}),
                        sil_fault_command=fault_command, sil_events=json.dumps(events.rows))
    if realtime:
        ds = _with_timing(ds, built, timing, realtime)
    return analysed_result(doc, built, ds, out, failures)
