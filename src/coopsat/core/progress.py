"""Progress of a counted step on stderr: a tqdm bar where someone watches a terminal, plain
lines where the output goes to a log.

A tqdm bar redraws itself with carriage returns, which a log file or a CI page keeps as one
long line of overwritten bars; so when stderr is not a terminal the step writes one line per
tenth of its count instead (``simulating: 30 % (36/120 records)``). A notebook's stderr is no
terminal but draws tqdm's widget, so it gets the bar. Callers that were asked to be quiet
(``-q``) make no bar at all.
"""

import sys
import time

TENTHS = 10


def interactive(stream):
    """Whether ``stream`` is watched live: a terminal, or a Jupyter kernel's stream."""
    isatty = getattr(stream, "isatty", None)
    return bool(isatty and isatty()) or type(stream).__module__.startswith("ipykernel")


def progress_bar(total, desc, unit, *, initial=0, delay=0.0, leave=True):
    """A progress bar over ``total`` counts of ``unit`` (plural noun: "records", "runs") on
    stderr: :func:`tqdm.auto.tqdm` when stderr is :func:`interactive`, else :class:`TenthLines`.

    Either has ``update(n)`` and ``close()``. ``initial``: counts already done (a resumed
    campaign); ``delay``: seconds before anything shows, so that a quick step stays silent;
    ``leave``: whether a terminal keeps the finished bar.
    """
    if interactive(sys.stderr):
        from tqdm.auto import tqdm

        return tqdm(total=total, initial=initial, unit=f" {unit}", desc=desc, delay=delay, leave=leave)
    return TenthLines(sys.stderr, total, desc, unit, initial=initial, delay=delay)


def tenth(done, total):
    """How many whole tenths of ``total`` ``done`` has reached (0 … 10; 10 for an empty total)."""
    return TENTHS if total <= 0 else min(TENTHS, done * TENTHS // total)


class TenthLines:
    """Progress as plain lines, ``desc: P % (done/total unit)``, one each time the count
    reaches a further tenth of ``total`` (one line for several tenths reached at once), none
    before ``delay`` seconds have passed; the tenth ``initial`` already reached prints nothing.
    """

    def __init__(self, stream, total, desc, unit, initial=0, delay=0.0, clock=time.monotonic):
        self.stream, self.total, self.desc, self.unit = stream, total, desc, unit
        self.done, self.shown = initial, tenth(initial, total)
        self.clock = clock
        self.start, self.delay = clock(), delay

    def update(self, n=1):
        self.done += n
        reached = tenth(self.done, self.total)
        if reached > self.shown and self.clock() - self.start >= self.delay:
            percent = 100 if self.total <= 0 else 100 * self.done // self.total
            self.stream.write(f"{self.desc}: {percent} % ({self.done}/{self.total} {self.unit})\n")
            self.stream.flush()
            self.shown = reached

    def close(self):
        """Nothing to end: every line is complete when written (tqdm's bar needs its close)."""
