"""coopsat: cooperative control of spacecraft formations.

The public names (docs/api.md) are loaded on first use, so ``import coopsat`` is cheap and
changes nothing in the process (no environment variable, no JAX setting)::

    import coopsat

    s = coopsat.Scenario.load("consensus-sync-a-stable").set("sim.t_final_s", 20.0)
    result = coopsat.run(s)
    result.metrics["final_attitude_spread_deg"]

Subpackages with public functions: :mod:`coopsat.design` (LQR, delay margins and
certificates, LMIs, sampled-data checks), :mod:`coopsat.network` (topology metrics), and
:mod:`coopsat.plugins` (the plug-in protocols and registry). Everything else is internal.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

__version__ = "0.1.0"

_PUBLIC = {
    "Scenario": "coopsat.scenarios.document",
    "ScenarioError": "coopsat.scenarios.load",
    "Result": "coopsat.workflows.pipeline",
    "Validation": "coopsat.api",
    "Batch": "coopsat.api",
    "CampaignRun": "coopsat.api",
    "configure": "coopsat.api",
    "validate": "coopsat.api",
    "run": "coopsat.api",
    "sil": "coopsat.api",
    "plot": "coopsat.api",
    "load_run": "coopsat.api",
    "report": "coopsat.api",
    "run_batch": "coopsat.api",
    "sweep": "coopsat.api",
    "pair": "coopsat.api",
    "tune": "coopsat.api",
    "campaign": "coopsat.api",
    "export": "coopsat.api",
    "ExportError": "coopsat.exports.run",
    "CoopsatError": "coopsat.core.errors",
    "InputError": "coopsat.core.errors",
    "SimulationError": "coopsat.core.errors",
    "ExternalProcessError": "coopsat.core.errors",
    "PlatformError": "coopsat.core.errors",
    "StageError": "coopsat.analysis.stages",
    "StageFailure": "coopsat.analysis.stages",
}
_SUBPACKAGES = ("design", "network", "plugins")

__all__ = sorted([*_PUBLIC, *_SUBPACKAGES, "__version__"])

if TYPE_CHECKING:  # for type checkers and IDEs; at run time the names load lazily (__getattr__)
    from coopsat import design, network, plugins
    from coopsat.api import (
        Batch,
        CampaignRun,
        Validation,
        campaign,
        configure,
        export,
        load_run,
        pair,
        plot,
        report,
        run,
        run_batch,
        sil,
        sweep,
        tune,
        validate,
    )
    from coopsat.analysis.stages import StageError, StageFailure
    from coopsat.core.errors import CoopsatError, ExternalProcessError, InputError, PlatformError, SimulationError
    from coopsat.exports.run import ExportError
    from coopsat.workflows.pipeline import Result
    from coopsat.scenarios.document import Scenario
    from coopsat.scenarios.load import ScenarioError


def __getattr__(name: str):
    if name in _PUBLIC:
        value = getattr(importlib.import_module(_PUBLIC[name]), name)
    elif name in _SUBPACKAGES:
        value = importlib.import_module(f"coopsat.{name}")
    else:
        raise AttributeError(f"module 'coopsat' has no attribute {name!r}")
    globals()[name] = value  # the next lookup is a plain attribute
    return value


def __dir__():
    return __all__
