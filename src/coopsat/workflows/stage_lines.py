"""Progress of a long step as text on a stream (stderr): one line per stage and per tenth of a
counted stage, so that a log stays short; on a terminal the line of a stage is rewritten in
place instead (carriage return), so that every report shows without scrolling.

The step reports through a callback ``(stage, done, total, best)`` (the design functions'
``progress``); :class:`StageLines` is such a callback and turns the reports into lines with
the caller's ``describe`` (the same arguments, returns the text).
"""

import os


def is_due(last, stage, done, total, steps=10):
    """Whether a report earns a line of its own: the first of a stage, or the first to reach
    the next of ``steps`` equal parts of ``total`` (the count of the stage; 0: not counted).

    ``last`` is ``(stage, done)`` of the last line written, or None before the first.
    """
    if last is None or last[0] != stage:
        return True
    if total <= 0:
        return False
    return done * steps // total > last[1] * steps // total


def _columns(stream):
    """Width of the terminal behind ``stream``, characters (80 when it cannot be told)."""
    try:
        return os.get_terminal_size(stream.fileno()).columns
    except (AttributeError, OSError, ValueError):
        return 80


class StageLines:
    """A progress callback that writes ``prefix + describe(stage, done, total, best)`` to
    ``stream``: plain lines at most one per stage and per tenth of it when the stream is not a
    terminal (a log, a pipe: no carriage returns); on a terminal every report, rewriting the
    stage's line, cut to the terminal's width (a wrapped line could not be rewritten).
    :meth:`close` ends an open terminal line, so that what follows starts on a line of its own.
    """

    def __init__(self, stream, describe, prefix="", steps=10):
        self.stream, self.describe, self.prefix, self.steps = stream, describe, prefix, steps
        isatty = getattr(stream, "isatty", None)
        self.tty = bool(isatty and isatty())
        self.width = _columns(stream) if self.tty else None
        self.last = None  # (stage, done) of the last line written
        self.open_width = 0  # characters of the unfinished terminal line (0: none)

    def __call__(self, stage, done, total, best):
        if not (self.tty or is_due(self.last, stage, done, total, self.steps)):
            return
        text = self.prefix + self.describe(stage, done, total, best)
        if not self.tty:
            self.stream.write(text + "\n")
        else:
            if self.last is None or self.last[0] != stage:
                self.close()
            text = text[: self.width - 1]
            # Pad with blanks: the new text may be shorter than the one it overwrites.
            self.stream.write("\r" + text.ljust(self.open_width))
            self.open_width = max(self.open_width, len(text))
        self.last = (stage, done)
        self.stream.flush()

    def close(self):
        """End the open terminal line, if any (a no-op for plain lines)."""
        if self.tty and self.open_width:
            self.stream.write("\n")
            self.stream.flush()
        self.open_width = 0
