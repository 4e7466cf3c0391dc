"""Paper analysis modules: each adds the metrics one source paper defines and its explanations
of differences from the published numbers.

A plug-in names its paper's module (:attr:`coopsat.plugins.Plugin.analysis`); a run imports the
modules of the plug-ins it uses. A module provides

* ``metrics(ds, built) -> dict`` — named numbers (unit at the end of each name);
* ``EXPLAINERS`` — ``{metric name or "_suffix": (quantity, metrics) -> str or None}``;
* optionally ``series(ds, built) -> {name: DataArray}`` — time series derived from the record
  (truth errors…), added to the run's dataset before it is written;
* optionally ``FIGURES`` — the name of a :mod:`coopsat.plots` module whose ``figures(ds,
  built) -> {stem: Figure}`` draws the paper's figures (plots sit above analysis).

So :mod:`coopsat.analysis.metrics` and :mod:`coopsat.analysis.compare` stay generic as papers
are added.
"""

import importlib


def paper_modules(built):
    """The analysis modules of a built run's plug-ins (each once, in plug-in order)."""
    names = dict.fromkeys(p.analysis for p in built.plugins if p.analysis)
    return [importlib.import_module(name) for name in names]


def paper_metrics(ds, built):
    """Every paper module's metrics of a finished run."""
    m = {}
    for module in paper_modules(built):
        m.update(module.metrics(ds, built))
    return m


def explainers(built):
    """The paper modules' explanations, merged."""
    out = {}
    for module in paper_modules(built):
        out.update(module.EXPLAINERS)
    return out


def paper_series(ds, built):
    """The run's dataset with every paper module's derived time series added."""
    for module in paper_modules(built):
        if hasattr(module, "series"):
            ds = ds.assign(module.series(ds, built))
    return ds
