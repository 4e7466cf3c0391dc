"""No module of the package outside coopsat.sim uses an underscore name of coopsat.sim: the
engine's stages are public (coopsat.sim.stepping), and whatever else is private may change
without a caller outside the engine noticing. Import-linter sees modules, not names (its
contract in pyproject.toml keeps outsiders off the stage modules); this reads every module's
syntax tree. The tests themselves may reach inside (they test the internals)."""

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[2] / "src" / "coopsat"
ENGINE = "coopsat.sim"
NAMEDTUPLE = {"_replace", "_fields", "_asdict", "_make", "_field_defaults"}
"""A named tuple's public members, underscored so as not to clash with its fields."""


def _private(name):
    return name.startswith("_") and not name.startswith("__") and name not in NAMEDTUPLE


def _in_engine(module):
    return module == ENGINE or module.startswith(ENGINE + ".")


def _module_name(path):
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _absolute(node, here, is_package):
    """The module an ``ImportFrom`` names, relative imports resolved from module ``here``."""
    if node.level == 0:
        return node.module or ""
    parts = here.split(".")
    base = parts[: len(parts) - node.level + is_package]
    return ".".join([*base, *([node.module] if node.module else [])])


def _dotted(node):
    """``a.b.c`` of an attribute chain on a name, else None."""
    names = []
    while isinstance(node, ast.Attribute):
        names.append(node.attr)
        node = node.value
    return ".".join([node.id, *reversed(names)]) if isinstance(node, ast.Name) else None


def private_uses(source, here="coopsat.outside", is_package=False):
    """``(line, what)`` for every underscore name of coopsat.sim that ``source`` imports or reads:
    ``from coopsat.sim.x import _y``, ``coopsat.sim.x._y``, and ``m._y`` where ``m`` was imported
    from coopsat.sim."""
    tree = ast.parse(source)
    bound, found = set(), []  # local names bound to coopsat.sim's modules and objects
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and _in_engine(module := _absolute(node, here, is_package)):
            for alias in node.names:
                if _private(alias.name):
                    found.append((node.lineno, f"from {module} import {alias.name}"))
                bound.add(alias.asname or alias.name)
        elif isinstance(node, ast.Import):  # without "as", the dotted name is read below
            bound.update(alias.asname for alias in node.names if alias.asname and _in_engine(alias.name))
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and _private(node.attr) and (dotted := _dotted(node)):
            head = dotted.rsplit(".", 1)[0]
            if _in_engine(head) or head in bound:
                found.append((node.lineno, dotted))
    return sorted(found)


def test_no_module_outside_the_engine_uses_its_private_names():
    uses = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        here = _module_name(path)
        if _in_engine(here):
            continue
        found = private_uses(path.read_text(), here, path.name == "__init__.py")
        if found:
            uses[str(path.relative_to(PACKAGE))] = found
    assert not uses, uses


def test_the_check_finds_each_form_of_private_use():
    source = (
        "from coopsat.sim.period import _sense, sense\n"
        "from coopsat.sim import engine\n"
        "import coopsat.sim.layout\n"
        "import coopsat.sim.tick as tick\n"
        "from ...sim.programs import _means\n"
        "engine._check_finite(1)\n"
        "coopsat.sim.layout._engine_view(2)\n"
        "tick._quantities(3)\n"
        "engine.run_output(3)\n"
        "state._replace(x=4)\n"
    )
    assert [what for _, what in private_uses(source, "coopsat.workflows.sil.loop")] == [
        "from coopsat.sim.period import _sense",
        "from coopsat.sim.programs import _means",
        "engine._check_finite",
        "coopsat.sim.layout._engine_view",
        "tick._quantities",
    ]
