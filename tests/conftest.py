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


def _native_off_outside_its_range():
    """Outside the native kernels' jax range (a jax newer than TESTED_JAX: Python 3.12 and later
    install 0.12) every run takes the XLA path anyway, and says so in a notice line on the stderr
    of each command the tests start; COOPSAT_NATIVE=0 takes the same path without the line, so the
    tests of a command's one-line errors hold there too. CI's environments are inside the range."""
    from coopsat.sim.native.capability import ENV, version_problem

    if version_problem() is not None:
        os.environ.setdefault(ENV, "0")


_native_off_outside_its_range()


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


# --- peak memory per worker (issue 26: a suite that fits beside a user's other programs) ----

PEAK_RSS_LIMIT_MB = 2560
"""Peak resident memory allowed to one test process (README: ≤ 2.5 GB per worker)."""


def _peak_rss_mb():
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: kB


def pytest_sessionfinish(session):
    if hasattr(session.config, "workeroutput"):  # a pytest-xdist worker reports to the controller
        session.config.workeroutput["peak_rss_mb"] = _peak_rss_mb()


@pytest.hookimpl(optionalhook=True)  # pytest-xdist's hook: absent with -p no:xdist
def pytest_testnodedown(node, error):
    node.config._coopsat_peaks = getattr(node.config, "_coopsat_peaks", {})
    node.config._coopsat_peaks[node.gateway.id] = node.workeroutput.get("peak_rss_mb", float("nan"))


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    peaks = getattr(config, "_coopsat_peaks", None) or {"main": _peak_rss_mb()}
    text = ", ".join(f"{worker} {mb:.0f} MB" for worker, mb in sorted(peaks.items()))
    over = [worker for worker, mb in peaks.items() if mb > PEAK_RSS_LIMIT_MB]
    terminalreporter.write_line(f"peak resident memory per test process: {text}"
                                + (f"  (over {PEAK_RSS_LIMIT_MB} MB: {', '.join(over)})" if over else ""))


@pytest.fixture(autouse=True, scope="module")
def _release_compiled_programs():
    """After each test module, drop the compiled programs and JAX's caches and give the freed
    memory back to the system: a worker otherwise keeps every structure it ever compiled (a
    large one is 100–300 MB of generated code) and glibc keeps what was freed. The next module
    traces its own structures again and loads them from the persistent compilation cache."""
    yield
    release_compiled_programs()


@pytest.fixture
def release_after():
    """The same release after one test: for a test parametrized over many structures (every
    bundled scenario), which would otherwise hold them all until its module ends."""
    yield
    release_compiled_programs()


def release_compiled_programs():
    """Drop the engine's compiled programs and JAX's caches; trim the C heap."""
    import ctypes
    import gc

    import jax

    from coopsat.sim import engine

    engine._COMPILED.clear()
    jax.clear_caches()
    gc.collect()
    try:
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):  # not glibc: nothing to trim
        pass
