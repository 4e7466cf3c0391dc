"""Paired runs: two scenarios on the same seeds, so that what differs between them is their
design, not their luck (``coopsat pair A B``; SPEC §5).

Every random draw of a run comes from its seed through a fixed sub-stream per part
(docs/architecture.md §4), so two scenarios with the same sensors and disturbances, run on the
same seed, see the same noise and disturbance realisations. :func:`run_pair` checks that the two
share them (otherwise the pairing would be a claim, not a fact), runs each scenario on seeds
``seed … seed + K − 1`` as one vmapped batch, and compares:

* every scalar metric both runs have, per seed, with the paired difference B − A;
* every time series both runs have, as B − A over time per seed, in ``pair.nc``: those a paper
  module names in ``PAIRED_SERIES`` (e.g. the relative attitude error) and the run's catalogue
  (:func:`coopsat.analysis.series.run_series`) of one value per spacecraft or per formation at
  each sample (attitude errors, spreads, effort, fuel, wheel momentum; a vector's components
  are left to the run's own figures). Series only one of the two runs has are named, not
  compared; with none in common no time-series file is written.
"""

import json
from dataclasses import dataclass

import numpy as np

from coopsat.core.errors import InputError
from coopsat.analysis.papers import member, paper_modules
from coopsat.analysis.series import run_series
from coopsat.workflows.folders import atomic_folder, check_folder, json_ready
from coopsat.workflows.analyse import analyse
from coopsat.scenarios.load import load_scenario
from coopsat.workflows.sweep import run_batch

MARKER = "pair.json"
"""Written into every pair folder: only a folder holding it is ever replaced."""

SHARED_TABLES = ("sensors", "disturbances", "spacecraft", "orbit", "sim")
"""What two scenarios must share for their runs on one seed to be paired."""


class PairError(InputError):
    """Two scenarios that cannot be paired, or a bad pair folder (one line)."""


@dataclass
class PairResult:
    """Two scenarios' runs on the same seeds.

    Attributes
    ----------
    names : (str, str)
        Scenario names A and B.
    seeds : list of int
    metrics : list of (dict, dict)
        Per seed, A's and B's metrics.
    series : dict of str -> (DataArray, DataArray)
        Per paired series, A's and B's values, dims ``(seed, time[, spacecraft])``.
    compile_s, run_s : float
    unpaired : (list of str, list of str)
        Time series only A has, and only B has (not compared).
    """

    names: tuple
    seeds: list
    metrics: list
    series: dict
    compile_s: float
    run_s: float
    unpaired: tuple = ((), ())

    def series_lines(self):
        """What the pair says of its time series: those compared (B − A in pair.nc), those only
        one run has, or that there are none in common (then no pair.nc and no pair.png)."""
        a, b = self.names
        lines = [f"time series B − A: {', '.join(self.series)}" if self.series else
                 "time series: none that both runs have (no pair.nc, no pair.png)"]
        lines += [f"  only in {who}: {', '.join(names)}" for who, names in zip((a, b), self.unpaired) if names]
        return lines

    def common_metrics(self):
        """Scalar metrics that both scenarios report in every seed, sorted."""
        keys = None
        for a, b in self.metrics:
            both = {k for k in a if k in b and _number(a[k]) is not None and _number(b[k]) is not None}
            keys = both if keys is None else keys & both
        return sorted(keys or ())

    def table(self):
        """Per common metric: A and B (mean over seeds) and the paired difference B − A (mean, min, max)."""
        rows = []
        for key in self.common_metrics():
            a = np.array([float(m[key]) for m, _ in self.metrics])
            b = np.array([float(m[key]) for _, m in self.metrics])
            d = b - a
            rows.append({"metric": key, "a": a.tolist(), "b": b.tolist(), "a_mean": a.mean(), "b_mean": b.mean(),
                         "diff_mean": d.mean(), "diff_min": d.min(), "diff_max": d.max()})
        return rows


def table_lines(result, metrics=None):
    """What ``coopsat pair`` prints: the header and, per common metric (or those named in
    ``metrics``), A and B (mean over seeds) and the paired difference B − A."""
    a, b = result.names
    n = len(result.seeds)
    lines = [f"{a} vs {b}: {n} seed{'s' if n > 1 else ''} each (compile {result.compile_s:.2f} s, run {result.run_s:.2f} s)"]
    shown = [r for r in result.table() if not metrics or r["metric"] in metrics]
    width = max((len(r["metric"]) for r in shown), default=6)
    lines.append(f"{'metric':<{width}}  {'A (mean)':>12}  {'B (mean)':>12}  {'B - A':>12}")
    lines += [f"{r['metric']:<{width}}  {r['a_mean']:>12.6g}  {r['b_mean']:>12.6g}  {r['diff_mean']:>12.6g}" for r in shown]
    return lines + result.series_lines()


def _number(v):
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        return None
    return float(v) if np.isfinite(v) else None


def check_paired(scenario_a, scenario_b):
    """Raise :class:`PairError` unless the two scenarios share :data:`SHARED_TABLES` exactly."""
    for table in SHARED_TABLES:
        a, b = getattr(scenario_a, table), getattr(scenario_b, table)
        dump = (lambda v: [x.model_dump() for x in v]) if isinstance(a, list) else (lambda v: v and v.model_dump())
        if dump(a) != dump(b):
            raise PairError(
                f"{scenario_a.name} and {scenario_b.name} differ in [{table}]: on one seed they would not see the same "
                "noise and disturbances; a paired run needs them equal"
            )


