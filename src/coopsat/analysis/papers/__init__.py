"""Paper analysis modules: each adds the metrics one source paper (or one plug-in) defines and
its explanations of differences from the published numbers.

A plug-in names its analysis module (:attr:`coopsat.plugins.Plugin.analysis`); a run imports
the modules of the plug-ins it uses. Every member of such a module is optional (:data:`MEMBERS`
gives each one's type and its default when absent):

* ``metrics(ds, built) -> dict`` — named numbers (unit at the end of each name); default none;
* ``batch_metrics(ds, builds) -> dict`` — the same numbers for every run of a batch at once:
  ``ds`` the batch's record (dimension ``run`` first), ``builds`` each run's build, each number
  an array over the runs (NaN for None). Campaigns and ``run_batch`` use it where it is
  defined (one call per batch instead of one per run); a module with only one of the two
  serves both (a batch run by run, or a run as a batch of one); default none;
* ``EXPLAINERS`` — ``{metric name or "_suffix": (quantity, metrics) -> str or None}``: why a
  published number differs; default none;
* ``series(ds, built) -> {name: DataArray}`` — time series derived from the record (truth
  errors…), added to the run's dataset before it is written; default none;
* ``FIGURES`` — the name of a module whose ``figures(ds, built) -> {stem: Figure}`` draws the
  paper's figures (plots sit above analysis); default none;
* ``PAIRED_SERIES`` — names of series ``coopsat pair`` compares over time; default none;
* ``SURROGATES`` — ``{metric name: coopsat.analysis.surrogates.Surrogate}`` for ``coopsat
  tune``; default none.

A module is checked when a scenario that uses it is built, before any simulation
(:func:`paper_modules`): one that cannot be imported, or whose member has the wrong type, is a
one-line :class:`~coopsat.plugins.PluginError` naming the module, the member and the plug-in.
After the simulation, each module's code runs under :func:`coopsat.analysis.stages.guarded`,
so that one that raises costs its own numbers, not the run's record.

So :mod:`coopsat.analysis.metrics` and :mod:`coopsat.analysis.compare` stay generic as papers
are added.
"""

import importlib
from collections.abc import Mapping

from coopsat.analysis.metrics import run_rows
from coopsat.analysis.stages import guarded
from coopsat.core.errors import one_line
from coopsat.plugins import PluginError


def _is_names(value):
    return isinstance(value, (tuple, list)) and all(isinstance(v, str) for v in value)


def _is_callable_map(value):
    return isinstance(value, Mapping) and all(isinstance(k, str) and callable(v) for k, v in value.items())


def _is_mapping(value):
    return isinstance(value, Mapping) and all(isinstance(k, str) for k in value)


MEMBERS = {
    "metrics": (callable, "a function (ds, built) -> dict of name -> float", None),
    "batch_metrics": (callable, "a function (ds, builds) -> dict of name -> array over the runs", None),
    "EXPLAINERS": (_is_callable_map, "a dict of metric name or '_suffix' -> function (quantity, metrics) -> str or None",
                   {}),
    "series": (callable, "a function (ds, built) -> dict of name -> xarray.DataArray", None),
    "FIGURES": (lambda v: isinstance(v, str), "the name of a module with figures(ds, built) -> dict of stem -> Figure",
                None),
    "PAIRED_SERIES": (_is_names, "a tuple of series names", ()),
    "SURROGATES": (_is_mapping, "a dict of metric name -> coopsat.analysis.surrogates.Surrogate", {}),
}
"""What an analysis module may define: name -> (test of its value, what it must be, its default
when absent). Every member is optional; an absent one contributes nothing."""

_checked = {}  # module name -> the imported module, once its members passed


def analysis_module(name, owner):
    """The analysis module ``name``, imported and checked against :data:`MEMBERS`.

    Parameters
    ----------
    name : str
        Importable module name.
    owner : str
        The plug-in that names it, for the message (``"controller 'consensus-sync' of coopsat
        (coopsat.plugins.consensus)"``).

    Raises
    ------
    PluginError
        One line: the module cannot be imported, or a member has the wrong type.
    """
    if name in _checked:
        return _checked[name]
    try:
        module = importlib.import_module(name)
    except Exception as err:  # noqa: BLE001 (a foreign module's import error, reported in one line)
        raise PluginError(f"analysis module '{name}' of plug-in {owner} failed to import: {one_line(err)}") from None
    for member, (test, what, _) in MEMBERS.items():
        if hasattr(module, member) and not test(getattr(module, member)):
            got = type(getattr(module, member)).__name__
            raise PluginError(f"analysis module '{name}' of plug-in {owner}: {member} must be {what}, not a {got}")
    _checked[name] = module
    return module


