"""``coopsat sweep``: a scenario run over values of any field(s), its metrics tabulated.

Each ``--vary FIELD=V1,V2,…`` is a list of ``--set`` values for one field; several lists of one
length are zipped (run k takes the k-th value of each). With ``seeds`` = K every point runs
with the seeds ``seed … seed + K − 1`` and is summarised by the mean and the max of each metric
over them. The runs are grouped by compiled structure (:func:`group_runs`) and each
group runs as one vmapped batch (:func:`run_batch`, also the engine of
:mod:`coopsat.workflows.deep_space_tradeoff`); every run's metrics are those ``coopsat run`` reports for the same
overrides.
"""

import csv
import json
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from coopsat.core.errors import InputError
from coopsat.workflows import interrupt
from coopsat.analysis.papers import member, paper_modules, paper_series
from coopsat.workflows.folders import atomic_folder, check_folder, json_ready
from coopsat.workflows.analyse import analyse, analyse_batch
from coopsat.workflows.pipeline import metric_names, prepare
from coopsat.scenarios.load import clip_echo, load_scenario, parse_value

MARKER = "sweep.json"
"""Written into every sweep folder: only a folder holding it is replaced by a new sweep."""

PRINTED_METRICS = 6
"""Metric columns printed when none are chosen (every metric is in the files)."""


class SweepError(InputError):
    """A sweep that cannot be run as asked (one line)."""


@dataclass
class SweepResult:
    """What :func:`run_sweep` produced.

    Attributes
    ----------
    fields : list of str
        The varied field paths.
    texts : list of list of str
        Per point, each field's value as given.
    runs : list of dict
        Per run (point-major, then seed): each field's value, ``seed``, and every scalar metric.
    points : list of dict
        Per point: ``values`` ({field: value}), ``seeds``, and ``mean`` and ``max`` over the
        seeds of each of ``metrics`` (NaN where a run has none, e.g. a time never reached).
    metrics : list of str
        The metrics tabulated: those asked for, else every scalar metric.
    n_batches : int
        Vmapped batches (one per compiled structure).
    compile_s, run_s : float
        Wall time compiling and running the closed loops, s.
    """

    fields: list
    texts: list
    runs: list
    points: list
    metrics: list
    n_batches: int
    compile_s: float
    run_s: float


def split_values(text):
    """``V1,V2,…`` split at the commas outside brackets, braces and quotes (so that
    ``[0,0,1],[0,1,0]`` is two arrays), each stripped."""
    pieces, depth, quote, start = [], 0, None, 0
    for k, ch in enumerate(text):
        if quote:
            quote = None if ch == quote else quote
        elif ch in "\"'":
            quote = ch
        elif ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        elif ch == "," and depth == 0:
            pieces.append(text[start:k].strip())
            start = k + 1
    return pieces + [text[start:].strip()]


def parse_vary(spec):
    """One ``--vary FIELD=V1,V2,…``.

    Returns
    -------
    (field, values)
        The field path and its values, each parsed as a ``--set`` value (TOML, else a bare
        string), as :func:`run_sweep` takes them.

    Raises
    ------
    SweepError
        No ``=``, no field, no values, or an empty value.
    """
    field, sep, values = spec.partition("=")
    field = field.strip()
    if not sep or not field:
        raise SweepError(f"--vary {clip_echo(spec)}: expected FIELD=V1,V2,... (e.g. controller.period_s=0.01,0.02)")
    texts = split_values(values)
    if not any(texts):
        raise SweepError(f"--vary {clip_echo(field)}: no values (expected {clip_echo(field)}=V1,V2,...)")
    if not all(texts):
        raise SweepError(f"--vary {clip_echo(spec)}: an empty value between commas")
    return field, [parse_value(t) for t in texts]


def value_text(value):
    """A varied value as the table and the CSV show it: its TOML text (``0.5``, ``"hub"``,
    ``[1.0, 2.0]``; floats round-trip exactly)."""
    import tomli_w

    return tomli_w.dumps({"v": value}).split("=", 1)[1].strip()


