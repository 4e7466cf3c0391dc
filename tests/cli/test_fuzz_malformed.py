"""A seeded fuzz of malformed scenario files (issue 26): whatever the file holds, ``coopsat
validate`` exits 0 or 2, never with a traceback, and an error is exactly one line (no NumPy
RuntimeWarning before it; overflow is detected, not computed); a misspelt key is answered with
the name that was meant.

The mutations (a few hundred, from three bundled scenarios) run in-process; a few files run
through ``coopsat run`` in a subprocess, to see the real stderr of the run path.
"""

import copy
import random
import subprocess
import sys
import warnings

import numpy as np
import pytest
import tomli_w

from coopsat.cli import main
from coopsat.scenarios.load import read_raw

BASES = ("consensus-sync-a-stable", "orbit-two-body", "delay-designed")
MUTATIONS_PER_BASE = 90
SEED = 26

NUMBERS = [1e308, -1e308, 1.7e308, 1e-308, 5e-324, -1.0, 0, 0.0, 1e15, -1e9, 10**400, -(10**30), 2**63,
           float("inf"), float("-inf"), float("nan")]
OTHERS = ["nan", "1e308", "", True, [], [1.0, 2.0], {}, {"a": 1}, "x" * 200]


def _paths(node, path=()):
    """(path, value) of every table entry and array element under ``node``, depth first."""
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for key, value in items:
        yield path + (key,), value
        yield from _paths(value, path + (key,))


def _parent(raw, path):
    for part in path[:-1]:
        raw = raw[part]
    return raw


def _misspelt(rng, key):
    """``key`` with two neighbouring letters swapped (a typing slip), or a letter dropped."""
    k = rng.randrange(len(key) - 1)
    if key[k] != key[k + 1]:
        return key[:k] + key[k + 1] + key[k] + key[k + 2:]
    return key[:k] + key[k + 1:]


def _mutate(rng, raw):
    """One random change to a copy of ``raw``: (the copy, what was done, the misspelt key or None)."""
    raw = copy.deepcopy(raw)
    paths = list(_paths(raw))
    numeric = [(p, v) for p, v in paths if isinstance(v, (int, float)) and not isinstance(v, bool)]
    op = rng.choice(["number"] * 4 + ["element", "length", "delete", "misspell", "misspell", "extra", "other"])
    path, value = rng.choice(numeric if op == "number" and numeric else paths)
    parent, key = _parent(raw, path), path[-1]
    if op in ("number", "other") or (op in ("element", "length") and not isinstance(value, list)):
        parent[key] = rng.choice(NUMBERS if op == "number" else OTHERS)
    elif op == "element" and value:
        value[rng.randrange(len(value))] = rng.choice(NUMBERS + OTHERS)
    elif op == "length":
        parent[key] = value + [1.0] if rng.random() < 0.5 else value[:-1]
    elif op == "delete":
        del parent[key]
    elif op == "misspell" and isinstance(key, str) and len(key) >= 4:
        wrong = _misspelt(rng, key)
        parent[wrong] = parent.pop(key)
        return raw, f"{op} {path}", wrong
    elif op == "extra" and isinstance(parent, dict):
        parent["unheard_of"] = {"x": 1}
    return raw, f"{op} {path}", None


def _cases():
    rng = random.Random(SEED)
    for name in BASES:
        base, _ = read_raw(name)
        base["name"] = "fuzz"
        for _ in range(MUTATIONS_PER_BASE):
            yield (name, *_mutate(rng, base))


def _problems(status, out, err, misspelt):
    """What is wrong with one answer of ``coopsat validate`` (empty: nothing)."""
    lines = (out + err).strip().splitlines()
    if status not in (0, 2):
        return [f"exit {status}"]
    if "Traceback" in out + err or "RuntimeWarning" in err:
        return ["traceback or warning"]
    if status == 0:
        ok = out.startswith("ok:") and len(out.splitlines()) == 1 and all(x.startswith("warning: ") for x in err.splitlines())
        return [] if ok else ["odd output"]
    if len(lines) != 1 or not lines[0].startswith("coopsat: error: "):
        return [f"{len(lines)} lines"]
    wrong = [w for w in ("norm inf", "is inf", "misspelt?") if w in lines[0]]
    if misspelt is not None and f"{misspelt}: unknown field" in lines[0] and f"{misspelt}: unknown field; did you mean" not in lines[0]:
        wrong.append("no hint")
    return wrong


