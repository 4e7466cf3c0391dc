"""Progress on stderr (coopsat.core.progress): a tqdm bar on a terminal, a plain line per tenth
of the count anywhere else (a log keeps no carriage returns), nothing before the delay."""

import io
import sys

from coopsat.core import progress
from coopsat.core.progress import TenthLines, progress_bar


class Terminal(io.StringIO):
    def isatty(self):
        return True


def test_a_log_gets_one_plain_line_per_tenth():
    log = io.StringIO()
    bar = TenthLines(log, 120, "simulating", "records")
    for _ in range(40):
        bar.update(3)
    bar.close()
    lines = log.getvalue().splitlines()
    assert "\r" not in log.getvalue()
    assert lines == [f"simulating: {p} % ({p * 120 // 100}/120 records)" for p in range(10, 101, 10)]


def test_several_tenths_at_once_give_one_line_and_a_resume_starts_where_it_was():
    log = io.StringIO()
    bar = TenthLines(log, 8, "campaign", "runs", initial=2)  # 25 % on disk already: no line for it
    bar.update(2)
    bar.update(4)
    assert log.getvalue().splitlines() == ["campaign: 50 % (4/8 runs)", "campaign: 100 % (8/8 runs)"]


def test_nothing_before_the_delay():
    now = [0.0]
    log = io.StringIO()
    bar = TenthLines(log, 10, "simulating", "records", delay=2.0, clock=lambda: now[0])
    bar.update(5)
    assert log.getvalue() == ""  # a quick step stays silent
    now[0] = 2.5
    bar.update(1)
    assert log.getvalue() == "simulating: 60 % (6/10 records)\n"


def test_a_terminal_gets_a_tqdm_bar_and_a_pipe_plain_lines(monkeypatch):
    from tqdm.auto import tqdm

    monkeypatch.setattr(sys, "stderr", Terminal())
    bar = progress_bar(10, "campaign", "runs")
    bar.update(10)
    bar.close()
    assert isinstance(bar, tqdm) and "\r" in sys.stderr.getvalue()
    monkeypatch.setattr(sys, "stderr", io.StringIO())
    assert isinstance(progress_bar(10, "campaign", "runs"), TenthLines)
    assert progress.interactive(Terminal()) and not progress.interactive(io.StringIO())
