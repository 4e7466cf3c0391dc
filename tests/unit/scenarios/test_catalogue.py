"""`coopsat list` reads the bundled scenarios without the schema (issue 26: ≤ 0.3 s)."""

import subprocess
import sys

from coopsat.scenarios.catalogue import bundled_names, description
from coopsat.scenarios.load import read_raw


def test_descriptions_are_those_of_the_loaded_scenarios():
    """The loader's reading (extends resolved, then merged) gives the same description."""
    names = bundled_names()
    assert len(names) >= 20
    for name in names:
        assert description(name) == read_raw(name)[0].get("description", ""), name


def test_list_imports_neither_the_schema_nor_jax_nor_numpy():
    code = ("import sys; from coopsat.cli import main; code = main(['list']); "
            "print(sorted(m for m in ('pydantic', 'coopsat.scenarios.schema', 'jax', 'numpy') if m in sys.modules), code)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.splitlines()[-1] == "[] 0"
    assert "consensus-sync-a " in out