def zip_points(varies):
    """Zip the varied fields' values into points.

    Parameters
    ----------
    varies : list of (field, values)

    Returns
    -------
    list of dict
        Per point, ``{field: value}``.

    Raises
    ------
    SweepError
        No field, a field given twice, a field with no values, or lists of different lengths.
    """
    if not varies:
        raise SweepError("vary: give at least one field and its values")
    fields = [f for f, _ in varies]
    twice = sorted({f for f in fields if fields.count(f) > 1})
    if twice:
        raise SweepError(f"vary {clip_echo(twice[0])}: given twice; give each field once")
    empty = [f for f, v in varies if not len(v)]
    if empty:
        raise SweepError(f"vary {clip_echo(empty[0])}: no values")
    lengths = {len(v) for _, v in varies}
    if len(lengths) > 1:
        counts = ", ".join(f"{clip_echo(f)}: {len(v)}" for f, v in varies)
        raise SweepError(f"vary: the value lists differ in length ({counts}); give every field the same number of values")
    return [{f: v[k] for f, v in varies} for k in range(lengths.pop())]


def parse_plot(spec):
    """One ``--plot X:Y`` as ``(x, y)``; raises :class:`SweepError` unless both are named."""
    x, sep, y = spec.partition(":")
    if not sep or not x.strip() or not y.strip():
        raise SweepError(f"--plot {clip_echo(spec)}: expected X:Y (a metric or varied field, then a metric)")
    return x.strip(), y.strip()


def group_runs(builds):
    """Indices of the built runs that can share one vmapped batch, in order of first appearance.

    Runs share a batch when their systems' pytree structure (static configuration) and every
    leaf's shape and dtype agree (what :func:`~coopsat.sim.system.stack_systems` needs), and so
    do their record times (``n_records``, ``record_interval_s``).

    Returns
    -------
    list of list of int
    """
    import jax
    import jax.numpy as jnp

    groups = {}
    for k, b in enumerate(builds):
        leaves = tuple((jnp.shape(v), jnp.result_type(v)) for v in jax.tree_util.tree_leaves(b.system))
        key = (jax.tree_util.tree_structure(b.system), leaves, b.n_records, b.record_interval_s)
        groups.setdefault(key, []).append(k)
    return list(groups.values())


def build_runs(models, paths):
    """Build validated scenarios that differ from ``models[0]`` only at ``paths`` (model paths):
    once, the others' values applied as arrays (:func:`coopsat.scenarios.applied.applied_runs`),
    when every path is applied as data; else each on its own.

    Returns
    -------
    (builds, stacked, note)
        ``stacked``: the runs' systems as one batch (None when each was built on its own, and
        :func:`simulate_runs` stacks them); ``note``: one line saying how they were built.
    """
    from coopsat.scenarios.applied import NotApplicable, applicable, applied_runs

    def build_one(m):
        return prepare(m, check_published=False)

    why = applicable(paths)
    if why is None and models:
        try:
            runs = applied_runs(build_one(models[0]), models, paths, build_one)
            shown = ", ".join(paths[:3]) + (f" and {len(paths) - 3} more" if len(paths) > 3 else "")
            return runs.builds, runs.system, (f"{len(models)} runs built once, {shown or 'nothing'} applied as arrays")
        except NotApplicable as err:
            why = str(err)
    return [build_one(m) for m in models], None, why or "each run built on its own"


def prepare_runs(ref, override_lists):
    """Load, validate and build the scenario once per override list (nothing runs).

    The runs are analysed without comparing with published values, so their ``[[published]]``
    names are not checked (:func:`~coopsat.workflows.pipeline.prepare`: the check traces the engine,
    2 s a run of ``observation-cooperative``)."""
    return [prepare(load_scenario(ref, overrides), check_published=False) for overrides in override_lists]


def simulate_batches(builds, progress=False, every_core=True, bucket=None, native=None, stacked=None):
    """Simulate built runs, one vmapped batch per group of :func:`group_runs`.

    ``every_core``: share each batch among the CPU devices (:func:`coopsat.sim.engine.simulate`);
    False keeps a run's result independent of the machine (campaigns, and their replay).
    ``bucket``: the largest batch expected; each group is padded to a recurring size below it
    (:func:`coopsat.sim.engine.bucket_runs`), so that the groups of many batches share
    compiled programs (campaigns). ``native``: as :func:`coopsat.sim.engine.simulate`.
    ``stacked``: the runs' systems already batched, all of one group
    (:func:`coopsat.scenarios.applied.applied_runs`); by default they are grouped and stacked here.

    Returns
    -------
    (batches, compile_s, run_s)
        ``batches``: per group, ``(run indices into builds, its batched RunOutput)``; the wall
        time compiling and running all of them, s.
    """
    from coopsat.sim.engine import simulate
    from coopsat.sim.system import stack_systems

    if stacked is None:
        groups = [(group, stack_systems([builds[k].system for k in group])) for group in group_runs(builds)]
    else:
        groups = [(list(range(len(builds))), stacked)]
    batches, compile_s, run_s = [], 0.0, 0.0
    for group, system in groups:
        first = builds[group[0]]
        out = simulate(
            system, first.n_records, first.record_interval_s,
            batched=True, progress=progress, names=first.names, every_core=every_core, bucket=bucket, cancel=interrupt.check,
            native=native,
        )
        compile_s += out.compile_s
        run_s += out.run_s
        batches.append((group, out))
        interrupt.check()
    return batches, compile_s, run_s


