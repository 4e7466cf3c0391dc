"""``coopsat design delay-gain`` (issue 26): a design that runs for a minute shows its stages on
stderr (plain lines when stderr is not a terminal, at most one per stage and per tenth of the
search), writes one file only, where ``--out`` says or under its default name, and names it in
the last line; a bad ``--out`` is refused before the search; an interrupt between gains leaves
nothing behind.

The runs search three gains of ``delay-law3-classic-gain`` (``--max-evaluations``), seconds
instead of the full search's minute.
"""

import io
import re
import signal
import subprocess
import sys

import pytest

from coopsat.cli import EXIT_BAD_INPUT, main
from coopsat.workflows import interrupt
from coopsat.workflows.stage_lines import StageLines, is_due

SCENARIO = "delay-law3-classic-gain"
SEARCH = re.compile(r"^design: gain search at h = 0\.5 s: (\d+)/3 gains, best so far: decay rate ([0-9.]+) 1/s")


def test_a_short_design_reports_its_stages_and_names_the_one_file_it_wrote(tmp_path, capsys):
    proc = subprocess.run([sys.executable, "-m", "coopsat.cli", "design", "delay-gain", SCENARIO, "--max-evaluations", "3"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert "\r" not in proc.stderr  # a pipe: plain lines, no carriage returns
    lines = proc.stderr.splitlines()
    assert lines[:2] == [
        "design: loading the scenario and running its design checks (delay margin, LMI)",
        "design: gain search at h = 0.5 s: up to 3 gains, each a bisection over LMI solves",
    ]
    counts = [int(SEARCH.match(line).group(1)) for line in lines[2:]]
    assert counts == [1, 2, 3]
    written = tmp_path / f"{SCENARIO}-delay-gain.toml"
    assert proc.stdout.splitlines()[-1] == f"wrote {written.name}"
    assert "3 gains evaluated" in proc.stdout
    assert sorted(tmp_path.iterdir()) == [written]  # nothing else in the working folder
    assert main(["validate", str(written)]) == 0
    assert capsys.readouterr().out.startswith(f"ok: {SCENARIO}-delay-gain:")


@pytest.mark.parametrize(
    "args, message",
    [
        (["--out", "designed.txt"], "--out designed.txt: a scenario file must end in .toml"),
        (["--out", "."], "--out .: is a folder; name the file"),
        (["--max-evaluations", "0"], "--max-evaluations 0: must be at least 1"),
    ],
)
def test_a_bad_out_or_budget_is_one_line_before_any_work(args, message, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["design", "delay-gain", SCENARIO, *args]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert err.startswith(f"coopsat: error: {message}") and err.count("\n") == 1  # not even the first stage
    assert not list(tmp_path.iterdir())


def test_quiet_prints_no_progress_and_out_makes_its_folder(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["design", "delay-gain", SCENARIO, "--max-evaluations", "1", "--h", "0.1", "-q", "--out", "k/d.toml"]) == 0
    out, err = capsys.readouterr()
    assert err == "" and out.splitlines()[-1] == "wrote k/d.toml"
    assert [p.relative_to(tmp_path).as_posix() for p in sorted(tmp_path.rglob("*"))] == ["k", "k/d.toml"]


def test_an_interrupt_between_gains_stops_the_search_and_writes_nothing(tmp_path):
    from coopsat.workflows.delay_gain import design_gain_scenario

    def stop_after_the_first_gain(stage, done, total, best):
        if done == 1:
            interrupt.request(signal.SIGINT, None)  # what Ctrl-C does under the command

    try:
        with pytest.raises(interrupt.Interrupted):
            design_gain_scenario(SCENARIO, h=0.1, out=tmp_path / "d.toml", max_evaluations=3,
                                 progress=stop_after_the_first_gain)
    finally:
        interrupt.restore(interrupt.install())  # clears the request, keeps pytest's handlers
    assert not list(tmp_path.iterdir())


def test_the_designed_file_follows_the_folder_rule(tmp_path):
    """A stop requested before the rename writes nothing; once the file is in place, the
    command's last line says it is complete (workflows.interrupt)."""
    from coopsat.workflows.folders import write_text_atomically

    path = tmp_path / "d.toml"
    try:
        interrupt.install()
        interrupt.request(signal.SIGINT, None)
        with pytest.raises(interrupt.Interrupted):
            write_text_atomically(path, "x = 1\n")
        assert not list(tmp_path.iterdir())
        interrupt.restore(interrupt.install())
        write_text_atomically(path, "x = 1\n")
        assert path.read_text() == "x = 1\n"
        assert interrupt.stop_line(signal.SIGTERM) == f"terminated (SIGTERM) after writing: the file {path} is complete"
    finally:
        interrupt.restore(interrupt.install())


# --- the lines themselves ----------------------------------------------------------------------


def _describe(stage, done, total, best):
    return f"{stage} {done}/{total}{best or ''}"


def test_plain_lines_come_once_per_stage_and_per_tenth():
    stream = io.StringIO()
    lines = StageLines(stream, _describe, prefix="x: ")
    lines("load", 0, 0, None)
    for done in range(0, 101):
        lines("search", done, 100, None)
    lines.close()
    assert stream.getvalue().splitlines() == ["x: load 0/0", *(f"x: search {d}/100" for d in range(0, 101, 10))]
    assert is_due(("search", 19), "search", 20, 100) and not is_due(("search", 20), "search", 29, 100)
    assert not is_due(("load", 0), "load", 0, 0)


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_on_a_terminal_a_stage_rewrites_its_line():
    stream = _Terminal()
    lines = StageLines(stream, _describe)
    lines("search", 9, 10, " (best 0.7)")
    lines("search", 10, 10, None)
    lines("write", 0, 0, None)
    lines.close()
    # The shorter line is padded with blanks over the longer one it replaces.
    assert stream.getvalue() == "\rsearch 9/10 (best 0.7)\rsearch 10/10          \n\rwrite 0/0\n"
    wide = _Terminal()
    StageLines(wide, _describe)("search", 1, 10, "x" * 200)
    assert wide.getvalue() == "\r" + "search 1/10" + "x" * 68  # 79 of the 80 columns told when unknown
