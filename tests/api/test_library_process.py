"""The plain library path, in a process coopsat does not own: no ``configure_process`` (no
XLA flags of the command's, no persistent cache, no xarray stand-in, JAX's own Threefry rule).
The rest of the suite runs in the command's set-up (tests/conftest.py); this runs a scenario the
way a user's script would, and finds the same numbers."""

import json
import os
import subprocess
import sys
import textwrap

import pytest

import coopsat

SCRIPT = textwrap.dedent(
    """
    import json, os, sys
    import coopsat
    result = coopsat.run(coopsat.Scenario.load("consensus-sync-a-stable").set("sim.t_final_s", 40.0))
    print(json.dumps({"metrics": result.metrics, "owned": os.environ.get("COOPSAT_OWNED_PROCESS"),
                      "xla_flags": os.environ.get("XLA_FLAGS")}))
    """
)


def test_a_library_process_runs_a_scenario_to_the_same_numbers(tmp_path):
    env = {k: v for k, v in os.environ.items() if k in ("PATH", "HOME", "LANG", "TMPDIR")}
    out = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, env=env, cwd=tmp_path,
                         timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    library = json.loads(out.stdout.strip().splitlines()[-1])
    assert library["owned"] is None and library["xla_flags"] is None  # nothing of the command's set-up
    here = coopsat.run(coopsat.Scenario.load("consensus-sync-a-stable").set("sim.t_final_s", 40.0)).metrics
    assert set(library["metrics"]) == set(here)
    for name, value in here.items():
        if isinstance(value, float):
            # The command's XLA flags (one CPU device per core, YNNPACK off) may change the order
            # of roundings, not the numbers: the loop has no solver (tests/data/README.md, "direct").
            assert library["metrics"][name] == pytest.approx(value, rel=1e-12, abs=1e-300), name
        else:
            assert library["metrics"][name] == value, name
