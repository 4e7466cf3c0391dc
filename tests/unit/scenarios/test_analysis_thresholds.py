"""Papers own their thresholds: ``[analysis]`` is the core's fields plus every installed
plug-in's ``thresholds`` table (issue 24)."""

import pytest
from pydantic import Field

from coopsat.plugins import ROLES, Plugin, PluginError, plugins
from coopsat.plugins.tables import FormationTolerance, Table
from coopsat.scenarios import schema


def _owners(field):
    return {p.kind for role in ROLES for p in plugins(role).values() if p.thresholds and field in p.thresholds.model_fields}


def test_paper_fields_live_with_their_papers():
    core = set(schema._CoreAnalysis.model_fields)
    assert core == {"sync_attitude_deg", "sync_rate_rad_s", "settle_hold_s"}
    assert _owners("spin_rate_rad_s") == {"consensus-sync", "consensus-track"}
    assert _owners("formation_tolerance_m") == {"formation-observer", "cartwheel-keeping"}
    assert _owners("pointing_converged_deg") == {"observation"}
    assert set(schema.Analysis.model_fields) == core | {"spin_rate_rad_s", "formation_tolerance_m", "pointing_converged_deg"}


def test_a_shared_table_composes_once_and_a_clash_is_one_line(monkeypatch):
    class Clash(Table):
        formation_tolerance_m: float = Field(2.0, gt=0)

    fake = Plugin("controller", "clash-law", Table, lambda table, ctx: None, thresholds=Clash)
    real = plugins("controller")
    assert sum(p.thresholds is FormationTolerance for p in real.values()) == 2  # shared, composed once
    monkeypatch.setattr("coopsat.scenarios.schema.plugins", lambda role: {**real, "clash-law": fake} if role == "controller" else plugins(role))
    with pytest.raises(PluginError, match=r"^\[analysis\] field 'formation_tolerance_m' is defined by .* and by .*Clash"):
        schema._analysis_table()