def run_datasets(builds, out):
    """One dataset per run of a batch (``builds``: its runs' builds, ``out``: its batched
    RunOutput), what ``coopsat run`` records: attributes ``scenario_name`` and ``seed``, the
    paper modules' derived series added."""
    from coopsat.sim.engine import output_specs
    from coopsat.sim.recorder import to_datasets

    first = builds[0]
    attrs = [{"scenario_name": b.scenario.name, "seed": b.scenario.seed} for b in builds]
    return [paper_series(ds, b) for b, ds in zip(builds, to_datasets(out, first.names, attrs, output_specs(first.system)))]


def batch_record(builds, out):
    """A batch's record as one dataset, dimension ``run`` first (its ``seed`` a coordinate), or
    None where a paper module of the runs derives series: those are made run by run, and the
    metrics may read them."""
    from coopsat.sim.engine import output_specs
    from coopsat.sim.recorder import to_dataset

    first = builds[0]
    if any(member(m, "series") is not None for m in paper_modules(first)):
        return None
    ds = to_dataset(out, first.names, {"scenario_name": first.scenario.name}, output_specs(first.system), batched=True)
    return ds.assign_coords(seed=("run", [b.scenario.seed for b in builds]))


def simulate_runs(builds, progress=False, every_core=True, bucket=None, native=None, stacked=None):
    """Simulate built runs (:func:`simulate_batches`), one dataset per run (:func:`run_datasets`).

    Returns
    -------
    (datasets, compile_s, run_s)
        One dataset per build, in order, and the wall time compiling and running all batches, s.
    """
    batches, compile_s, run_s = simulate_batches(builds, progress, every_core, bucket, native, stacked)
    datasets = [None] * len(builds)
    for group, out in batches:
        for k, ds in zip(group, run_datasets([builds[k] for k in group], out)):
            datasets[k] = ds
    return datasets, compile_s, run_s


def analysed_runs(builds, progress=False, datasets=True, **options):
    """Simulate built runs (:func:`simulate_batches`, ``options`` its own) and compute each
    one's metrics as ``coopsat run`` does (no comparison), a batch's at once where its paper
    modules allow (:func:`~coopsat.workflows.analyse.analyse_batch`).

    ``datasets``: also return each run's dataset (:func:`run_datasets`); False makes them only
    where the metrics need them.

    Returns
    -------
    (metrics, datasets, compile_s, run_s)
        Per build, in order: its metrics (dict) and its dataset (None where not made).
    """
    batches, compile_s, run_s = simulate_batches(builds, progress, **options)
    metrics, records = [None] * len(builds), [None] * len(builds)
    for group, out in batches:
        blds = [builds[k] for k in group]
        record = batch_record(blds, out)
        dss = run_datasets(blds, out) if datasets or record is None else [None] * len(blds)
        values = (analyse_batch(blds, record) if record is not None else
                  [analyse(b, ds, compare=False)[0] for b, ds in zip(blds, dss)])
        for k, m, ds in zip(group, values, dss):
            metrics[k], records[k] = m, ds
    return metrics, records, compile_s, run_s


def run_batch(ref, override_lists, progress=False):
    """Run a scenario once per override list, batching the runs that share a structure.

    Parameters
    ----------
    ref : str or Path
        Bundled scenario name or TOML path.
    override_lists : list of list of str
        Per run, its ``key.path=value`` overrides.
    progress : bool
        Progress bar per batch.

    Returns
    -------
    (runs, compile_s, run_s)
        ``runs``: per override list, ``(built, dataset)``.
    """
    builds = prepare_runs(ref, override_lists)
    datasets, compile_s, run_s = simulate_runs(builds, progress)
    return list(zip(builds, datasets)), compile_s, run_s


def _is_scalar(value):
    return value is None or isinstance(value, (bool, int, float, np.bool_, np.integer, np.floating))


def _number(value):
    return np.nan if value is None else float(value)


