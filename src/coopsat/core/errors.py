"""The exceptions coopsat raises, and errors as the one line a user reads.

One base, a small tree by cause, each with the exit status of the ``coopsat`` command (the
public names are ``coopsat.CoopsatError``, ``coopsat.InputError``, …):

::

    CoopsatError                              exit 2
    ├── InputError (ValueError)               a scenario, campaign, sweep, run folder or option
    │   └── DesignError                       a design the input asks for cannot be made
    ├── PluginError                           a plug-in that cannot be registered or imported
    ├── SimulationError (RuntimeError)        the simulation cannot go on (a non-finite state)
    ├── ExternalProcessError (RuntimeError)   a process outside coopsat failed or misbehaved
    ├── PlatformError (RuntimeError)          this machine cannot do what was required
    └── StageFailedError (RuntimeError)       exit 3: a stage after the simulation failed, the
                                              run itself kept (:class:`coopsat.StageError`)

Every module's own exception derives from one of these (``ScenarioError`` from
:class:`InputError`, ``NonFiniteStateError`` from :class:`SimulationError`, …), so a caller
catches :class:`CoopsatError` for all of them, or a cause, and the command line catches the base
alone: this module imports nothing, so the error path loads no JAX. The standard bases
(``ValueError``, ``RuntimeError``) are kept where they were, so existing ``except ValueError``
code still works.

Two kinds of class are not errors and stay outside the tree: the warning categories, which
derive from :class:`CoopsatWarning`, and ``coopsat.workflows.interrupt.Interrupted``, a
``BaseException`` like ``KeyboardInterrupt`` so that no ``except Exception`` swallows a stop.
"""


class CoopsatError(Exception):
    """Base of every exception coopsat defines; its message is one line.

    Attributes
    ----------
    exit_status : int
        What the ``coopsat`` command exits with when this error ends it (class attribute).
    """

    exit_status = 2


class InputError(CoopsatError, ValueError):
    """Input that cannot be used: a scenario, campaign or sweep file, a run folder, an option.
    The message names the field or the cause."""


class DesignError(InputError):
    """A design the input asks for cannot be made (an infeasible LMI, an unstable Riccati
    solution, a configuration a plug-in's builder cannot build); the message is one line naming
    the field (``coopsat.plugins.DesignError``)."""


class PluginError(CoopsatError):
    """A plug-in that cannot be registered (one line): two registrations of one role and kind
    (naming both distributions and modules), an entry point that fails to import or names
    something else than a module or a ``Plugin``, an unknown role; or an analysis module that
    cannot be imported or has a malformed member (``coopsat.plugins.PluginError``)."""


class SimulationError(CoopsatError, RuntimeError):
    """The simulation cannot go on (a state that turned non-finite)."""


class ExternalProcessError(CoopsatError, RuntimeError):
    """A process outside coopsat (an external flight software under SIL) failed, did not answer
    or broke its protocol."""


class PlatformError(CoopsatError, RuntimeError):
    """This machine cannot do what was required (native kernels asked for but unavailable)."""


class StageFailedError(CoopsatError, RuntimeError):
    """A stage after the simulation failed; the run itself is kept (exit status 3)."""

    exit_status = 3


class CoopsatWarning(UserWarning):
    """Base of coopsat's warning categories."""


def one_line(err):
    """An exception as one line: its type, then its message's lines joined by "; "."""
    text = "; ".join(line.strip() for line in str(err).splitlines() if line.strip())
    return f"{type(err).__name__}: {text}" if text else type(err).__name__