def owners(built):
    """``{analysis module name: "role 'kind' of origin"}`` for the run's plug-ins (each module
    once, in plug-in order; the first plug-in naming it is its owner)."""
    out = {}
    for p in built.plugins:
        if p.analysis and p.analysis not in out:
            out[p.analysis] = f"{p.role} '{p.kind}' of {p.origin}"
    return out


def paper_modules(built):
    """The checked analysis modules of a built run's plug-ins (each once, in plug-in order).

    Raises
    ------
    PluginError
        See :func:`analysis_module`.
    """
    return [analysis_module(name, owner) for name, owner in owners(built).items()]


def member(module, name):
    """A module's member, or its default when absent (:data:`MEMBERS`)."""
    return getattr(module, name, MEMBERS[name][2])


def source_of(module, built):
    """Who a module's failure is reported against: ``"analysis module 'm' of plug-in role 'kind' of origin"``."""
    return f"analysis module '{module.__name__}' of plug-in {owners(built)[module.__name__]}"


def paper_metrics(ds, built, failures=None):
    """Every paper module's metrics of a finished run; a module that raises is recorded in
    ``failures`` (a list of :class:`~coopsat.analysis.stages.StageFailure`; None: the error
    propagates) and adds none."""
    m = {}
    for module in paper_modules(built):
        if member(module, "metrics") is not None:
            m.update(guarded(failures, "metrics", source_of(module, built), {}, module.metrics, ds, built))
        elif member(module, "batch_metrics") is not None:
            m.update(guarded(failures, "metrics", source_of(module, built), {},
                             lambda mod=module: run_rows(mod.batch_metrics(ds.expand_dims("run"), [built]), 1)[0]))
    return m


def paper_batch_metrics(ds, builds, failures=None):
    """Every paper module's metrics of each run of a batch (one dict per run): a module's
    ``batch_metrics`` once for the batch, else its ``metrics`` run by run (on ``ds.isel(run=r)``).

    Parameters
    ----------
    ds : xarray.Dataset
        The batch's record, dimension ``run`` first.
    builds : sequence of Built
        Each run's build; they share one structure, hence one set of modules.
    failures : list, optional
        As :func:`paper_metrics` (a module failing in a batch adds nothing to any of its runs).
    """
    rows = [{} for _ in builds]
    for module in paper_modules(builds[0]):
        source = source_of(module, builds[0])
        if member(module, "batch_metrics") is not None:
            batch = guarded(failures, "metrics", source, None,
                            lambda mod=module: run_rows(mod.batch_metrics(ds, builds), len(builds)))
            for row, values in zip(rows, batch or ()):
                row.update(values)
        elif member(module, "metrics") is not None:
            for r, (row, built) in enumerate(zip(rows, builds)):
                row.update(guarded(failures, "metrics", source, {}, module.metrics, ds.isel(run=r), built))
    return rows


def explainers(built, failures=None):
    """The paper modules' explanations, merged; each wrapped so that one that raises is
    recorded in ``failures`` and explains nothing."""
    out = {}
    for module in paper_modules(built):
        source = source_of(module, built)
        for key, explain in member(module, "EXPLAINERS").items():
            out[key] = lambda quantity, metrics, explain=explain, source=source: guarded(
                failures, "comparison", source, None, explain, quantity, metrics)
    return out


def paper_series(ds, built, failures=None):
    """The run's dataset with every paper module's derived time series added; a module whose
    ``series`` raises (or returns something that is not series of the record) is recorded in
    ``failures`` and adds none."""
    for module in paper_modules(built):
        if member(module, "series") is not None:
            ds = guarded(failures, "series", source_of(module, built), ds, lambda m=module: ds.assign(m.series(ds, built)))
    return ds
