"""The stages after a simulation (series, metrics, comparison, figures, report), each run so that
one that raises costs only what it computes: the record and every other stage's output stay.

A run collects what failed as :class:`StageFailure` lines; when any failed, the pipeline ends
with a :class:`StageError` that carries everything that was computed (and where it was written).
"""

from dataclasses import dataclass

from coopsat.core.errors import StageFailedError, one_line


@dataclass(frozen=True)
class StageFailure:
    """One stage that raised after the simulation.

    Attributes
    ----------
    stage : str
        ``"series"``, ``"metrics"``, ``"comparison"``, ``"figures"`` or ``"report"``.
    source : str
        Whose code raised: ``"analysis module 'm' of plug-in controller 'k' of dist (module)"``,
        or ``"coopsat"`` for coopsat's own stage.
    error : str
        The exception, in one line (``"ZeroDivisionError: division by zero"``).
    """

    stage: str
    source: str
    error: str

    def __str__(self):
        return f"the {self.stage} stage failed in {self.source}: {self.error}"


def guarded(failures, stage, source, fallback, fn, *args):
    """``fn(*args)``, or ``fallback`` after appending a :class:`StageFailure` to ``failures``
    when it raises an ``Exception`` (an interrupt, ``KeyboardInterrupt``, still stops the run).
    With ``failures`` None the error propagates (a sweep, a campaign: no partial run to keep)."""
    if failures is None:
        return fn(*args)
    try:
        return fn(*args)
    except Exception as err:  # noqa: BLE001 (plug-in code: any error is reported, none ends the run)
        failures.append(StageFailure(stage, source, one_line(err)))
        return fallback


class StageError(StageFailedError):
    """A stage after the simulation failed; the run itself is kept.

    Attributes
    ----------
    failures : tuple of StageFailure
    result : coopsat.Result
        Everything computed: the record (``dataset``), the metrics and comparison rows that
        could be computed.
    out_dir : Path or None
        The run folder, when it was written (``coopsat run``, :meth:`coopsat.Result.save`):
        ``result.nc`` and every file whose stage succeeded.
    """

    def __init__(self, failures, result, out_dir=None):
        self.failures = tuple(failures)
        self.result = result
        self.out_dir = out_dir
        kept = f"the record and what else was computed are in {out_dir}" if out_dir else "the record is in .result"
        super().__init__("; ".join(map(str, self.failures)) + f" ({kept})")
