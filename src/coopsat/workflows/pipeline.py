"""One scenario, end to end: load → build → simulate → dataset → metrics → comparison → files.

The run folder is written to a temporary sibling folder and renamed into place at the end,
so a failed run (bad input, non-finite state) leaves nothing half-written.
"""

import importlib
import json
import warnings
from dataclasses import dataclass, field, replace
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

import coopsat
from coopsat.core.errors import InputError
from coopsat.workflows import interrupt
from coopsat.analysis.compare import comparison_markdown
from coopsat.analysis.papers import member, paper_modules, paper_series, source_of
from coopsat.analysis.stages import StageError, guarded
from coopsat.workflows.analyse import analyse
from coopsat.workflows.folders import atomic_folder, check_folder, json_ready, read_result, write_netcdf
from coopsat.scenarios.build import DesignWarning, build
from coopsat.scenarios.run_length import check_run_length
from coopsat.scenarios.load import ScenarioError, resolved_toml


@dataclass(frozen=True)
class Result:
    """One finished run, in memory (:func:`run`); :meth:`save` writes the run folder.

    Attributes
    ----------
    scenario : coopsat.Scenario
        What ran (the scenario as given, its seed included).
    dataset : xarray.Dataset
        The record: what ``result.nc`` holds (docs/scenarios.md lists the variables; SI units,
        quaternions scalar first), with the resolved scenario, the seed and every design-time
        check in its attributes.
    metrics : dict of str -> float or None
        ``metrics.json``: named numbers, unit at the end of each name; None for a time never
        reached.
    comparison : list of dict
        ``comparison.json``: per ``[[published]]`` number, ours, the verdict and its reason
        (empty when the scenario quotes none).
    checks : dict of str -> coopsat.plugins.DesignCheck
        The design-time checks by name, each with ``ok``, its one-line ``note``, its
        ``metrics`` and ``detail`` (the certificate: spectral radius, margins, LMI results…).
    warnings : list of str
        The checks that failed, one line each (the CLI prints them before the run).
    compile_s, run_s : float
        Wall time compiling and running the closed loop, s.
    """

    scenario: object
    dataset: object
    metrics: dict
    comparison: list
    checks: dict
    warnings: list
    compile_s: float
    run_s: float
    built: object = field(default=None, repr=False, compare=False)
    """The built run (:class:`coopsat.scenarios.build.Built`): the compiled system's parts, for
    figures and further analysis."""
    failures: tuple = ()
    """The stages after the simulation that raised (:class:`~coopsat.analysis.stages.StageFailure`),
    their numbers missing from ``metrics``/``comparison`` (:func:`run` raises
    :class:`~coopsat.analysis.stages.StageError` with this result)."""

    @classmethod
    def from_built(cls, scenario, built, dataset, metrics, comparison=(), *, compile_s=0.0, run_s=0.0, failures=()):
        """The one way a result is made: the checks and warnings come from ``built`` (a
        :class:`~coopsat.scenarios.build.Built`), the rest as named."""
        return cls(scenario, dataset, metrics, list(comparison), built.named_checks, list(built.warnings), compile_s,
                   run_s, built, tuple(failures))

    def save(self, out_dir, *, figures=False, report=True):
        """Write the run folder ``coopsat run`` writes (result.nc, metrics.json,
        comparison.{md,json}, report.html, run.json; the PNG figures when ``figures``),
        atomically; returns its path.

        An existing folder is replaced only if it is a run folder (it holds ``run.json``).

        Raises
        ------
        RunFolderError
        StageError
            The figures or the report raised: the folder is written without them, and the error
            names the stage and the plug-in (``.out_dir``, ``.failures``).
        """
        return save_run(replace(self, failures=()), out_dir, figures=figures, report=report)

    def report_html(self):
        """The interactive report page (``report.html``) of this run, as text."""
        from coopsat.reports import report_html

        return report_html(self.built, self.dataset, self.metrics, self.comparison)

    def figures(self):
        """The run's figures (matplotlib), keyed by the file stem ``save`` gives them."""
        return run_figures(self.built, self.dataset)


@dataclass
class RunResult:
    """What :func:`run_scenario` produced.

    Attributes
    ----------
    out_dir : Path
        The run folder.
    dataset : xarray.Dataset
    metrics : dict
    comparison : list of dict
    warnings : list of str
    compile_s, run_s : float
        Wall time compiling and running the closed loop, s.
    """

    out_dir: Path
    dataset: object
    metrics: dict
    comparison: list
    warnings: list
    compile_s: float
    run_s: float