def _is_number(value):
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def summarise(runs, fields, metrics, n_seeds):
    """Per point (``n_seeds`` consecutive runs): its field values, seeds, and the mean and max
    of each metric over the seeds (a metric missing or null in a run makes them NaN)."""
    points = []
    for start in range(0, len(runs), n_seeds):
        group = runs[start:start + n_seeds]
        values = np.array([[_number(r.get(m)) for m in metrics] for r in group], dtype=float).reshape(len(group), len(metrics))
        points.append({
            "values": {f: group[0][f] for f in fields},
            "seeds": [r["seed"] for r in group],
            "mean": dict(zip(metrics, values.mean(axis=0).tolist())),
            "max": dict(zip(metrics, values.max(axis=0).tolist())),
        })
    return points


def check_sweep_folder(out_dir):
    """Refuse, before anything runs, a target that is not a sweep folder or cannot be created."""
    check_folder(out_dir, MARKER, "sweep", SweepError)


def _check_names(metrics, plots, known, points):
    """Every metric asked for is one the runs report; every plot's x is one, or a varied field
    with numbers for values."""
    fields = set(points[0])
    names = set(metrics or ()) | {y for _, y in plots} | {x for x, _ in plots if x not in fields}
    unknown = sorted(names - known)
    if unknown:
        raise SweepError(f"unknown metric '{clip_echo(unknown[0])}' (metrics of this scenario: {', '.join(sorted(known))})")
    for x, _ in plots:
        if x in fields and not all(_is_number(p[x]) for p in points):
            raise SweepError(f"plot {clip_echo(x)}: this field's values are not all numbers; plot against a metric")


def _seeded(base, points, n_seeds):
    """Per run (point-major), its scenario: the point's values, then its seed."""
    if n_seeds < 1:
        raise SweepError(f"seeds {n_seeds}: must be at least 1")
    runs = []
    for p in points:
        doc = base.update(p)
        runs += [doc] if n_seeds == 1 else [doc.with_seed(doc.model.seed + k) for k in range(n_seeds)]
    return runs


