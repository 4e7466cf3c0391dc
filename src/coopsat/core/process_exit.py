"""The ``coopsat`` command's end: exit with its status, skipping the interpreter's teardown.

After a command has done its work and printed its last line, Python's finalization still frees
every module and object one by one, JAX's runtime and matplotlib's and xarray's module graphs
among them: 0.25–0.3 s of a 1.2 s ``coopsat validate`` and 0.8–1.0 s of a 5–6 s ``coopsat run``
on the development machine, for nothing a user sees. :func:`end` does what a normal
exit does that has an effect outside the process (waiting for the program's own threads, the
:mod:`atexit` handlers, flushing stdout and stderr) and then ends the process at once.

Only the console script and ``python -m coopsat.cli`` call it; :func:`coopsat.cli.main` returns
its status, so a program or test that calls it in-process keeps its interpreter.
"""

import atexit
import os
import sys
import threading

EXIT_FLUSH_FAILED = 120
"""Python's own status when stdout cannot be flushed at exit (its reader went away)."""


def exit_code(status):
    """The process status :func:`sys.exit` gives ``status``: None is 0, an int itself, anything
    else is printed on stderr and gives 1."""
    if status is None:
        return 0
    if isinstance(status, int):
        return status
    print(status, file=sys.stderr)
    return 1


def _other_threads_running():
    """Whether a non-daemon thread besides the main one is alive (a normal exit waits for it)."""
    main = threading.main_thread()
    return any(t is not main and not t.daemon and t.is_alive() for t in threading.enumerate())


def end(status):
    """End the process with ``status`` (as :func:`sys.exit` would) without Python's teardown.

    While another non-daemon thread runs, or on an interpreter without
    ``atexit._run_exitfuncs``, this is :func:`sys.exit` itself (a normal exit waits for the
    thread). Otherwise the atexit handlers run (logging's flush, multiprocessing's children,
    :class:`weakref.finalize` hooks), stdout and stderr are flushed, and :func:`os._exit` ends
    the process. Never returns.
    """
    run_exit_handlers = getattr(atexit, "_run_exitfuncs", None)
    if run_exit_handlers is None or _other_threads_running():
        sys.exit(status)
    code = exit_code(status)
    run_exit_handlers()
    for stream in (sys.stdout, sys.stderr):
        try:
            if stream is not None:
                stream.flush()
        except (OSError, ValueError):  # a closed pipe or stream: what Python reports with 120
            code = code or EXIT_FLUSH_FAILED
    os._exit(code)