def prepare(scenario, check_published=True):
    """Build a validated scenario; its design-time warnings are in ``built.warnings``. Its
    plug-ins' analysis modules are imported and checked (:func:`coopsat.analysis.papers.paper_modules`).

    Also checks, before anything runs, that every ``[[published]]`` quantity names a metric
    this run will produce, unless ``check_published`` is False (a campaign's runs, which never
    compare with published values: the check traces the engine, 15 ms a run of
    ``consensus-sync-a-stable``, half the run itself in a batch).
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DesignWarning)  # returned in built.warnings instead
        built = build(scenario)
    paper_modules(built)  # a malformed analysis module is an error now, not after the simulation
    if check_published and scenario.published:
        known = metric_names(built)
        for k, entry in enumerate(scenario.published):
            if entry.quantity not in known:
                raise ScenarioError(
                    f"published[{k}].quantity: '{entry.quantity}' is not a metric of this scenario "
                    f"(metrics: {', '.join(sorted(known))})"
                )
    return built


def metric_names(built):
    """Names of the metrics a run of ``built`` will report (from a stand-in two-sample record).

    Kept in the persistent cache by the resolved scenario (:func:`coopsat.design.memo.kept`):
    the stand-in record is an xarray Dataset, and xarray with pandas is a second of imports
    that ``coopsat validate`` would otherwise pay for nothing else.
    """
    from coopsat.design.memo import kept

    parts = _plugin_distributions()
    if parts is None:
        return _metric_names(built)
    return set(kept("metric_names", (resolved_toml(built.scenario), parts), lambda: sorted(_metric_names(built))))


def _plugin_distributions():
    """(name, version) of every distribution with a registered plug-in (part of the key of
    :func:`metric_names`), or None when a plug-in was registered by a module outside any
    distribution: a script's parts cannot be keyed, so their names are worked out each time."""
    from importlib.metadata import version

    from coopsat.plugins import ROLES, plugins

    dists = {p.origin.distribution for role in ROLES for p in plugins(role).values()}
    return None if None in dists else sorted((d, version(d)) for d in dists)


def _metric_names(built):
    """:func:`metric_names` worked out: the metrics of a two-sample record of zeros."""
    from coopsat.sim.engine import RunOutput, output_shapes, output_specs
    from coopsat.sim.recorder import to_dataset

    specs = output_specs(built.system)
    samples = {k: np.zeros((2, *shape)) for k, shape in output_shapes(built.system).items()}
    for k, spec in specs.items():
        if spec.dims == ("q_component",):
            samples[k][..., 0] = 1.0  # unit quaternions, so that attitude metrics are defined
    ignored = []  # a plug-in that fails on the stand-in's zeros is reported by the real run, not here
    ds = paper_series(to_dataset(RunOutput(np.array([0.0, 1.0]), samples, 0.0, 0.0), built.names, {}, specs), built, ignored)
    with np.errstate(all="ignore"):  # only the names count: the stand-in's zeros may divide 0 by 0
        metrics, _ = analyse(built, ds, compare=False, failures=ignored)
    return set(metrics)


def simulate_built(built, progress=False, native=None, failures=None):
    """Run a built scenario; returns (dataset, RunOutput). ``native``: as
    :func:`coopsat.sim.engine.simulate`; ``failures``: as :func:`record_dataset`."""
    from coopsat.sim.engine import simulate

    out = simulate(built.system, built.n_records, built.record_interval_s, progress=progress, names=built.names,
                   cancel=interrupt.check, native=native)
    return record_dataset(built, out, failures=failures), out


def record_dataset(built, out, failures=None, **attrs):
    """The run's record as a Dataset, from the engine's samples (a RunOutput): what ran, when,
    the design checks and the paper's series; ``attrs``: more global attributes (str, int or
    float), after the standard ones. A paper module whose series raise is appended to
    ``failures`` (a list of :class:`~coopsat.analysis.stages.StageFailure`; None: it raises)."""
    from coopsat.plugins.earth_environment import time_attributes
    from coopsat.sim.engine import output_specs
    from coopsat.sim.recorder import to_dataset

    scenario = built.scenario
    attrs = {
        "scenario_name": scenario.name,
        "scenario_toml": resolved_toml(scenario),
        "seed": scenario.seed,
        "coopsat_version": coopsat.__version__,
        "created_utc": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "compile_time_s": out.compile_s,
        "run_time_s": out.run_s,
        "conventions": "SI units; quaternions scalar-first, Hamilton, body to inertial",
        **time_attributes(scenario, built.system),
        **attrs,
    }
    for check in built.checks.values():
        attrs[f"check_{check.name}"] = check.note
    return paper_series(to_dataset(out, built.names, attrs, output_specs(built.system)), built, failures)


