"""The optional members of a part (coopsat.plugins.protocols.OPTIONAL): one default each, read
through ``protocols.optional``, their types checked by ``protocol_problems``, and listed with
their defaults in docs/plugins.md §4."""

import ast
import re
from pathlib import Path

import jax.numpy as jnp
import pytest

from coopsat.plugins import part, protocol_problems, protocols

ROOT = Path(__file__).resolve().parents[2]
OPTIONAL = protocols.OPTIONAL


@part()
class Net:
    """A network part with every protocol member; optional ones are added per test."""

    weight: jnp.ndarray

    def init(self, outbox0):
        return ()

    def deliver(self, tick, outbox, state, key):
        raise NotImplementedError

    def output_specs(self):
        return {}


def _with(**members):
    return part()(type("Net", (Net,), {**members, "__annotations__": {}}))(jnp.zeros(1))


def test_a_part_without_an_optional_member_reads_as_its_default():
    assert {name: protocols.optional(_with(), name) for name in OPTIONAL} == {
        name: spec.default for name, spec in OPTIONAL.items()}
    assert protocols.optional(_with(hold=True), "hold") is True


def test_a_well_typed_optional_member_is_no_problem():
    assert protocol_problems(_with(lossy=True, hold=False), "network") == []


@pytest.mark.parametrize("value", ["yes", 1, jnp.asarray(True), None])
def test_an_optional_member_of_another_type_is_a_problem(value):
    assert protocol_problems(_with(lossy=True, hold=value), "network") == [
        f"Net.hold is {value!r}, not a bool (optional member of a network part)"]


def test_only_the_optional_members_of_the_parts_role_are_checked():
    # reads_own is a controller's: a network part may carry anything of that name.
    assert protocol_problems(_with(reads_own="whatever"), "network") == []


def test_every_reader_of_an_optional_member_outside_the_table_uses_its_default():
    """``getattr(part, "hold", False)`` where the table cannot be imported (coopsat.sim lies below
    coopsat.plugins in the layers; a module another change owns): the default must be the table's."""
    readers = {}
    for path in sorted((ROOT / "src" / "coopsat").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "getattr"
                    and len(node.args) == 3 and isinstance(node.args[1], ast.Constant)
                    and node.args[1].value in OPTIONAL):
                name = node.args[1].value
                default = ast.literal_eval(node.args[2])
                readers[f"{path.relative_to(ROOT)}:{node.lineno} {name}"] = default == OPTIONAL[name].default
    assert all(readers.values()), readers


def test_the_plugins_page_lists_every_optional_member_with_its_default():
    text = (ROOT / "docs" / "plugins.md").read_text(encoding="utf-8")
    rows = re.findall(r"^\| `(\w+)` \| (\w+) \| [^|]+ \| `([^`]+)` \|", text, re.M)
    assert {name: (role, default) for name, role, default in rows} == {
        name: (spec.roles[0], repr(spec.default)) for name, spec in OPTIONAL.items()}
