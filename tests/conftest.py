"""Shared test set-up: the test process is set up as the ``coopsat`` command sets up its own
(XLA's CPU options, float64), with a private JAX compilation cache, so tests never touch the
user's. tests/meta/test_import_side_effects.py checks a bare import in a fresh interpreter."""

import os
import tempfile

import pytest

os.environ.setdefault("COOPSAT_JAX_CACHE", os.path.join(tempfile.gettempdir(), "coopsat-test-jax-cache"))

from coopsat.core import runtime  # noqa: E402
from coopsat.cli import configure_process  # noqa: E402

configure_process()
runtime.enable()  # tests call low-level JAX functions directly, before any build or run


def _run_toml(directory, text, overrides=()):
    """Write a scenario's TOML into ``directory``, build and run it: (built, dataset)."""
    from coopsat.workflows.pipeline import prepare, simulate_built
    from coopsat.scenarios.load import load_scenario

    path = directory / "scenario.toml"
    path.write_text(text, encoding="utf-8")
    built = prepare(load_scenario(path, overrides))
    ds, _ = simulate_built(built)
    return built, ds


@pytest.fixture(scope="session")
def run_toml():
    """``run_toml(directory, text, overrides=()) -> (built, dataset)``: a scenario from text."""
    return _run_toml
