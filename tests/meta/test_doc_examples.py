"""Documentation that runs: every ``python`` and ``bash`` fenced block of README.md and docs/
is executed as written, in a fresh folder (issue 24).

A block may be preceded by one directive comment (docs/api.md, "Examples that run"):

* ``<!-- doc-test: skip REASON -->`` — not run (installing into a new virtual environment,
  a cluster that is not here); the reason is shown;
* ``<!-- doc-test: append ARGS -->`` — ARGS appended to each ``coopsat`` command of the block,
  to shorten a long run (``--set sim.t_final_s=20``, ``--max-iter 2``); the command's own
  options stay as the reader sees them, a later option wins.

``python`` blocks run in a fresh interpreter; ``bash`` blocks run command by command, each
``coopsat`` as this interpreter's ``python -m coopsat.cli``. Blocks of one file run in order
in one folder, so a later block may read what an earlier one wrote.
"""

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
FENCE = re.compile(r"(?:<!-- doc-test: (?P<directive>[^\n]*?) -->\n)?```(?P<lang>python|bash)\n(?P<body>.*?)```", re.S)
SLOW_S = 60
"""Blocks expected to take longer than this, s, are marked ``slow`` by their directive ``slow``."""


def blocks(path):
    """``(lang, body, directive)`` of each runnable fenced block of a markdown file, in order."""
    return [(m["lang"], m["body"], (m["directive"] or "").strip()) for m in FENCE.finditer(path.read_text(encoding="utf-8"))]


def commands(body):
    """The shell commands of a bash block: continuation lines joined, comments and blanks dropped."""
    joined = re.sub(r"\\\n\s*", " ", body)
    out = []
    for line in joined.splitlines():
        words = shlex.split(line, comments=True)
        if words:
            out.append(words)
    return out


def _env():
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT / "src"), env.get("PYTHONPATH")]))
    return env


def run_block(lang, body, directive, cwd):
    """Run one block; raise AssertionError with its output when it fails."""
    if lang == "python":
        proc = subprocess.run([sys.executable, "-c", body], cwd=cwd, capture_output=True, text=True, env=_env())
        assert proc.returncode == 0, f"python block failed:\n{body}\n--- stderr ---\n{proc.stderr[-4000:]}"
        return
    extra = shlex.split(directive.removeprefix("slow").strip().removeprefix("append")) if "append" in directive else []
    for words in commands(body):
        if words[0] == "coopsat":
            words = [sys.executable, "-m", "coopsat.cli", *words[1:], *extra]
        proc = subprocess.run(words, cwd=cwd, capture_output=True, text=True, env=_env())
        assert proc.returncode == 0, f"command failed: {shlex.join(words)}\n--- stderr ---\n{proc.stderr[-4000:]}"


def _cases():
    for path in DOCS:
        found = blocks(path)
        if not found:
            continue
        slow = any(d.startswith("slow") for _, _, d in found)
        marks = [pytest.mark.slow] if slow else []
        yield pytest.param(path, found, id=str(path.relative_to(ROOT)), marks=marks)


@pytest.mark.parametrize(("path", "found"), list(_cases()))
def test_examples_run_as_written(path, found, tmp_path):
    ran = 0
    for lang, body, directive in found:
        if directive.startswith("skip"):
            assert directive.removeprefix("skip").strip(), f"{path.name}: a skipped block must say why"
            continue
        run_block(lang, body, directive, tmp_path)
        ran += 1
    assert ran, f"{path.name}: every block is skipped"


def test_directives_are_known():
    for path in DOCS:
        for _, _, directive in blocks(path):
            assert re.fullmatch(r"(slow ?)?(skip .+|append .+)?", directive), f"{path.name}: unknown directive '{directive}'"


def test_the_readme_opens_its_python_session_with_the_api():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    using = text.split("## Using it", 1)[1]
    first = FENCE.search(using)
    assert first["lang"] == "python" and "coopsat.run(" in first["body"] and len(first["body"].splitlines()) <= 12
