"""The flight-software processes of a SIL run: started, answered, paused, killed, reaped.

Every process is a child of the simulator, in its process group, and started through a
launcher that asks Linux to kill it when the simulator dies (``PR_SET_PDEATHSIG``) before it
becomes the flight software (``exec``): so a simulator killed outright (SIGKILL) leaves none
behind. Otherwise :meth:`Fleet.close` (a ``with`` block's exit, and ``atexit`` as a last
resort) stops them: a ``stop`` message, a short wait, then SIGKILL (which also ends a paused
one), then ``wait`` so that none stays a zombie. No receive waits forever: every wait polls in
short slices, checks the processes it waits on, and has a deadline.

Nothing is left in the file system either: each process's output goes to an anonymous file
(unlinked from the start; the simulator reads its tail through its own descriptor), and the
private folder of the IPC socket is removed once every process has connected (the end of the
handshake; connections outlive the name), so a simulator killed outright after its start-up
leaves no file behind.

Every message a process sends passes :mod:`~coopsat.workflows.sil.schema`'s check before it is
used: anything else ends the run in one line naming the process and the field.
"""

import atexit
import os
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from coopsat.workflows import interrupt
from coopsat.workflows.sil import protocol, schema
from coopsat.workflows.sil.schema import SILError, SILSetupError

POLL_SLICE_MS = 100
"""Longest time one poll blocks before the waits check for a stop request and dead processes."""

STOP_GRACE_S = 2.0
"""How long :meth:`Fleet.close` waits for the processes to leave after ``stop``, s."""

_LAUNCHER = (
    "import ctypes, os, signal, sys\n"
    "try:\n"
    "    ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG (Linux)\n"
    "except (AttributeError, OSError):\n"
    "    pass\n"
    f"if os.getppid() != int(os.environ['{protocol.PARENT_ENV}']):\n"
    "    os._exit(1)  # the simulator died before the line above: nobody to fly for\n"
    "os.execvp(sys.argv[1], sys.argv[1:])\n"
)
"""Runs in the child before it becomes the flight software: die with the simulator."""


def builtin_command():
    """The command of coopsat's own flight-software host (:mod:`coopsat.workflows.sil.fsw`)."""
    return [sys.executable, "-m", "coopsat.workflows.sil.fsw"]


