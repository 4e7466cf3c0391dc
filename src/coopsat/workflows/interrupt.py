"""Clean interrupts: SIGINT and SIGTERM ask a command to stop; it stops at the next safe point,
and its exit status is never 0.

Raising from a signal handler is not reliable inside JAX (an exception raised while a garbage
collector callback runs is swallowed: the run would finish and write its folder). So the
command line installs :func:`request` as the handler, and the long stages call :func:`check`
at their safe points (after compiling, after each compiled chunk of the loop, between the
pipeline's stages), which raises :class:`Interrupted`. A second signal raises at once.

What a stopped command leaves is decided by one rule, around the rename that puts a finished
folder in place (:func:`coopsat.workflows.folders.atomic_folder`):

- a stop requested before the rename (start-up, compiling, simulating, the metrics, writing the
  files and figures into the temporary sibling): :func:`check` raises right before it, the
  temporary folder is removed, and the command ends with "nothing written", status 130 (SIGINT)
  or 143 (SIGTERM);
- a stop requested during or after the rename: the folder is complete and stays; the rename is
  never cut short (inside :func:`holding` a second signal waits until it is done), the command
  reaches its next safe point or its end, and it ends with status 130 or 143 and the last line
  "interrupted (SIGINT) after writing: the folder OUT is complete" (:func:`wrote` notes it,
  :func:`stop_line` says it).

The command line reads what is pending when it puts the handlers back (:func:`restore`), so a
signal during a command's last steps (printing the summary) also ends it with 130 or 143.
"""

import signal
from contextlib import contextmanager

_requested = []  # the signals received since install(), first first
_written = {}  # path -> what a stop after its rename reports ("the folder runs/x is complete")
_holding = []  # non-empty while a finished output is renamed into place


class Interrupted(BaseException):
    """A run stopped by a signal (a BaseException, like KeyboardInterrupt, so that no
    ``except Exception`` swallows it and every clean-up runs)."""

    def __init__(self, signum):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def request(signum, frame):
    """Signal handler: note the request; a second one stops at once (once a rename in
    :func:`holding` is done)."""
    if _requested and not _holding:
        raise Interrupted(signum)
    _requested.append(signum)


def check():
    """Raise :class:`Interrupted` if a stop was requested."""
    if _requested:
        raise Interrupted(_requested[0])


@contextmanager
def holding():
    """Signals are only noted inside (the rename of a finished output must not be cut short);
    a second one raises on the way out."""
    _holding.append(True)
    try:
        yield
    finally:
        _holding.pop()
    if len(_requested) > 1:
        raise Interrupted(_requested[-1])


def wrote(path, note):
    """Note that the output at ``path`` is in place: ``note`` (e.g. "the folder runs/x is
    complete") is what :func:`stop_line` reports if the command is stopped after. A later note
    for the same path replaces the earlier one (a campaign counts its batches)."""
    _written[str(path)] = note


def stop_line(signum):
    """The last line of a command stopped by ``signum`` (without the "coopsat: " prefix)."""
    what = "terminated (SIGTERM)" if signum == signal.SIGTERM else "interrupted (SIGINT)"
    if not _written:
        return f"{what}; nothing written"
    return f"{what} after writing: {'; '.join(_written.values())}"


def install():
    """Handle SIGINT and SIGTERM with :func:`request` (main thread only); returns the previous
    handlers for :func:`restore`."""
    _requested.clear()
    _written.clear()
    return {sig: signal.signal(sig, request) for sig in (signal.SIGINT, signal.SIGTERM)}


def restore(previous):
    """Put the ``previous`` handlers back, then return the signal of a stop requested while ours
    were in place (None if none) and forget it, so that later work in this process runs on.

    Handlers first: a signal that comes after acts as Python's default (KeyboardInterrupt, or
    the end of the process for SIGTERM), never as an exit status 0."""
    if not previous:
        return None  # nothing was installed (not the main thread): nothing of ours to forget
    for sig, handler in previous.items():
        signal.signal(sig, handler)
    pending = _requested[0] if _requested else None
    _requested.clear()
    return pending