def run_sweep(ref, varies, n_seeds=1, metrics=None, overrides=(), out_dir=None, plots=(), progress=False):
    """Run a scenario over zipped values of fields, and tabulate (and with ``out_dir`` write)
    its metrics.

    Parameters
    ----------
    ref : str, Path or coopsat.Scenario
        Bundled scenario name, TOML path or scenario.
    varies : list of (field, values)
        Python values per field (the command line's from :func:`parse_vary`); zipped.
    n_seeds : int
        Runs per point, with seeds ``seed … seed + n_seeds − 1``.
    metrics : list of str, optional
        Metrics to tabulate; default every scalar metric.
    overrides : iterable of str
        The command line's ``key.path=value`` assignments applied to every run before the
        varied values.
    out_dir : str or Path, optional
        Folder for ``sweep.csv``, ``sweep.json`` and the plots (:func:`write_sweep_folder`).
    plots : list of (x, y)
        Metric or field ``y`` against ``x``; need ``out_dir``.
    progress : bool
        Progress bar per batch.

    Returns
    -------
    SweepResult

    Raises
    ------
    SweepError, ScenarioError
        Before anything runs: bad varied values, seeds, metric or plot names, or folder; a field
        or value the scenario refuses.
    """
    from coopsat.scenarios.document import with_overrides

    fields = [f for f, _ in varies]
    points = zip_points(varies)
    texts = [[value_text(p[f]) for f in fields] for p in points]
    if plots and out_dir is None:
        raise SweepError("plots: need a folder to receive the figures (out_dir, the command's --out)")
    if out_dir is not None:
        check_sweep_folder(out_dir)
    builds = [prepare(d.model, check_published=False) for d in _seeded(with_overrides(ref, overrides), points, n_seeds)]
    groups = group_runs(builds)
    known = set().union(*(metric_names(builds[g[0]]) for g in groups))
    _check_names(metrics, plots, known, points)
    interrupt.check()
    all_values, _, compile_s, run_s = analysed_runs(builds, progress, datasets=False)
    runs = []
    for k, (built, values) in enumerate(zip(builds, all_values)):
        runs.append({
            **points[k // n_seeds],
            "seed": built.scenario.seed,
            **{m: v for m, v in values.items() if _is_scalar(v)},
        })
    if metrics is None:
        metrics = [m for m in runs[0] if m not in fields and m != "seed" and all(m in r for r in runs)]
    result = SweepResult(fields, texts, runs, summarise(runs, fields, metrics, n_seeds), list(metrics),
                         len(groups), compile_s, run_s)
    if out_dir is not None:
        write_sweep_folder(out_dir, result, plots, ref)
    return result


def _csv_cell(value):
    if value is None or (isinstance(value, float) and not np.isfinite(value)):
        return ""
    return json.dumps(value) if isinstance(value, (list, dict)) else value


def _plot_values(result, name):
    """(points, seeds) array of a metric or varied field."""
    n = len(result.points)
    return np.array([_number(r.get(name)) for r in result.runs], dtype=float).reshape(n, -1)


def plot_file(x, y):
    """File name of the ``--plot x:y`` figure."""
    return re.sub(r"[^A-Za-z0-9_.-]", "_", f"sweep_{x}_{y}") + ".png"


def write_sweep_folder(out_dir, result, plots, ref):
    """Write ``sweep.csv`` (one row per run), ``sweep.json`` (the points, the metrics, the
    times) and one ``sweep_X_Y.png`` per plot, atomically: into a temporary sibling renamed
    into place, so that a failure leaves nothing half-written; an existing sweep folder is
    replaced only by a complete one."""
    out_dir = Path(out_dir)
    check_sweep_folder(out_dir)
    with atomic_folder(out_dir, SweepError) as tmp:
        columns = [*result.fields, "seed", *result.metrics]
        with open(tmp / "sweep.csv", "w", newline="", encoding="utf-8") as f:
            writer = csv.writer(f)
            writer.writerow(columns)
            writer.writerows([_csv_cell(r.get(c)) for c in columns] for r in result.runs)
        summary = {
            "scenario": str(ref),
            "fields": result.fields,
            "seeds_per_point": len(result.points[0]["seeds"]),
            "metrics": result.metrics,
            "points": result.points,
            "batches": result.n_batches,
            "compile_s": result.compile_s,
            "run_s": result.run_s,
        }
        (tmp / MARKER).write_text(json.dumps(json_ready(summary), indent=2, allow_nan=False) + "\n")
        if plots:
            from coopsat.plots.sweep import sweep_figure

            for x, y in plots:
                fig = sweep_figure(_plot_values(result, x), _plot_values(result, y), x, y, title=str(ref))
                fig.savefig(tmp / plot_file(x, y), dpi=120)
    return out_dir


def _cell(value):
    return "null" if value is None or not np.isfinite(value) else f"{value:.4g}"


def printed_metrics(result, chosen):
    """The metrics the printed table shows: all when chosen, else at most
    :data:`PRINTED_METRICS`, those that change across the runs first."""
    if chosen:
        return result.metrics
    varying = [m for m in result.metrics if len({repr(r.get(m)) for r in result.runs}) > 1]
    return (varying + [m for m in result.metrics if m not in varying])[:PRINTED_METRICS]


def table_lines(result, metrics):
    """The table of points: each varied field's value as given, then each metric (its value,
    or ``mean / max`` over the seeds), in aligned columns."""
    seeded = len(result.points[0]["seeds"]) > 1
    header = [*result.fields, *metrics]
    rows = [
        [*texts, *(f"{_cell(p['mean'][m])} / {_cell(p['max'][m])}" if seeded else _cell(p["mean"][m]) for m in metrics)]
        for texts, p in zip(result.texts, result.points)
    ]
    widths = [max(len(str(c)) for c in column) for column in zip(header, *rows)]
    return ["  ".join(f"{c:<{w}}" for c, w in zip(line, widths)).rstrip() for line in [header, *rows]]


def summary_lines(result, label, n_seeds, metrics=None, out_dir=None):
    """What ``coopsat sweep`` prints: the runs and batches, the table (at most six metrics
    unless ``metrics`` names them, :func:`printed_metrics`), and a note on what is not shown."""
    n_points, n_runs = len(result.points), len(result.runs)
    lines = [f"{label}: {n_points} points x {n_seeds} seed{'s' if n_seeds > 1 else ''} = {n_runs} runs in "
             f"{result.n_batches} batch{'es' if result.n_batches > 1 else ''} "
             f"(compile {result.compile_s:.2f} s, run {result.run_s:.2f} s)"]
    shown = printed_metrics(result, metrics)
    lines += table_lines(result, shown)
    notes = [f"mean / max over {n_seeds} seeds"] if n_seeds > 1 else []
    if len(shown) < len(result.metrics):
        where = f"sweep.csv and sweep.json in {out_dir}" if out_dir else "--out DIR writes them"
        notes.append(f"{len(shown)} of {len(result.metrics)} metrics shown; --metrics m1,m2 chooses, {where}")
    if notes:
        lines.append(f"({'; '.join(notes)})")
    return lines
