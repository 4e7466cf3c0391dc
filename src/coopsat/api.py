"""The public Python API: what the ``coopsat`` command does, callable with the same objects.

Everything here takes a :class:`~coopsat.scenarios.document.Scenario` (or a bundled name or a
TOML path) and returns a named result; nothing is written unless a folder is asked for.
docs/api.md lists the public names; ``coopsat/__init__.py`` loads them lazily.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from coopsat.workflows.pipeline import Result, prepare, run_and_save
from coopsat.workflows.pipeline import run as _run_one
from coopsat.scenarios.document import Scenario

ScenarioLike = Scenario | str | Path
"""A :class:`Scenario`, a bundled scenario's name, or a TOML file's path."""


def _document(scenario: ScenarioLike) -> Scenario:
    return scenario if isinstance(scenario, Scenario) else Scenario.load(scenario)


def configure(*, float64: bool = True, unrolled_threefry: bool = False, compilation_cache: bool | str = False) -> None:
    """Choose what coopsat changes in this process's JAX (docs/api.md, "Your process").

    Importing coopsat changes nothing. The first build or run turns on ``jax_enable_x64``;
    call this before it to decline that, to opt in to the unrolled lowering of small Threefry
    hashes on the CPU (the same random bits, faster; on by default only in the processes
    coopsat owns, the ``coopsat`` command and its workers), or to turn on JAX's persistent
    compilation cache (at any time).

    Parameters
    ----------
    float64 : bool
        Turn on ``jax_enable_x64`` (process-wide). The closed loop integrates attitude to
        1e-12: without float64, results are float32 and do not meet the documented accuracy.
    unrolled_threefry : bool
        Lower Threefry hashes of at most 16 elements as straight-line code on the CPU
        (2–3× faster runs that draw random numbers every period; numbers unchanged): replaces
        JAX's CPU lowering rule of ``threefry2x32`` for the whole process.
    compilation_cache : bool or str
        True: JAX's persistent compilation cache in ``$COOPSAT_JAX_CACHE`` or
        ``~/.cache/coopsat/jax`` (what the ``coopsat`` command uses); a string: that folder.
        Process-wide, and it caches every program, not only slow ones.

    Raises
    ------
    coopsat.InputError
        ``float64`` or ``unrolled_threefry`` other than what the process's first build or run
        already applied: too late, say so rather than leave compiled programs inconsistent.
    """
    from coopsat.core import runtime

    runtime.set_choices(float64=float64, unrolled_threefry=unrolled_threefry)
    if compilation_cache:
        import jax

        settings = runtime.cache_settings()
        if isinstance(compilation_cache, str):
            settings["jax_compilation_cache_dir"] = compilation_cache
        for name, value in settings.items():
            jax.config.update(name, value)


@dataclass(frozen=True)
class Validation:
    """A scenario validated and built, its design checks run; nothing simulated.

    Attributes
    ----------
    scenario : Scenario
    checks : dict of str -> coopsat.plugins.DesignCheck
        Each check's ``ok``, one-line ``note``, ``metrics`` and ``detail`` (its certificate).
    warnings : list of str
        The checks that failed, one line each.
    metrics : dict of str -> float
        Numbers known before the run (stability bounds, margins).
    estimated_run_s : float
        Rough wall time of the closed loop, s.
    """

    scenario: Scenario
    checks: dict
    warnings: list
    metrics: dict
    estimated_run_s: float
    built: Any = field(default=None, repr=False, compare=False)


def validate(scenario: ScenarioLike) -> Validation:
    """Validate and build a scenario and run its design-time checks (``coopsat validate``).

    Raises
    ------
    ScenarioError
        One line naming the field or the cause.
    """
    from coopsat.scenarios.run_length import estimated_run_s

    doc = _document(scenario)
    built = prepare(doc.model)
    return Validation(doc, built.named_checks, list(built.warnings), dict(built.design_metrics), estimated_run_s(built), built)


def run(scenario: ScenarioLike, *, seed: int | None = None, out_dir: str | Path | None = None, figures: bool = False,
        report: bool = True, progress: bool = False, allow_long: bool = False, native: bool | None = None) -> Result:
    """Run one scenario (``coopsat run``), in memory.

    Parameters
    ----------
    scenario : Scenario, str or Path
    seed : int, optional
        Replaces the scenario's seed.
    out_dir : str or Path, optional
        Also write the run folder there (as :meth:`Result.save`).
    figures : bool
        With ``out_dir``: write the figures too (:meth:`Result.figures` draws them any time).
    report : bool
        With ``out_dir``: write ``report.html`` (:func:`report` makes it any time).
    progress : bool
        Progress bar once a run has taken 2 s.
    allow_long : bool
        Run even when the estimated wall time is above half an hour.
    native : bool, optional
        Native CPU kernels: True requires them (an error where they cannot run), False keeps
        the whole loop in XLA; None (default) follows ``COOPSAT_NATIVE`` (``auto``: the kernels
        where this process's check passes, else XLA with one notice; docs/api.md).

    Returns
    -------
    Result
        ``dataset`` (xarray), ``metrics``, ``comparison``, ``checks``, ``save(dir)``,
        ``figures()``.

    Raises
    ------
    StageError
        A stage after the simulation raised (a plug-in's metrics, figures, the report): its
        ``.result`` holds the record and whatever else was computed, and with ``out_dir`` the
        folder is written (``.out_dir``).
    """
    return run_and_save(lambda: _run_one(_document(scenario), seed=seed, progress=progress, allow_long=allow_long,
                                         native=native), out_dir, figures, report)


def sil(scenario: ScenarioLike, *, seed: int | None = None, out_dir: str | Path | None = None, figures: bool = False,
        report: bool = True, kill: Sequence[tuple[str, float]] = (), pause: Sequence[tuple[str, float, float]] = (),
        externals: Mapping[str, str] | None = None,
        fault_command: str | None = None, realtime: float | None = None, answer_s: float = 10.0,
        handshake_s: float = 120.0) -> Result:
    """Run one scenario as software in the loop (``coopsat sil``, docs/sil.md): one flight-software
    process per spacecraft, the simulator here; the same :class:`Result` as :func:`run`, equal to
    it when every process answers.

    Parameters
    ----------
    scenario, seed, out_dir, figures, report
        As :func:`run`.
    kill : sequence of (str, float)
        ``("sat3", 10.0)``: kill that spacecraft's flight software at t = 10 s.
    pause : sequence of (str, float, float)
        ``("sat3", 120.0, 30.0)``: stop it at t = 120 s for 30 s of simulated time.
    externals : mapping of str to str, optional
        ``{"sat2": "python law3.py"}``: that spacecraft's flight software is this command (it
        speaks the protocol of docs/sil.md) instead of coopsat's own.
    fault_command : {"hold", "zero"}, optional
        What a silent spacecraft's actuators execute: its last command, or zero (default: the
        scenario's ``[sil] fault_command``, hold).
    realtime : float, optional
        Simulated seconds per wall second, each period's answers due within its slot of wall
        time; misses are counted and recorded (``sil_deadline_misses``) and a late command is
        held (default: lockstep, as fast as the processes answer).
    answer_s, handshake_s : float
        Longest wait for a process's answer in a period, and for every process to start, s.

    Raises
    ------
    coopsat.workflows.sil.schema.SILSetupError
        A controller that cannot be split per spacecraft, a fault record naming an unknown
        spacecraft or a time outside the run, an external command that cannot start (one line).
    coopsat.workflows.sil.schema.SILError
        A process that does not start, answer in time or keep the protocol (one line).
    StageError
        As :func:`run`.
    """
    from coopsat.workflows.sil.run import sil as _sil

    return run_and_save(lambda: _sil(_document(scenario), seed=seed, kill=kill, pause=pause, externals=externals,
                                     fault_command=fault_command, realtime=realtime, answer_s=answer_s,
                                     handshake_s=handshake_s), out_dir, figures, report)


def load_run(run_dir: str | Path) -> Result:
    """A run folder written by ``coopsat run`` (or :meth:`Result.save`), read back.

    The record, metrics and comparison come from the folder; the scenario is rebuilt from the
    resolved TOML kept in ``result.nc``, so ``built``, ``checks`` and :meth:`Result.figures`
    work as after :func:`run`.

    Raises
    ------
    coopsat.workflows.pipeline.RunFolderError
        Not a run folder, or one that cannot be read.
    """
    from coopsat.workflows.pipeline import load_run as _load

    return _load(run_dir)


def report(run: Result | str | Path, out: str | Path | None = None) -> Path:
    """Write a run's interactive report page (``coopsat report``): the 3D view of the formation,
    its network over time, the time series, the published comparison, the design-time checks
    and the metrics, in one self-contained HTML file (docs/report.md).

    Parameters
    ----------
    run : Result, str or Path
        A result in memory, or a run folder.
    out : str or Path, optional
        The file to write; default ``report.html`` in the run folder (required for a result
        in memory).

    Returns
    -------
    Path
        The file written (atomically).
    """
    from coopsat.workflows.folders import write_text_atomically
    from coopsat.workflows.pipeline import REPORT_FILE

    if not isinstance(run, Result):
        folder = Path(run)
        run = load_run(folder)
        out = folder / REPORT_FILE if out is None else out
    elif out is None:
        raise TypeError("report(result): give out=FILE for a result in memory (a run folder has its own place)")
    write_text_atomically(out, run.report_html())
    return Path(out)


def plot(run_dir: str | Path, what: Sequence[str] | None = None, out: str | Path | None = None) -> list[Path]:
    """Draw a run folder's figures again from its ``result.nc`` (``coopsat plot``).

    Parameters
    ----------
    run_dir : str or Path
        A run folder written by ``coopsat run``.
    what : sequence of str, optional
        Figures by file stem (``attitude``, ``torque_sat1``, a paper's ``formation_error`` …);
        default every figure the run has.
    out : str or Path, optional
        Folder for the PNG files (created if missing); default the run folder.

    Returns
    -------
    list of Path
        The files written.

    Raises
    ------
    coopsat.workflows.pipeline.PlotError
        No record in the folder, or a name the run has no figure of (the message lists those
        it has).
    """
    from coopsat.workflows.pipeline import plot_run

    return plot_run(run_dir, what, out)


@dataclass(frozen=True)
class Batch:
    """Runs made together (:func:`run_batch`).

    Attributes
    ----------
    results : list of Result
        One per scenario, in order (``compile_s``/``run_s`` of each are zero: see below).
    compile_s, run_s : float
        Wall time compiling and running every vmapped batch, s.
    n_batches : int
        Compiled structures (runs that share laws, sizes and rates run as one batch).
    build_s : float
        Wall time building the runs, s.
    build_note : str
        How they were built, one line: once, the fields in which they differ applied as arrays
        (the seed, the initial attitude, rates and wheel momenta), or each on its own and why.
    """

    results: list
    compile_s: float
    run_s: float
    n_batches: int
    build_s: float = 0.0
    build_note: str = ""


def run_batch(scenarios: Sequence[ScenarioLike], *, progress: bool = False, native: bool | None = None) -> Batch:
    """Run several scenarios, one vmapped batch per shared structure (``coopsat sweep``'s engine).

    Each run's dataset and metrics are those :func:`run` gives for the same scenario (to the
    last bits: a batch groups its floating-point sums differently). Published numbers are not
    compared (``comparison`` is empty). ``native``: as :func:`run`.
    """
    import time

    from coopsat.scenarios.applied import changed_paths
    from coopsat.workflows.sweep import analysed_runs, build_runs, group_runs

    t0 = time.perf_counter()
    docs = [_document(s) for s in scenarios]
    raws = [d.to_dict() for d in docs]
    paths = list(dict.fromkeys(p for raw in raws[1:] for p in changed_paths(raws[0], raw)))
    builds, stacked, note = build_runs([d.model for d in docs], paths)
    build_s = time.perf_counter() - t0
    metrics, datasets, compile_s, run_s = analysed_runs(builds, progress, native=native, stacked=stacked)
    results = [Result.from_built(doc, built, ds, m) for doc, built, ds, m in zip(docs, builds, datasets, metrics)]
    return Batch(results, compile_s, run_s, 1 if stacked is not None else len(group_runs(builds)), build_s, note)


def sweep(scenario: ScenarioLike, vary: Mapping[str, Sequence[Any]], *, seeds: int = 1, metrics: Sequence[str] | None = None,
          out_dir: str | Path | None = None, plots: Sequence[tuple[str, str]] = (), progress: bool = False):
    """Run a scenario over values of fields, zipped (``coopsat sweep``).

    Parameters
    ----------
    scenario : Scenario, str or Path
    vary : mapping of field path -> sequence of values
        Run k takes the k-th value of every field (all sequences of one length).
    seeds : int
        Runs per point, seeds ``seed … seed + seeds − 1``.
    metrics : sequence of str, optional
        Metrics tabulated; default every scalar metric.
    out_dir : str or Path, optional
        Write ``sweep.csv``, ``sweep.json`` and the ``plots`` there.
    plots : sequence of (x, y)
        Metric or field ``y`` against ``x``, one PNG each (need ``out_dir``).

    Returns
    -------
    coopsat.workflows.sweep.SweepResult
        ``runs`` (per run: fields, seed, metrics), ``points`` (mean and max over seeds),
        ``metrics``, ``n_batches``, ``compile_s``, ``run_s``.
    """
    from coopsat.workflows.sweep import run_sweep

    return run_sweep(_document(scenario), [(path, list(values)) for path, values in vary.items()], n_seeds=seeds, metrics=list(metrics) if metrics else None,
                     out_dir=out_dir, plots=list(plots), progress=progress)


def pair(a: ScenarioLike, b: ScenarioLike, *, seeds: int = 3, progress: bool = False):
    """Run two scenarios on the same seeds, so that one design change is isolated (``coopsat pair``).

    Returns
    -------
    coopsat.workflows.pair.PairResult
        ``metrics`` per seed for A and B, ``series`` over time, ``table()`` of B − A.
    """
    from coopsat.workflows.pair import run_pair

    return run_pair(_document(a), _document(b), n_seeds=seeds, progress=progress)


def tune(scenario: ScenarioLike, objective: str, params: Sequence[str], *, constraints: Mapping[str, float] | None = None,
         starts: int = 1,
         polish: int = 1, max_iter: int = 50, seed: int = 0, report: Callable[[str], None] | None = None):
    """Tune gains by gradient through the whole closed loop, then re-run exactly (``coopsat tune``).

    Parameters
    ----------
    scenario : Scenario, str or Path
    objective : str
        Metric to minimise.
    params : sequence of str
        Field paths (``"controller.alpha"``).
    constraints : mapping of str -> float, optional
        ``{"sync_time_s": 300.0}``: each metric must end at most its bound (the command line's
        ``--constraint 'sync_time_s<=300'``).
    starts, polish, max_iter, seed
        As ``coopsat tune``'s options (docs/tuning.md).
    report : callable, optional
        Receives one line per iteration (default: silent).

    Returns
    -------
    coopsat.workflows.tune.TuneResult
    """
    from coopsat.workflows.tune import tune as _tune

    return _tune(_document(scenario), objective, constraints=dict(constraints or {}), params=tuple(params), starts=starts,
                 polish=polish, max_iter=max_iter, seed=seed, report=report or (lambda line: None))


@dataclass(frozen=True)
class CampaignRun:
    """A finished (or resumed) campaign (``coopsat campaign run``).

    Attributes
    ----------
    out_dir : Path
        The campaign folder (Parquet per batch, resumable).
    runs, batches, skipped_batches, failed : int
        Runs and batches in all, batches already on disk, runs that failed.
    wall_s : float
        Wall time, s.
    worker_peak_rss_mb : float or None
    """

    out_dir: Path
    runs: int
    batches: int
    skipped_batches: int
    failed: int
    wall_s: float
    worker_peak_rss_mb: float | None

    def results(self):
        """Every finished run's parameters and metrics, one row per run (a ``pyarrow.Table``;
        ``.to_pandas()`` where pandas is installed)."""
        from coopsat.workflows.campaign.runner import read_results

        return read_results(self.out_dir)


def campaign(campaign: str | Path, out_dir: str | Path, *, workers: int | None = None, scheduler: str | None = None,
             progress: bool = False) -> CampaignRun:
    """Run or resume a Monte Carlo campaign on Dask (docs/campaigns.md).

    Parameters
    ----------
    campaign : str or Path
        A bundled campaign's name or a campaign TOML file.
    out_dir : str or Path
        Campaign folder; a killed campaign resumes where it stopped.
    workers : int, optional
        Local worker processes (one CPU device each); default one.
    scheduler : str, optional
        ``tcp://host:port`` of a running Dask scheduler instead.
    """
    from coopsat.workflows.campaign.runner import run_campaign

    summary = run_campaign(campaign, Path(out_dir), workers=workers, scheduler=scheduler, progress=progress)
    return CampaignRun(Path(out_dir), **{k: summary[k] for k in ("runs", "batches", "skipped_batches", "failed", "wall_s",
                                                                  "worker_peak_rss_mb")})


def export(run: Result | str | Path, format: str, out: str | Path | None = None) -> Path:
    """Write a finished run as a CCSDS OEM, a CCSDS AEM or a CZML scene (``coopsat export``,
    docs/export.md).

    Parameters
    ----------
    run : Result, str or Path
        A run in memory, or a run folder written by ``coopsat run``.
    format : {"oem", "aem", "czml"}
        ``oem``: orbits (the run's frame and clock, GCRF and TT by default; km); ``aem``:
        attitude quaternions (the run's inertial frame to SC_BODY_1, A2B, scalar first); ``czml``: a Cesium scene of an Earth orbit.
    out : str or Path, optional
        The file written; for an OEM or AEM of several spacecraft, a folder of one file per
        spacecraft (CCSDS messages describe one object each). Default: in the run folder (the
        current folder for a run in memory), ``<scenario>.<format>`` or ``<scenario>-<format>/``.

    Returns
    -------
    Path
        The file or folder written.

    Raises
    ------
    ExportError
        One line naming the cause: an unknown format, a run without what the format holds
        (positions, attitude, a central body the standard names), an output that cannot be written.
    """
    from coopsat.exports import export_run

    return export_run(run, format, out)
