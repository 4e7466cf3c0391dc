"""The house plan matches the house (issue 27): docs/architecture.md's layer list is the
import-linter contract, every subpackage is in a layer, the package root holds only the public
API and the CLI, and no module or function grows past what a reader can hold."""

import ast
import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "src" / "coopsat"
MAX_MODULE_LINES = 600
MAX_FUNCTION_LINES = 80


def _contract_layers():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]["contracts"]
    (layers,) = [c["layers"] for c in config if c["type"] == "layers"]
    return [" ".join(layer.split()) for layer in layers]


def _documented_layers():
    text = (ROOT / "docs" / "architecture.md").read_text()
    block = re.search(r"<!-- layers -->\s*```\n(.*?)```", text, re.S)
    assert block, "docs/architecture.md: no '<!-- layers -->' block"
    return [" ".join(line.split()) for line in block.group(1).splitlines() if line.strip()]


def test_documented_layers_are_the_import_linter_contract():
    assert _documented_layers() == _contract_layers()


def test_every_subpackage_is_in_a_layer():
    named = {m.strip().split(".")[1] for layer in _contract_layers() for m in re.split(r"[|:]", layer)}
    packages = {p.name for p in PACKAGE.iterdir() if (p / "__init__.py").is_file()}
    modules = {p.stem for p in PACKAGE.glob("*.py") if p.stem != "__init__"}
    assert packages | modules <= named, sorted((packages | modules) - named)


def test_package_root_holds_only_the_public_api_and_the_cli():
    assert sorted(p.name for p in PACKAGE.glob("*.py")) == ["__init__.py", "api.py", "cli.py"]


def _sources():
    return sorted(PACKAGE.rglob("*.py"))


def test_no_module_over_600_lines():
    long = {str(p.relative_to(PACKAGE)): n for p in _sources() if (n := len(p.read_text().splitlines())) > MAX_MODULE_LINES}
    assert not long, long


def test_no_function_over_80_lines():
    long = {}
    for path in _sources():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > MAX_FUNCTION_LINES:
                    long[f"{path.relative_to(PACKAGE)}:{node.name}"] = n
    assert not long, long


def test_the_size_measure_counts_from_def_to_the_last_line():
    source = "def f():\n" + "    x = 1\n" * MAX_FUNCTION_LINES
    (node,) = ast.parse(source).body
    assert node.end_lineno - node.lineno + 1 == MAX_FUNCTION_LINES + 1