RUN_MARKER = "run.json"
"""Written into every run folder (what ran, when, with which coopsat): only a folder holding
it is ever replaced by a new run."""


class RunFolderError(InputError):
    """The run folder cannot be written where the user asked."""


def check_run_folder(out_dir):
    """Refuse, before anything runs, a target that is not a run folder or cannot be created.

    Raises
    ------
    RunFolderError
    """
    check_folder(out_dir, RUN_MARKER, "coopsat run", RunFolderError)


def write_run_folder(out_dir, built, ds, metrics, rows, figures=False, report=True, failures=None):
    """Write result.nc, metrics.json, comparison.{md,json}, report.html, run.json and, when
    ``figures``, the PNG figures, atomically.

    Parameters
    ----------
    out_dir : Path
        Final folder; an existing run folder is replaced only once the new one is complete,
        anything else that exists there is refused (:func:`check_run_folder`).
    failures : list, optional
        The figures or report stage that raises is appended here
        (:class:`~coopsat.analysis.stages.StageFailure`) and the folder is written without it;
        None: it raises and nothing is written.
    """
    out_dir = Path(out_dir)
    check_run_folder(out_dir)
    with atomic_folder(out_dir, RunFolderError) as tmp:
        (tmp / RUN_MARKER).write_text(
            json.dumps(
                {
                    "scenario": built.scenario.name,
                    "seed": built.scenario.seed,
                    "coopsat_version": coopsat.__version__,
                    "created_utc": ds.attrs.get("created_utc", ""),
                },
                indent=2,
            )
            + "\n"
        )
        write_netcdf(ds, tmp / "result.nc")
        (tmp / "metrics.json").write_text(json.dumps(json_ready(metrics), indent=2, allow_nan=False) + "\n")
        if built.scenario.published:
            (tmp / "comparison.json").write_text(json.dumps(json_ready(rows), indent=2, allow_nan=False) + "\n")
            (tmp / "comparison.md").write_text(comparison_markdown(rows, built.scenario.name))
        if figures:
            interrupt.check()  # the figures take seconds: a stop need not wait for them (nothing is written)
            _save_figures(built, ds, tmp, failures)
        if report:
            from coopsat.reports import report_html

            interrupt.check()
            page = guarded(failures, "report", "coopsat", None, report_html, built, ds, metrics, rows)
            if page is not None:
                (tmp / REPORT_FILE).write_text(page, encoding="utf-8")
    return out_dir


def _save_figures(built, ds, folder, failures):
    """Draw and save the run's figures into ``folder``: the standard ones, then each paper
    module's, each set guarded on its own (:func:`~coopsat.analysis.stages.guarded`)."""
    from coopsat.plots.figures import save_figures, standard_figures

    sets = [("coopsat", lambda: standard_figures(ds, built.scenario.analysis))]
    sets += [(source, lambda m=module: _module_figures(m, built, ds)) for source, module in _figure_modules(built)]
    for source, draw in sets:
        guarded(failures, "figures", source, None, lambda: save_figures(draw(), folder))


REPORT_FILE = "report.html"


def read_record(run_dir, error):
    """A run folder's record and the scenario it ran: (``result.nc`` as a Dataset, the
    :class:`~coopsat.scenarios.document.Scenario` of its resolved TOML); ``error`` (an exception
    class) names a folder without a readable record in one line."""
    from coopsat.scenarios.document import Scenario as Document

    ds = read_result(run_dir, error)
    try:
        return ds, Document.from_toml(ds.attrs["scenario_toml"])
    except (ValueError, KeyError) as err:
        raise error(f"{run_dir}: no scenario to read in result.nc (its scenario_toml): {err}") from None


