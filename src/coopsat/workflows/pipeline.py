"""One scenario, end to end: load → build → simulate → dataset → metrics → comparison → files.

The run folder is written to a temporary sibling folder and renamed into place at the end,
so a failed run (bad input, non-finite state) leaves nothing half-written.
"""

import importlib
import json
import warnings
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

import coopsat
from coopsat.workflows import interrupt
from coopsat.analysis.compare import compare_published, comparison_markdown
from coopsat.analysis.metrics import attitude_moves, run_metrics
from coopsat.analysis.papers import explainers, paper_metrics, paper_modules, paper_series
from coopsat.workflows.folders import atomic_folder, check_folder, json_ready
from coopsat.scenarios.build import DesignWarning, build, inertia_matrix
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

    def save(self, out_dir, *, figures=True, report=True):
        """Write the run folder ``coopsat run`` writes (result.nc, metrics.json,
        comparison.{md,json}, figures, report.html, run.json), atomically; returns its path.

        An existing folder is replaced only if it is a run folder (it holds ``run.json``).

        Raises
        ------
        RunFolderError
        """
        return write_run_folder(Path(out_dir), self.built, self.dataset, self.metrics, self.comparison, figures=figures,
                                report=report)

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
    """Build a validated scenario; its design-time warnings are in ``built.warnings``.

    Also checks, before anything runs, that every ``[[published]]`` quantity names a metric
    this run will produce, unless ``check_published`` is False (a campaign's runs, which never
    compare with published values: the check traces the engine, 15 ms a run of
    ``consensus-sync-a-stable``, half the run itself in a batch).
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DesignWarning)  # returned in built.warnings instead
        built = build(scenario)
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
    ds = paper_series(to_dataset(RunOutput(np.array([0.0, 1.0]), samples, 0.0, 0.0), built.names, {}, specs), built)
    with np.errstate(all="ignore"):  # only the names count: the stand-in's zeros may divide 0 by 0
        metrics, _ = analyse(built, ds, compare=False)
    return set(metrics)


def simulate_built(built, progress=False, native=None):
    """Run a built scenario; returns (dataset, RunOutput). ``native``: as
    :func:`coopsat.sim.engine.simulate`."""
    from coopsat.sim.engine import simulate

    out = simulate(built.system, built.n_records, built.record_interval_s, progress=progress, names=built.names,
                   cancel=interrupt.check, native=native)
    return record_dataset(built, out), out


def record_dataset(built, out, **attrs):
    """The run's record as a Dataset, from the engine's samples (a RunOutput): what ran, when,
    the design checks and the paper's series; ``attrs``: more global attributes (str, int or
    float), after the standard ones."""
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
        **attrs,
    }
    for check in built.checks.values():
        attrs[f"check_{check.name}"] = check.note
    return paper_series(to_dataset(out, built.names, attrs, output_specs(built.system)), built)


def analyse(built, ds, compare=True):
    """Metrics and comparison rows (empty unless ``compare``) of a finished run."""
    sc = built.scenario
    inertia = np.stack([inertia_matrix(s.inertia_kgm2) for s in sc.spacecraft])
    h_wheels = np.array([s.h_wheels_b_nms for s in sc.spacecraft], dtype=float)
    # From the scenario's initial state, not the record's: metric_names' stand-in record is zeros.
    attitude = attitude_moves(ds, [s.omega_b_rad_s for s in sc.spacecraft], [s.angle_rad for s in sc.spacecraft])
    metrics = {**built.design_metrics, **run_metrics(ds, built.names, inertia, h_wheels, attitude), **paper_metrics(ds, built)}
    if not compare:
        return metrics, []
    note = "; ".join(built.warnings) or None
    return metrics, compare_published(sc.published, metrics, note, sc.sim.t_final_s, explainers(built))


RUN_MARKER = "run.json"
"""Written into every run folder (what ran, when, with which coopsat): only a folder holding
it is ever replaced by a new run."""


class RunFolderError(ValueError):
    """The run folder cannot be written where the user asked."""


def check_run_folder(out_dir):
    """Refuse, before anything runs, a target that is not a run folder or cannot be created.

    Raises
    ------
    RunFolderError
    """
    check_folder(out_dir, RUN_MARKER, "coopsat run", RunFolderError)


def write_run_folder(out_dir, built, ds, metrics, rows, figures=True, report=True):
    """Write result.nc, metrics.json, comparison.{md,json}, figures, report.html and run.json,
    atomically.

    Parameters
    ----------
    out_dir : Path
        Final folder; an existing run folder is replaced only once the new one is complete,
        anything else that exists there is refused (:func:`check_run_folder`).
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
        ds.to_netcdf(tmp / "result.nc", engine="h5netcdf")
        (tmp / "metrics.json").write_text(json.dumps(json_ready(metrics), indent=2, allow_nan=False) + "\n")
        if built.scenario.published:
            (tmp / "comparison.json").write_text(json.dumps(json_ready(rows), indent=2, allow_nan=False) + "\n")
            (tmp / "comparison.md").write_text(comparison_markdown(rows, built.scenario.name))
        if figures:
            from coopsat.plots.figures import save_figures

            interrupt.check()  # the figures take seconds: a stop need not wait for them (nothing is written)
            save_figures(run_figures(built, ds), tmp)
        if report:
            from coopsat.reports import report_html

            interrupt.check()
            (tmp / REPORT_FILE).write_text(report_html(built, ds, metrics, rows), encoding="utf-8")
    return out_dir


