"""docs/scenarios.md documents every scenario field and every bundled scenario."""

import re
from pathlib import Path

import pydantic
import pytest

from coopsat.plugins import ROLES, plugins
from coopsat.scenarios import schema
from coopsat.scenarios.load import bundled_names, load_scenario

DOC = Path(__file__).resolve().parents[2] / "docs" / "scenarios.md"

CORE_MODELS = [
    schema.Sim,
    schema.Elements,
    schema.Relative,
    schema.Tle,
    schema.OemState,
    schema.Roe,
    schema.SpacecraftDefaults,
    schema.Spacecraft,
    schema.Orbit,
    schema.Graph,
    schema.GraphSwitch,
    schema.Network,
    schema.Sil,
    schema.Analysis,
    schema.Published,
    schema.Scenario,
]
OWN = [p for role in ROLES for p in plugins(role).values() if p.origin.distribution == "coopsat"]
"""coopsat's own kinds (a plug-in package installed beside it documents its own)."""
PLUGIN_TABLES = [p.table for p in OWN] + list({p.thresholds for p in OWN if p.thresholds is not None})

FIELDS = sorted({(model.__name__, field) for model in CORE_MODELS + PLUGIN_TABLES for field in model.model_fields})


@pytest.fixture(scope="module")
def doc():
    return DOC.read_text(encoding="utf-8")


def test_every_schema_model_is_checked():
    public = {
        name
        for name, obj in vars(schema).items()
        if isinstance(obj, type)
        and issubclass(obj, pydantic.BaseModel)
        and obj.__module__ == schema.__name__
        and not name.startswith("_")
    }
    assert public == {m.__name__ for m in CORE_MODELS}, "a schema model was added or removed: update CORE_MODELS"


@pytest.mark.parametrize("kind", sorted({p.kind for p in OWN}))
def test_every_plugin_kind_is_documented(doc, kind):
    assert f'kind = "{kind}"' in doc, f"plug-in kind {kind} is not documented in docs/scenarios.md"


@pytest.mark.parametrize(("model", "field"), FIELDS, ids=[f"{m}.{f}" for m, f in FIELDS])
def test_field_is_documented(doc, model, field):
    assert f"`{field}`" in doc, f"{model}.{field} is not documented in docs/scenarios.md"


@pytest.mark.parametrize("name", bundled_names())
def test_bundled_scenario_is_listed(doc, name):
    assert f"`{name}`" in doc, f"bundled scenario {name} is not listed in docs/scenarios.md"


def test_examples_are_valid_scenarios(doc, tmp_path):
    blocks = re.findall(r"```toml\n(.*?)```", doc, flags=re.S)
    examples = [b for b in blocks if "[sim]" in b or b.lstrip().startswith("extends")]
    assert len(examples) >= 2
    for k, text in enumerate(examples):
        path = tmp_path / f"example{k}.toml"
        path.write_text(text, encoding="utf-8")
        load_scenario(path)