def load_run(run_dir):
    """A run folder read back as a :class:`Result` (``coopsat report``, ``plot``, ``export``).

    The record, metrics and comparison are read from the folder; the scenario is rebuilt from
    the resolved TOML kept in ``result.nc`` (design results come from the disk memo when the
    process has a persistent cache), so the design-time checks are this installation's.

    Raises
    ------
    RunFolderError
        Not a run folder, or one whose files cannot be read.
    """
    run_dir = Path(run_dir)
    if not (run_dir / RUN_MARKER).is_file():
        raise RunFolderError(f"{run_dir}: not a run folder (coopsat run writes {RUN_MARKER} and result.nc)")
    ds, doc = read_record(run_dir, RunFolderError)
    try:
        metrics = json.loads((run_dir / "metrics.json").read_text())
        comparison_file = run_dir / "comparison.json"
        rows = json.loads(comparison_file.read_text()) if comparison_file.is_file() else []
    except (OSError, ValueError) as err:
        raise RunFolderError(f"{run_dir}: cannot read the run folder ({err})") from None
    built = prepare(doc.model, check_published=False)
    return Result.from_built(doc, built, ds, metrics, rows, compile_s=float(ds.attrs.get("compile_time_s", 0.0)),
                             run_s=float(ds.attrs.get("run_time_s", 0.0)))


def run_figures(built, ds):
    """Every figure of a run, keyed by file stem: the standard ones and its papers'."""
    from coopsat.plots.figures import standard_figures

    return {**standard_figures(ds, built.scenario.analysis), **_paper_figures(built, ds)}


def _figure_modules(built):
    """``(source, analysis module)`` of each paper module of the run that names ``FIGURES``."""
    return [(source_of(m, built), m) for m in paper_modules(built) if member(m, "FIGURES") is not None]


def _module_figures(module, built, ds):
    """One paper module's figures, keyed by file stem."""
    return importlib.import_module(module.FIGURES).figures(ds, built)


def _paper_figures(built, ds):
    """The figures of the run's papers, keyed by file stem."""
    figures = {}
    for _, module in _figure_modules(built):
        figures.update(_module_figures(module, built, ds))
    return figures


class PlotError(InputError):
    """A figure a run folder does not have, or a folder without a run's record (one line)."""


def plot_run(run_dir, what=None, out=None):
    """Draw a run folder's figures again from its ``result.nc``: :func:`coopsat.plot` (``coopsat
    plot``), whose docstring is the reference for the arguments, the files returned and the
    :class:`PlotError` raised.
    """
    from coopsat.plots.figures import figure_makers, save_figures

    run_dir = Path(run_dir)
    ds, doc = read_record(run_dir, PlotError)
    scenario = doc.model
    makers = figure_makers(ds, scenario.analysis)
    wanted = list(dict.fromkeys(what or ()))
    papers = {}
    if not wanted or any(stem not in makers for stem in wanted):  # the build takes seconds: only when needed
        papers = _paper_figures(prepare(scenario, check_published=False), ds)
    known = [*makers, *(stem for stem in papers if stem not in makers)]
    unknown = [stem for stem in wanted if stem not in known]
    if unknown:
        raise PlotError(f"{run_dir} has no figure {', '.join(unknown)}; its figures: {', '.join(known)}")
    figures = {stem: papers[stem] if stem in papers else makers[stem]() for stem in wanted or known}
    return save_figures(figures, run_dir if out is None else out)


def run(scenario, *, seed=None, progress=False, allow_long=False, on_warning=None, native=None):
    """Run a scenario in memory: build, design checks, closed loop, metrics, comparison.

    Parameters
    ----------
    scenario : coopsat.Scenario, str or Path
        A scenario, or a bundled scenario's name or a TOML file's path.
    seed : int, optional
        Replaces the scenario's seed.
    progress : bool
        Progress bar (shown once a run has taken 2 s).
    allow_long : bool
        Run even when the estimated wall time is above :data:`LONG_RUN_S`.
    on_warning : callable, optional
        Called with each failed design check (one line) before the simulation starts.
    native : bool, optional
        As :func:`coopsat.sim.engine.simulate`.

    Returns
    -------
    Result
        Nothing is written; :meth:`Result.save` writes the run folder.

    Raises
    ------
    ScenarioError
        A scenario that cannot be loaded, validated or built, or a run too long.
    coopsat.sim.engine.NonFiniteStateError
        The state turned NaN or infinite.
    coopsat.plugins.PluginError
        An analysis module that cannot be imported or has a malformed member (before the run).
    StageError
        A stage after the simulation (a paper's series, metrics, an explanation) raised: its
        ``.result`` holds the record and everything else that was computed.
    """
    from coopsat.scenarios.document import Scenario as Document

    doc = scenario if isinstance(scenario, Document) else Document.load(scenario)
    if seed is not None:
        doc = doc.with_seed(seed)
    built = prepare(doc.model)
    check_run_length(built, allow_long)
    for note in built.warnings:
        if on_warning is not None:
            on_warning(note)
    interrupt.check()
    failures = []
    ds, out = simulate_built(built, progress=progress, native=native, failures=failures)
    return analysed_result(doc, built, ds, out, failures)


