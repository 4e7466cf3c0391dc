"""One error family: every exception class coopsat defines derives from ``CoopsatError`` (or is a
warning category under ``CoopsatWarning``, or the signal stop ``Interrupted``), and the command's
error path loads no JAX."""

import importlib
import inspect
import pkgutil
import subprocess
import sys

import pytest

import coopsat
from coopsat.core.errors import CoopsatError, CoopsatWarning, InputError, StageFailedError
from coopsat.workflows.interrupt import Interrupted


def _modules():
    """Every module of the installed coopsat package, imported."""
    names = [m.name for m in pkgutil.walk_packages(coopsat.__path__, "coopsat.")]
    return [importlib.import_module(name) for name in names if not name.endswith("__main__")]


def _exception_classes():
    found = []
    for module in _modules():
        for _, cls in inspect.getmembers(module, inspect.isclass):
            if cls.__module__ == module.__name__ and issubclass(cls, BaseException):
                found.append(cls)
    return found


def test_every_exception_class_is_in_the_family():
    classes = _exception_classes()
    names = {c.__name__ for c in classes}
    assert {"ScenarioError", "GraphError", "SILError", "NonFiniteStateError", "StageError", "PluginError"} <= names
    outside = [
        f"{c.__module__}.{c.__name__}" for c in classes
        if not issubclass(c, CoopsatError) and not issubclass(c, CoopsatWarning) and c is not Interrupted
    ]
    assert outside == []
    warnings = [c for c in classes if issubclass(c, Warning)]
    assert warnings and all(issubclass(c, CoopsatWarning) for c in warnings)


def test_the_causes_keep_their_standard_bases_and_statuses():
    from coopsat.analysis.stages import StageError
    from coopsat.plugins import DesignError, PluginError
    from coopsat.scenarios.load import ScenarioError
    from coopsat.sim.engine import NonFiniteStateError
    from coopsat.workflows.sil.schema import SILError, SILSetupError

    assert issubclass(ScenarioError, ValueError) and issubclass(DesignError, InputError)
    assert issubclass(NonFiniteStateError, RuntimeError) and issubclass(PluginError, CoopsatError)
    assert issubclass(SILSetupError, InputError) and not issubclass(SILError, InputError)
    assert StageError.exit_status == StageFailedError.exit_status == 3 and ScenarioError.exit_status == 2


@pytest.mark.parametrize("argv, status", [
    (["show", "no-such-scenario"], 2),
    (["show", "no/such/scenario.toml"], 2),
])
def test_the_command_error_path_loads_no_jax(argv, status, tmp_path):
    """A command that fails before any computation loads no JAX on its way out (catching the
    family's base needs nothing imported)."""
    code = (
        "import sys\n"
        "from coopsat.cli import main\n"
        f"status = main({argv!r})\n"
        "print(status, 'jax' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert out.stdout.split() == [str(status), "False"], out.stderr
    assert out.stderr.startswith("coopsat: error: ") and out.stderr.count("\n") == 1