def test_malformed_files_give_one_line_and_no_warning(tmp_path, capsys):
    path = tmp_path / "fuzz.toml"
    failures, statuses = [], {0: 0, 2: 0}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for name, raw, what, misspelt in _cases():
            path.write_text(tomli_w.dumps(raw), encoding="utf-8")
            status = main(["validate", str(path)])
            captured = capsys.readouterr()
            problems = _problems(status, captured.out, captured.err, misspelt)
            statuses[status] = statuses.get(status, 0) + 1
            if problems:
                failures.append(f"{name} {what}: {problems}: {(captured.out + captured.err).strip()[:300]}")
    assert failures == [], f"{len(failures)} of {sum(statuses.values())} cases:\n" + "\n".join(failures[:10])
    assert [str(w.message) for w in caught] == []
    assert np.geterr() == {"divide": "warn", "over": "warn", "under": "ignore", "invalid": "warn"}  # nothing leaked
    # The fuzz reaches both sides: files that still validate and files refused.
    assert statuses[0] >= 20 and statuses[2] >= 150, statuses


def test_misspelt_keys_get_a_hint_for_each_table(tmp_path, capsys):
    rng = random.Random(SEED)
    base, _ = read_raw("delay-designed")
    keys = [p for p, _ in _paths(base) if isinstance(p[-1], str) and len(p[-1]) >= 5]
    path = tmp_path / "typo.toml"
    for key_path in rng.sample(keys, 12):
        raw = copy.deepcopy(base)
        parent, key = _parent(raw, key_path), key_path[-1]
        wrong = _misspelt(rng, key)
        parent[wrong] = parent.pop(key)
        path.write_text(tomli_w.dumps(raw), encoding="utf-8")
        assert main(["validate", str(path)]) == 2
        err = capsys.readouterr().err
        assert f"{wrong}: unknown field; did you mean `{key}`" in err, (key_path, err)


def _cli(*args, cwd):
    return subprocess.run([sys.executable, "-m", "coopsat.cli", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=300)


GOOD = """\
name = "huge"
[sim]
t_final_s = 0.1
dt_s = 0.01
[[spacecraft]]
inertia_kgm2 = [1.0, 0.9, 1.1]
omega_b_rad_s = {omega}
[[spacecraft]]
inertia_kgm2 = [1.0, 1.2, 0.8]
[network]
kind = "ring"
[controller]
kind = "consensus-sync"
period_s = 0.01
alpha = 1.0
beta = 2.0
"""


@pytest.mark.parametrize(
    "omega, expected",
    [
        ("[1e308, 0, 0]", "spacecraft[0].omega_b_rad_s: norm 1e+308 rad/s is above 1000 rad/s: not a physical value"),
        ("[1.7e308, 1.7e308, 0]", "spacecraft[0].omega_b_rad_s: norm overflows float64 (above 1.8e+308 rad/s)"),
        ("[1e400, 0, 0]", "spacecraft[0].omega_b_rad_s[0]: Input should be a finite number, got inf (a value beyond"),
    ],
)
def test_run_of_an_overflowing_rate_prints_exactly_one_line(tmp_path, omega, expected):
    (tmp_path / "huge.toml").write_text(GOOD.format(omega=omega), encoding="utf-8")
    proc = _cli("run", "huge.toml", "--out", "out", "-q", "--no-figures", cwd=tmp_path)
    lines = (proc.stdout + proc.stderr).strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1, proc.stdout + proc.stderr
    assert lines[0].startswith(f"coopsat: error: {expected}"), lines[0]
    assert not (tmp_path / "out").exists()