class Fleet:
    """One flight-software process per spacecraft, and the simulator's socket.

    Parameters
    ----------
    commands : dict of str -> list of str
        Each spacecraft's command (argv), in spacecraft order.
    answer_s : float
        Longest wait for an answer in a control period, s.
    """

    def __init__(self, commands, answer_s):
        import zmq

        self.names = list(commands)
        self.answer_s = answer_s
        self.procs = {}
        self.identity = {}  # name -> the ZeroMQ routing id its hello came from
        self._name = {}  # and back
        self._schema = {}  # name -> the schema of its replies, as its setup told it (schema.replies_schema)
        self.paused = set()
        self.killed = set()
        self._since = {}  # name -> since when it has been awaited without a word from it (time.monotonic())
        self._logs = {}  # name -> its output, an anonymous file
        self._dir = Path(tempfile.mkdtemp(prefix="coopsat-sil-"))  # private (0700): the socket, until the handshake ends
        self._ctx = zmq.Context()
        self._sock = self._ctx.socket(zmq.ROUTER)
        self._sock.linger = 0
        self._sock.router_mandatory = 1  # a send to a process that is gone raises instead of vanishing
        if zmq.has("ipc"):
            self.endpoint = f"ipc://{self._dir / 'sim'}"
            self._sock.bind(self.endpoint)
        else:
            port = self._sock.bind_to_random_port("tcp://127.0.0.1")
            self.endpoint = f"tcp://127.0.0.1:{port}"
        self._poller = zmq.Poller()
        self._poller.register(self._sock, zmq.POLLIN)
        atexit.register(self.close)
        self._commands = commands

    def start(self):
        """Start every process (its output goes to a log file, quoted when it fails)."""
        for name, argv in self._commands.items():
            env = {**os.environ, protocol.ENDPOINT_ENV: self.endpoint, protocol.NAME_ENV: name,
                   protocol.PARENT_ENV: str(os.getpid())}
            self._logs[name] = log = tempfile.TemporaryFile()
            self.procs[name] = subprocess.Popen([sys.executable, "-c", _LAUNCHER, *argv], env=env, stdout=log,
                                                stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)

    def pids(self):
        """Process id of each spacecraft's flight software."""
        return {name: p.pid for name, p in self.procs.items()}

    def handshake(self, setups, timeout_s):
        """Answer each process's ``hello`` with its ``setup`` and wait for its ``ready``; its
        later replies are checked against the schema its ``setup`` carries (``replies``).

        Parameters
        ----------
        setups : dict of str -> dict
            Each spacecraft's ``setup`` message.
        timeout_s : float
            Longest wait for the whole handshake, s.

        Raises
        ------
        SILError
            A process that exits, does not answer in time or sends anything but its ``hello``,
            then its ``ready`` (:mod:`~coopsat.workflows.sil.schema`).
        """
        deadline = time.monotonic() + timeout_s
        ready = set()
        while len(ready) < len(self.names):
            waiting = [n for n in self.names if n not in self.identity] or [n for n in self.names if n not in ready]
            late = ("did not say hello (did it start? does it speak docs/sil.md's protocol?)"
                    if waiting[0] not in self.identity else "did not get ready (its setup)")
            got = self._receive(waiting, deadline, f"{late} within {timeout_s:g} s")
            if got is None:
                continue
            identity, message = got
            if identity in self._name:
                schema.check_ready(self._name[identity], message)
                ready.add(self._name[identity])
            else:
                name = schema.check_hello(message, [n for n in self.names if n not in self.identity])
                self.identity[name], self._name[identity] = identity, name
                self._schema[name] = setups[name]["replies"]
                self._send(name, setups[name])
        shutil.rmtree(self._dir, ignore_errors=True)  # every process is connected: the socket's name is not needed

    def exchange(self, messages, answer, k, due=None):
        """Send each named process its message and collect each one's answer of type
        ``answer`` for period ``k``; returns ``{name: reply}``, each checked against its schema,
        its arrays float64 ndarrays (:func:`~coopsat.workflows.sil.schema.check_reply`).

        Parameters
        ----------
        messages : dict of str -> dict
        answer : str
        k : int
        due : float, optional
            Realtime: the instant (``time.monotonic()``) after which a missing answer is late;
            the replies are returned without it (its late answer is discarded when it comes).
            A process from which nothing at all (not even a late answer) has come for
            ``answer_s`` is hung: an error, as in lockstep (``due`` None), where every answer
            is awaited up to ``answer_s``.

        Raises
        ------
        SILError
            A process that exits, hangs or sends a message that is not a well-formed reply in
            its turn (one line naming it and the field).
        """
        start = time.monotonic()
        for name, message in messages.items():
            self._send(name, message)
            self._since.setdefault(name, start)
        replies = {}
        while len(replies) < len(messages):
            waiting = [n for n in messages if n not in replies]
            if due is not None and time.monotonic() >= due:
                break
            hung = min(self._since.get(n, start) for n in waiting) + self.answer_s
            got = self._receive(waiting, hung, f"did not answer period {k} within {self.answer_s:g} s", until=due)
            if got is None:
                continue
            identity, message = got
            name = self._name_of(identity)
            reply = schema.check_reply(name, message, answer, k, self._schema[name], name in waiting)
            if reply is not None:  # else a late answer (a process paused or late mid-answer): discarded
                replies[name] = reply
        return replies

    def _send(self, name, message):
        import zmq

        try:
            self._sock.send_multipart([self.identity[name], protocol.encode(message)])
        except zmq.ZMQError as err:
            raise SILError(f"{name}'s flight software cannot be reached ({err}){self._log_tail(name)}") from None

    def _name_of(self, identity):
        try:
            return self._name[identity]
        except KeyError:
            raise SILError("a message came from a process that never said hello") from None

    def _receive(self, waiting, deadline, late, until=None):
        """One message ``(identity, message)``, or None after a poll slice (ending at ``until``
        at the latest) with none; raises :class:`SILError` when a process waited on has exited
        or the deadline has passed, and :class:`~coopsat.workflows.interrupt.Interrupted` on a
        stop request."""
        slice_ms = POLL_SLICE_MS if until is None else min(POLL_SLICE_MS, max(0.0, until - time.monotonic()) * 1e3)
        if self._poller.poll(slice_ms):
            identity, *frames = self._sock.recv_multipart()
            self._since.pop(self._name.get(identity), None)  # alive
            return identity, schema.read(self._name.get(identity), frames)
        interrupt.check()  # a Ctrl-C at the terminal reaches the flight software too: a stop, not a crash
        for name in waiting:
            code = self.procs[name].poll()
            if code is not None:
                raise SILError(f"{name}'s flight software exited ({_status(code)}) without being told to"
                               f"{self._log_tail(name)}")
        if time.monotonic() > deadline:
            raise SILError(f"{', '.join(waiting)}: flight software {late}{self._log_tail(waiting[0])}")
        return None

    def _log_tail(self, name):
        """The last line of a process's output, as ``": LINE"`` (empty when it wrote none)."""
        try:
            fd = self._logs[name].fileno()
            size = os.fstat(fd).st_size
            # pread: the process writes through the same open file, whose offset must not move
            lines = os.pread(fd, 4096, max(0, size - 4096)).decode(errors="replace").strip().splitlines()
        except (KeyError, OSError, ValueError):
            return ""
        return f": {lines[-1].strip()}" if lines else ""

    def kill(self, name):
        """SIGKILL one spacecraft's flight software and reap it."""
        proc = self.procs[name]
        proc.kill()
        proc.wait()
        self.killed.add(name)
        self.paused.discard(name)

    def pause(self, name):
        """SIGSTOP one spacecraft's flight software (it is idle, waiting for its next message)."""
        os.kill(self.procs[name].pid, signal.SIGSTOP)
        self.paused.add(name)

    def resume(self, name):
        """SIGCONT a paused flight software."""
        os.kill(self.procs[name].pid, signal.SIGCONT)
        self.paused.discard(name)
        self._since.pop(name, None)

    def close(self):
        """Stop every process and reap it; close the logs, remove the socket. Idempotent."""
        atexit.unregister(self.close)
        if self._ctx is None:
            return
        for name, proc in self.procs.items():
            if proc.poll() is None and name in self.identity and name not in self.paused:
                try:
                    self._send(name, {"type": protocol.STOP})
                except Exception:  # noqa: BLE001 - a process that is gone: it is killed below anyway
                    pass
        deadline = time.monotonic() + STOP_GRACE_S
        for proc in self.procs.values():
            try:
                proc.wait(max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                pass
        for proc in self.procs.values():
            if proc.poll() is None:
                proc.kill()  # ends a stopped (paused) process too
            proc.wait()
        self._sock.close(0)
        self._ctx.term()
        self._ctx = None
        for log in self._logs.values():
            log.close()
        shutil.rmtree(self._dir, ignore_errors=True)


def _status(code):
    return f"killed by {signal.Signals(-code).name}" if code < 0 else f"status {code}"


def external_command(text, name):
    """An ``--external`` command line as argv: split as a POSIX shell splits words (quotes and
    backslashes), but with no shell (no expansion, redirection or pipe: nothing between the
    simulator and the process it must be able to kill); the program is looked up on ``PATH``
    unless it names a path (docs/sil.md, "External flight software")."""
    try:
        argv = shlex.split(text)
    except ValueError as err:  # an unclosed quote
        raise SILSetupError(f"external command of {name}: {err} in {text!r}") from None
    if not argv:
        raise SILSetupError(f"external command of {name}: empty")
    if shutil.which(argv[0]) is None:
        raise SILSetupError(f"external command of {name}: cannot start {argv[0]!r} (not found or not executable)")
    return argv