def paired_series_names(built):
    """The series the run's paper modules name in ``PAIRED_SERIES``."""
    names = []
    for module in paper_modules(built):
        names += [n for n in member(module, "PAIRED_SERIES") if n not in names]
    return names


def pairable_series(built, ds):
    """``{name: DataArray}`` of one run that a pair compares over time: its papers'
    ``PAIRED_SERIES`` it recorded, then its catalogue series of one value per spacecraft or per
    formation (``log_scale`` 0/1 in their attrs, for the figure)."""
    out = {n: ds[n] for n in paired_series_names(built) if n in ds}
    for s in run_series(ds, built.scenario.analysis):
        if s.values.dims in (("time",), ("time", "spacecraft")):
            out[s.name] = s.values.assign_attrs(log_scale=int(s.log_scale))
    return out


def run_pair(ref_a, ref_b, n_seeds=3, overrides=(), progress=False):
    """Run two scenarios on the same seeds (module docstring).

    Parameters
    ----------
    ref_a, ref_b : str or Path
        Bundled scenario names or TOML paths.
    n_seeds : int
        Seeds ``seed(A) … seed(A) + n_seeds − 1``, the same for B.
    overrides : iterable of str
        ``key.path=value`` applied to both.
    progress : bool

    Returns
    -------
    PairResult
    """
    import xarray as xr

    if n_seeds < 1:
        raise PairError(f"seeds {n_seeds}: must be at least 1")
    scenario_a, scenario_b = load_scenario(ref_a, overrides), load_scenario(ref_b, overrides)
    check_paired(scenario_a, scenario_b)
    seeds = [scenario_a.seed + k for k in range(n_seeds)]
    lists = [[*overrides, f"seed={s}"] for s in seeds]
    runs_a, ca, ra = run_batch(ref_a, lists, progress)
    runs_b, cb, rb = run_batch(ref_b, lists, progress)
    metrics = [(analyse(ba, da, compare=False)[0], analyse(bb, db, compare=False)[0])
               for (ba, da), (bb, db) in zip(runs_a, runs_b)]
    per_run = [[pairable_series(built, ds) for built, ds in runs] for runs in (runs_a, runs_b)]
    # A series counts only if every seed of a run has it (a catalogue leaves out all-zero series).
    have = [set.intersection(*(set(s) for s in run)) for run in per_run]
    names = [n for n in per_run[0][0] if n in have[0] & have[1]]
    series = {
        n: tuple(xr.concat([s[n] for s in run], dim="seed").assign_coords(seed=seeds) for run in per_run) for n in names
    }
    unpaired = tuple([n for n in per_run[k][0] if n in have[k] - have[1 - k]] for k in (0, 1))
    return PairResult((scenario_a.name, scenario_b.name), seeds, metrics, series, ca + cb, ra + rb, unpaired)


def _fmt(v):
    return "—" if v is None else f"{v:.6g}"


def markdown(result):
    """pair.md: the paired comparison table."""
    a, b = result.names
    lines = [
        f"# Paired runs: {b} against {a}",
        "",
        f"Seeds {', '.join(str(s) for s in result.seeds)}: each seed gives both scenarios the same sensor noise and "
        "disturbance realisations, so B − A isolates the difference of design.",
        "",
        f"| metric | {a} (mean) | {b} (mean) | B − A mean | B − A min … max |",
        "|---|---|---|---|---|",
    ]
    for row in result.table():
        lines.append(f"| `{row['metric']}` | {_fmt(row['a_mean'])} | {_fmt(row['b_mean'])} | {_fmt(row['diff_mean'])} | "
                     f"{_fmt(row['diff_min'])} … {_fmt(row['diff_max'])} |")
    lines += ["", "## Time series", ""] + [f"- {line.strip()}" for line in result.series_lines()]
    return "\n".join(lines) + "\n"


def write_pair_folder(out_dir, result, figure=None):
    """Write pair.json, pair.md and, when the runs have time series in common, pair.nc (the
    paired series and B − A) and pair.png, atomically."""
    import xarray as xr

    with atomic_folder(out_dir, PairError) as tmp:
        a, b = result.names
        data = {}
        for name, (sa, sb) in result.series.items():
            data[f"{name}_a"] = sa
            data[f"{name}_b"] = sb
            data[f"{name}_b_minus_a"] = (sb - sa).assign_attrs(sa.attrs, long_name=f"{sa.attrs.get('long_name', name)}: B − A")
        if data:
            xr.Dataset(data, attrs={"scenario_a": a, "scenario_b": b}).to_netcdf(tmp / "pair.nc", engine="h5netcdf")
        (tmp / "pair.md").write_text(markdown(result), encoding="utf-8")
        if figure is not None and data:
            figure.savefig(tmp / "pair.png", dpi=110)
        summary = {"scenario_a": a, "scenario_b": b, "seeds": result.seeds, "metrics": result.table(),
                   "compile_s": result.compile_s, "run_s": result.run_s}
        (tmp / MARKER).write_text(json.dumps(json_ready(summary), indent=1), encoding="utf-8")


def check_pair_folder(out_dir):
    """Refuse, before anything runs, a target that is not a pair folder."""
    check_folder(out_dir, MARKER, "pair", PairError)

