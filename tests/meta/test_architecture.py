"""Architecture rules that code review alone would miss."""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_layers_contract_holds():
    # import-linter reads [tool.importlinter] from pyproject.toml.
    proc = subprocess.run(
        [sys.executable, "-c", "from importlinter.cli import lint_imports_command; lint_imports_command()"],
        cwd=ROOT, capture_output=True, text=True,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_listing_scenarios_imports_no_heavy_library():
    code = (
        "import sys, io, contextlib\n"
        "from coopsat.cli import main\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n"
        "    assert main(['list']) == 0\n"
        "heavy = [m for m in ('jax', 'matplotlib', 'xarray', 'scipy', 'cvxpy', 'dask') if m in sys.modules]\n"
        "print(','.join(heavy))\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert proc.stdout.strip() == ""