def analysed_result(doc, built, ds, out, failures):
    """The :class:`Result` of a simulated run: its metrics and comparison added to its record.

    Parameters
    ----------
    doc : coopsat.Scenario
    built : Built
    ds : xarray.Dataset
        The record (:func:`record_dataset`).
    out : RunOutput
        The engine's output (for the compile and run times).
    failures : list
        The stages that failed so far (:class:`~coopsat.analysis.stages.StageFailure`); the
        analysis adds its own.

    Raises
    ------
    StageError
        Some stage failed: the error carries the result.
    """
    metrics, rows = analyse(built, ds, failures=failures)
    result = Result.from_built(doc, built, ds, metrics, rows, compile_s=out.compile_s, run_s=out.run_s, failures=failures)
    if failures:
        raise StageError(failures, result)
    return result


def save_run(result, out_dir, figures=False, report=True):
    """Write a run's folder (:func:`write_run_folder`) whether or not its stages all succeeded.

    Raises
    ------
    StageError
        A stage failed, in the run (``result.failures``) or while writing (figures, report):
        the folder holds the record and everything that was computed.
    """
    failures = list(result.failures)
    write_run_folder(Path(out_dir), result.built, result.dataset, result.metrics, result.comparison, figures=figures,
                     report=report, failures=failures)
    if failures:
        raise StageError(failures, replace(result, failures=tuple(failures)), Path(out_dir))
    return Path(out_dir)


def run_and_save(make, out_dir, figures=False, report=True):
    """``make()``'s :class:`Result` (a run, a SIL run), its folder written at ``out_dir`` (when
    not None) even when a stage after the simulation failed.

    Raises
    ------
    StageError
        A stage failed; with ``out_dir``, raised after the folder is written, naming it.
    """
    try:
        result = make()
    except StageError as err:
        if out_dir is None:
            raise
        result = err.result
    if out_dir is not None:
        interrupt.check()  # a stop requested during the run writes nothing
        save_run(result, out_dir, figures=figures, report=report)
    return result


def summary_lines(result):
    """What ``coopsat run`` prints after the folder line: every metric, then each published
    number beside ours with the verdict and its reason (a :class:`RunResult`)."""
    lines = [f"  {key} = {'null' if value is None else f'{value:.6g}'}" for key, value in result.metrics.items()]
    for row in result.comparison:
        ours = "never" if row["ours"] is None else f"{row['ours']:.4g}"
        lines.append(f"  {row['quantity']}: published {row['published']:g}, ours {ours}: {row['verdict']}")
        if row["reason"]:
            lines.append(f"    {row['reason']}")
    if result.comparison:
        lines.append(f"  (comparison.md in {result.out_dir})")
    return lines


def run_scenario(ref, out_dir=None, overrides=(), progress=False, figures=False, on_warning=None, allow_long=False,
                 report=True):
    """Run a bundled scenario or scenario file and write its run folder (``coopsat run``).

    Parameters
    ----------
    ref : str or Path
        Bundled scenario name or TOML path.
    out_dir : str or Path, optional
        Run folder; default ``runs/<scenario name>``.
    overrides : iterable of str
        ``key.path=value`` assignments.
    progress : bool
        Progress bar for long runs.
    figures : bool
        Draw the PNG figures too (``coopsat run --figures``; ``coopsat plot`` draws them later).
    on_warning : callable, optional
        Called with each design-time warning (one line) before the simulation starts.
    allow_long : bool
        Run even when the estimated wall time is above :data:`LONG_RUN_S`.
    report : bool
        Write ``report.html``.

    Returns
    -------
    RunResult

    Raises
    ------
    StageError
        A stage after the simulation raised: the folder is written with the record and every
        other stage's output, and the error names the stage and the plug-in.
    """
    from coopsat.scenarios.document import with_overrides

    doc = with_overrides(ref, overrides)
    target = Path(out_dir) if out_dir is not None else Path("runs") / doc.name
    check_run_folder(target)
    result = run_and_save(lambda: run(doc, progress=progress, allow_long=allow_long, on_warning=on_warning), target,
                          figures=figures, report=report)
    return RunResult(target, result.dataset, result.metrics, result.comparison, result.warnings, result.compile_s, result.run_s)
