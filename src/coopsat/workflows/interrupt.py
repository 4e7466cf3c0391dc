"""Clean interrupts: SIGINT and SIGTERM ask a run to stop; the run stops at the next safe point.

Raising from a signal handler is not reliable inside JAX (an exception raised while a garbage
collector callback runs is swallowed: the run would finish and write its folder). So the
command line installs :func:`request` as the handler, and the long stages call :func:`check`
at their safe points (after compiling, after each compiled chunk of the loop, between the
pipeline's stages), which raises :class:`Interrupted`. A second signal raises at once.
"""

import signal

_requested = []


class Interrupted(BaseException):
    """A run stopped by a signal (a BaseException, like KeyboardInterrupt, so that no
    ``except Exception`` swallows it and every clean-up runs)."""

    def __init__(self, signum):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def request(signum, frame):
    """Signal handler: note the request; a second one stops at once."""
    if _requested:
        raise Interrupted(signum)
    _requested.append(signum)


def check():
    """Raise :class:`Interrupted` if a stop was requested."""
    if _requested:
        raise Interrupted(_requested[0])


def install():
    """Handle SIGINT and SIGTERM with :func:`request` (main thread only); returns the previous
    handlers for :func:`restore`."""
    _requested.clear()
    return {sig: signal.signal(sig, request) for sig in (signal.SIGINT, signal.SIGTERM)}


def restore(previous):
    for sig, handler in previous.items():
        signal.signal(sig, handler)