REPORT_FILE = "report.html"


def read_record(run_dir, error):
    """A run folder's record and the scenario it ran: (``result.nc`` as a Dataset, the
    :class:`~coopsat.scenarios.document.Scenario` of its resolved TOML); ``error`` (an exception
    class) names a folder without a readable record in one line."""
    import xarray as xr

    from coopsat.scenarios.document import Scenario as Document

    try:
        ds = xr.load_dataset(Path(run_dir) / "result.nc", engine="h5netcdf")
        return ds, Document.from_toml(ds.attrs["scenario_toml"])
    except (OSError, ValueError, KeyError) as err:
        raise error(f"{run_dir}: no run record to read (result.nc with its scenario_toml): {err}") from None


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
    checks = {c.name: c for c in built.checks.values()}
    return Result(doc, ds, metrics, rows, checks, list(built.warnings), float(ds.attrs.get("compile_time_s", 0.0)),
                  float(ds.attrs.get("run_time_s", 0.0)), built)


def run_figures(built, ds):
    """Every figure of a run, keyed by file stem: the standard ones and its papers'."""
    from coopsat.plots.figures import standard_figures

    return {**standard_figures(ds, built.scenario.analysis), **_paper_figures(built, ds)}


def _paper_figures(built, ds):
    """The figures of the run's papers, keyed by file stem."""
    figures = {}
    for module in paper_modules(built):
        if hasattr(module, "FIGURES"):
            figures.update(importlib.import_module(module.FIGURES).figures(ds, built))
    return figures


class PlotError(ValueError):
    """A figure a run folder does not have, or a folder without a run's record (one line)."""


def plot_run(run_dir, what=None, out=None):
    """Draw a run folder's figures again from its ``result.nc`` (``coopsat plot``).

    Parameters
    ----------
    run_dir : str or Path
        A run folder written by ``coopsat run``.
    what : iterable of str, optional
        File stems of the figures to draw (``attitude``, ``torque_sat1``, a paper's
        ``formation_error`` …); default every figure the run has.
    out : str or Path, optional
        Folder for the PNG files (created if missing); default ``run_dir``.

    Returns
    -------
    list of Path
        The files written.

    Raises
    ------
    PlotError
        No record in ``run_dir``, or a stem the run has no figure of (the message lists those
        it has).
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


ENGINE_RATE_SC_STEPS_S = 2e6
"""Spacecraft-steps per second assumed when estimating a run's wall time: the consensus loop's
lower figure on the 2-core CPU machine of `coopsat bench` (README, Speed); pulsed actuators
split ticks and count double."""

LONG_RUN_S = 1800.0
"""Estimated wall time above which a run needs ``allow_long`` (``--allow-long``), s."""


class RunTooLongError(ScenarioError):
    """A run whose estimated wall time is above :data:`LONG_RUN_S` and was not allowed."""


def estimated_run_s(built):
    """Rough wall time of the closed loop, s, from the run's size and the engine's speed."""
    s = built.scenario
    steps = s.sim.t_final_s / s.sim.dt_s * len(built.names) * s.sim.substeps
    pulsed = any(getattr(a, "pulsed", False) for a in built.system.actuators)
    return steps * (2.0 if pulsed else 1.0) / ENGINE_RATE_SC_STEPS_S


def check_run_length(built, allow_long=False):
    """Refuse, before anything runs, a run estimated to take longer than :data:`LONG_RUN_S`.

    Raises
    ------
    RunTooLongError
    """
    estimate = estimated_run_s(built)
    if estimate > LONG_RUN_S and not allow_long:
        s = built.scenario
        raise RunTooLongError(
            f"sim: {s.sim.t_final_s / s.sim.dt_s:.3g} ticks of {len(built.names)} spacecraft would take about "
            f"{estimate / 3600:.2g} h at ~{ENGINE_RATE_SC_STEPS_S / 1e6:g} M spacecraft-steps/s; shorten the run or "
            "take a larger step, or pass --allow-long to run it anyway"
        )
    return estimate


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
    ds, out = simulate_built(built, progress=progress, native=native)
    metrics, rows = analyse(built, ds)
    checks = {c.name: c for c in built.checks.values()}
    return Result(doc, ds, metrics, rows, checks, list(built.warnings), out.compile_s, out.run_s, built)


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


def run_scenario(ref, out_dir=None, overrides=(), progress=False, figures=True, on_warning=None, allow_long=False,
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
        Write the PNG figures.
    on_warning : callable, optional
        Called with each design-time warning (one line) before the simulation starts.
    allow_long : bool
        Run even when the estimated wall time is above :data:`LONG_RUN_S`.
    report : bool
        Write ``report.html``.

    Returns
    -------
    RunResult
    """
    from coopsat.scenarios.document import with_overrides

    doc = with_overrides(ref, overrides)
    target = Path(out_dir) if out_dir is not None else Path("runs") / doc.name
    check_run_folder(target)
    result = run(doc, progress=progress, allow_long=allow_long, on_warning=on_warning)
    interrupt.check()
    result.save(target, figures=figures, report=report)
    return RunResult(target, result.dataset, result.metrics, result.comparison, result.warnings, result.compile_s, result.run_s)
