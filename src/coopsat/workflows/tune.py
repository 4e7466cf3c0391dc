"""``coopsat tune``: gradient design through the compiled closed loop.

The scenario fields named by ``--params`` (gains, weights: each plug-in says which of its
fields are continuous and how they enter its part, :class:`coopsat.plugins.Tunable`) become
traced values of one differentiable run (:func:`coopsat.sim.engine.run_samples`). The run's
actuators are replaced by their smooth surrogates where they have one (a dead zone and a
saturation have no useful derivative), and the objective and constraints by their metrics'
smooth stand-ins (:mod:`coopsat.analysis.surrogates`). SciPy's SLSQP minimises the objective
under the constraints with JAX gradients; several starts run as one ``vmap`` and the best
feasible one is kept. The tuned scenario is then re-run on the exact loop and every figure
reported is the exact loop's, beside the surrogate's, so the cost of the surrogate is a number.

Parametrisation: a positive field (a consensus gain, graph weights) is tuned as ``θ0·e^z`` so
that it stays positive; any other (a gain matrix) as ``θ0 + s ⊙ z`` with ``s`` the size of its
entries (at least 5 % of the largest of their column), so that every variable is of order one. The objective is divided
by its value at the scenario's own parameters.

This module is the workflow (options, attempts, exact re-runs, the report and the tune folder);
the differentiable problem is :mod:`coopsat.workflows.tune_problem` and the minimiser
:mod:`coopsat.workflows.tune_minimise`; ``TuneError``, ``Param``, ``resolve_params``,
``with_params``, ``smooth_system``, ``loss_function`` and ``minimise`` are importable from here too.
"""

import json
import re
import time
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from coopsat.analysis.surrogates import surrogates
from coopsat.workflows import interrupt
from coopsat.workflows.folders import atomic_folder, check_folder, json_ready
from coopsat.workflows.analyse import analyse
from coopsat.workflows.pipeline import prepare, simulate_built
from coopsat.workflows.tune_minimise import minimise
from coopsat.workflows.tune_problem import (  # noqa: F401  (Param, with_params: public here too)
    Param,
    TuneError,
    loss_function,
    resolve_params,
    smooth_system,
    split_variables,
    with_params,
)
from coopsat.scenarios.load import ScenarioError, clip_echo, load_scenario, resolved_toml

MARKER = "tune.json"
"""Written into every tune folder: only a folder holding it is replaced by a new tuning."""


LOG_BOUND = 3.0
"""Bound on the variable of a positive field tuned as ``θ0·e^z``: ``|z| ≤ 3``."""


@dataclass(frozen=True)
class Spec:
    """An objective (``bound`` None) or a constraint ``metric <= bound``."""

    metric: str
    bound: float | None = None

    def __str__(self):
        return self.metric if self.bound is None else f"{self.metric}<={self.bound:g}"


def parse_constraint(text):
    """The command line's ``METRIC<=VALUE`` → :class:`Spec` (worded with ``--constraint``)."""
    m = re.fullmatch(r"\s*([A-Za-z0-9_]+)\s*<=\s*([-+0-9.eE]+)\s*", text)
    if not m:
        raise TuneError(f"--constraint {clip_echo(text)}: expected METRIC<=VALUE (e.g. settling_time_s<=4000)")
    try:
        bound = float(m.group(2))
    except ValueError:
        raise TuneError(f"--constraint {clip_echo(text)}: '{clip_echo(m.group(2))}' is not a number") from None
    if not np.isfinite(bound):
        raise TuneError(f"--constraint {clip_echo(text)}: the bound must be finite")
    return Spec(m.group(1), bound)


def constraint_specs(constraints):
    """``{metric: bound}`` (each ``metric <= bound``) or a sequence of :class:`Spec` as a list of
    specs.

    Raises
    ------
    TuneError
        A bound that is not a finite number (one line naming the metric).
    """
    pairs = constraints.items() if isinstance(constraints, Mapping) else ((c.metric, c.bound) for c in constraints)
    specs = []
    for metric, bound in pairs:
        if isinstance(bound, bool) or not isinstance(bound, (int, float)) or not np.isfinite(bound):
            raise TuneError(f"constraint {clip_echo(str(metric))} <= {clip_echo(repr(bound))}: the bound must be a finite "
                            "number")
        specs.append(Spec(str(metric), float(bound)))
    return specs


@dataclass
class TuneResult:
    """What a tuning found, and the exact loop's figures before and after."""

    scenario: str
    params: list
    objective: Spec
    constraints: list
    surrogate_notes: list
    history: list
    best_start: int
    starts: int
    values: dict
    tuned_toml: str
    overrides: list
    exact_before: dict
    exact_after: dict
    surrogate_after: dict
    objective_in_metric_units: bool
    metrics_after: dict
    iterations: int
    compile_s: float
    optimise_s: float
    rerun_s: float
    warnings: list = field(default_factory=list)


def _overrides(params, values):
    """``--set`` strings that put the tuned values into the scenario file."""
    import tomli_w

    out = []
    for p, v in zip(params, values):
        for key, val in p.tunable.write(np.asarray(v)).items():
            text = tomli_w.dumps({"v": val}).strip()[len("v = "):].replace("\n", " ")
            out.append(f"{key if p.tunable.root else p.place + '.' + key}={text}")
    return out


def _exact_metrics(ref, overrides):
    """Metrics of one exact run (the pipeline's, as ``coopsat run`` reports them)."""
    built = prepare(load_scenario(ref, overrides))
    ds, out = simulate_built(built)
    metrics, _ = analyse(built, ds, compare=False)
    return metrics, out.run_s + out.compile_s, built


def tune(ref, objective, constraints=(), params=(), overrides=(), starts=1, spread=0.3, max_iter=50, seed=0,
         polish=1, retries=1, report=print):
    """Tune the named fields of a scenario by gradient, then re-run it exactly.

    Parameters
    ----------
    ref : str
        Bundled scenario name or path.
    objective : str
        Metric to minimise.
    constraints : mapping of str -> float, or sequence of Spec
        Each ``metric <= bound`` (:func:`constraint_specs`).
    params : sequence of str
        Field paths (``controller.alpha``).
    overrides : sequence of str
        ``--set`` assignments applied first.
    starts : int
        Initial points (the scenario's own, then ``starts − 1`` drawn around it with relative
        spread ``spread``), screened together in one ``vmap``.
    polish : int
        How many of the best screened starts SLSQP refines.
    retries : int
        Times to tune again, from the tuned point, when the exact re-run misses a constraint
        the surrogate met (the surrogate's bound lowered by the miss).
    max_iter : int
        SLSQP iterations.
    seed : int
        Seed of the drawn starts.
    report : callable
        Receives one line per iteration.

    Returns
    -------
    TuneResult
    """
    _check_options(starts, max_iter, spread)
    obj_spec = Spec(objective)
    cons_specs = constraint_specs(constraints)
    built = prepare(load_scenario(ref, overrides))
    par = resolve_params(built, params)
    notes = smooth_system(built.system)[1]
    if not 1 <= polish <= starts:
        raise TuneError(f"polish {polish}: must be between 1 and starts ({starts})")
    z0, bounds = _starts(par, starts, spread, seed)
    t0 = time.perf_counter()
    before, _, _ = _exact_metrics(ref, overrides)
    run = _Attempts(rerun_s=time.perf_counter() - t0)
    used = cons_specs
    for attempt in range(1 + retries):
        opt = _optimise(built, par, obj_spec, used, z0, bounds, max_iter, polish, report)
        _rerun(run, opt, attempt, ref, overrides, par)
        missed = [k for k, c in enumerate(cons_specs) if not constraint_met(c, run.after.get(c.metric))]
        if not missed or attempt == retries:
            break
        used = _retighten(run, used, cons_specs, missed)
        z0 = opt.z[opt.best][None]
        polish = 1
        report(run.warnings[-1])
    return _result(built, par, obj_spec, cons_specs, notes, starts, before, run)


def _check_options(starts, max_iter, spread):
    """The options that need no scenario to check."""
    if starts < 1:
        raise TuneError(f"starts {starts}: must be at least 1")
    if max_iter < 1:
        raise TuneError(f"max_iter {max_iter}: must be at least 1")
    if not spread > 0:
        raise TuneError(f"spread {spread}: must be positive")


def _starts(par, starts, spread, seed):
    """The initial variables (starts, n_var) — the scenario's own, then ``starts − 1`` drawn
    around them — and every variable's bounds."""
    n_var = sum(p.size for p in par)
    rng = np.random.default_rng(seed)
    z0 = np.zeros((starts, n_var))
    z0[1:] = spread * rng.standard_normal((starts - 1, n_var))
    # A positive field moves at most a factor e^3 ≈ 20 either way from its start.
    bounds = [(-LOG_BOUND, LOG_BOUND) if p.log else (None, None) for p in par for _ in range(p.size)]
    z0 = np.clip(z0, [lo if lo is not None else -np.inf for lo, _ in bounds], [hi if hi is not None else np.inf for _, hi in bounds])
    return z0, bounds


@dataclass
class _Attempts:
    """What the attempts of one tuning have found so far (the last one's optimum, tuned values
    and exact re-run), and their totals."""

    rerun_s: float
    history: list = field(default_factory=list)
    warnings: list = field(default_factory=list)
    iterations: int = 0
    compile_s: float = 0.0
    optimise_s: float = 0.0
    opt: object = None
    values: list = None
    tuned: list = None
    after: dict = None
    tuned_built: object = None


def _optimise(built, par, obj_spec, used, z0, bounds, max_iter, polish, report):
    """One attempt's minimisation of the surrogate objective under the constraints ``used``,
    one report line per iteration."""
    import jax.numpy as jnp

    f = loss_function(built, par, obj_spec, used)

    def stacked(z):  # (objective, constraints...) of one start
        obj, cons = f(z)
        return jnp.concatenate([obj[None], cons])

    def line(k, v):
        cons = ", ".join(f"{c}: {g:+.3g}" for c, g in zip(used, v[1:]))
        return f"  iter {k:3d}  {obj_spec.metric} surrogate {v[0]:.6g}" + (f"  constraints (≤ 0) {cons}" if used else "")

    def each_iteration(k, v):
        interrupt.check()  # Ctrl-C ends the search between iterations, not after all of them
        report(line(k, v))

    return minimise(stacked, z0, len(used), bounds, max_iter, each_iteration, polish=polish)


def _rerun(run, opt, attempt, ref, overrides, par):
    """Record the attempt's optimum in ``run`` and re-run its tuned values on the exact loop."""
    import jax.numpy as jnp

    run.history += [{**h, "attempt": attempt} for h in opt.history]
    run.iterations, run.compile_s, run.optimise_s = (run.iterations + opt.iterations, run.compile_s + opt.compile_s,
                                                     run.optimise_s + opt.optimise_s)
    run.warnings += opt.warnings
    run.opt = opt
    run.values = [np.asarray(x) for x in split_variables(par, jnp.asarray(opt.z[opt.best]))]
    run.tuned = _overrides(par, run.values)
    t0 = time.perf_counter()
    try:
        run.after, _, run.tuned_built = _exact_metrics(ref, [*overrides, *run.tuned])
    except ScenarioError as err:
        raise TuneError(f"the tuned values do not make a valid scenario: {err}") from None
    run.rerun_s += time.perf_counter() - t0


def _retighten(run, used, cons_specs, missed):
    """The surrogate's constraints for the next attempt, after the exact loop (real dead zone,
    real saturation, the metric's own threshold) missed the ``missed`` ones that the smoothed
    loop met: each asks that much more. Warns in ``run``."""
    after = run.after
    used = [_tightened(u, c, after.get(c.metric)) if k in missed else u for k, (u, c) in enumerate(zip(used, cons_specs))]
    run.warnings.append("exact loop missed " + ", ".join(f"{cons_specs[k]} ({_figure(after.get(cons_specs[k].metric))})" for k in missed)
                        + "; tuned again with the surrogate asked for " + ", ".join(str(used[k]) for k in missed))
    return used


def _result(built, par, obj_spec, cons_specs, notes, starts, before, run):
    """The :class:`TuneResult` of the last attempt."""
    best, v, after, tuned_built = run.opt.best, run.opt.values, run.after, run.tuned_built
    return TuneResult(
        scenario=built.scenario.name, params=[p.path for p in par], objective=obj_spec, constraints=cons_specs,
        surrogate_notes=[surrogates(built)[s.metric].what for s in (obj_spec, *cons_specs)] + notes,
        history=run.history, best_start=int(best), starts=starts,
        values={p.path: np.asarray(x).tolist() for p, x in zip(par, run.values)},
        tuned_toml=resolved_toml(tuned_built.scenario), overrides=run.tuned,
        exact_before={s.metric: before.get(s.metric) for s in (obj_spec, *cons_specs)},
        exact_after={s.metric: after.get(s.metric) for s in (obj_spec, *cons_specs)}, metrics_after=after,
        surrogate_after={"objective": float(v[best, 0]), "constraints": v[best, 1:].tolist()},
        objective_in_metric_units=surrogates(built)[obj_spec.metric].exact_in_metric_units,
        iterations=run.iterations, compile_s=run.compile_s, optimise_s=run.optimise_s, rerun_s=run.rerun_s,
        warnings=[*run.warnings, *(f"tuned scenario: {w}" for w in tuned_built.warnings)],
    )

def _tightened(used, spec, exact):
    """The surrogate's bound for a constraint the exact loop missed: lowered by the excess
    (``exact − bound``), or by 10 % of the bound's size when the exact figure is missing (a
    time never reached)."""
    excess = exact - spec.bound if exact is not None and np.isfinite(exact) else 0.1 * max(abs(spec.bound), 1e-12)
    return Spec(used.metric, used.bound - excess)


def constraint_met(spec, value):
    """The exact loop's figure meets ``metric <= bound`` (None — e.g. never settled — does not)."""
    return value is not None and np.isfinite(value) and value <= spec.bound


def _figure(x):
    """A metric for a report line: ``never`` for a time that was never reached (None)."""
    return "never" if x is None else f"{x:.6g}"


def report_lines(result):
    """The tuning's summary: figures before and after, exact, beside the surrogate's."""
    lines = [f"{result.scenario}: tuned {', '.join(result.params)} in {result.iterations} iterations "
             f"({result.starts} start{'s' if result.starts > 1 else ''}, kept start {result.best_start}; "
             f"compile {result.compile_s:.1f} s, optimise {result.optimise_s:.1f} s, exact re-runs {result.rerun_s:.1f} s)"]
    for s in (result.objective, *result.constraints):
        b, a = result.exact_before[s.metric], result.exact_after[s.metric]
        verdict = "" if s.bound is None else ("  met" if constraint_met(s, a) else "  NOT MET on the exact loop")
        lines.append(f"  {str(s):<32} exact before {_figure(b):>12}  exact after {_figure(a):>12}{verdict}")
    sur, exact = result.surrogate_after["objective"], result.exact_after[result.objective.metric]
    if result.objective_in_metric_units and exact is not None:
        lines.append(f"  surrogate's {result.objective.metric} at the optimum {sur:.6g}, exact loop {exact:.6g} "
                     f"({100 * (sur - exact) / exact:+.2f} %: what the smoothing costs)")
    else:
        lines.append(f"  surrogate objective at the optimum: {sur:.6g} (not in the metric's units: a stand-in criterion)")
    for p, v in result.values.items():
        lines.append(f"  {p} = {np.array2string(np.asarray(v), precision=6, max_line_width=200)}")
    lines += [f"  warning: {w}" for w in result.warnings]
    return lines


def markdown(result):
    """tune.md: what was tuned, on which surrogates, and the exact figures."""
    rows = ["| metric | exact before | exact after | constraint |", "|---|---|---|---|"]
    for s in (result.objective, *result.constraints):
        b, a = result.exact_before[s.metric], result.exact_after[s.metric]
        rows.append(f"| {s.metric} | {_figure(b)} | {_figure(a)} | "
                    f"{'objective' if s.bound is None else ('≤ %g: ' % s.bound) + ('met' if constraint_met(s, a) else 'NOT MET')} |")
    notes = "\n".join(f"- {n}" for n in result.surrogate_notes)
    return (f"# Tuning of {result.scenario}\n\nTuned: {', '.join(result.params)}; {result.iterations} SLSQP iterations, "
            f"{result.starts} start(s), start {result.best_start} kept.\n\nExact closed loop (every figure below is a "
            f"re-run of the scenario, not the surrogate):\n\n" + "\n".join(rows)
            + f"\n\nSurrogates used for the gradient only:\n\n{notes}\n\nSurrogate objective at the optimum: "
            f"{result.surrogate_after['objective']:.6g}; constraints (≤ 0 holds): {result.surrogate_after['constraints']}.\n")


def write_tune_folder(out_dir, result):
    """``tuned.toml`` (the scenario with the tuned values, replayable), ``tune.json`` (the
    path of the optimisation and the figures) and ``tune.md``, atomically."""
    check_folder(out_dir, MARKER, "tune", TuneError)
    with atomic_folder(out_dir, TuneError) as tmp:
        (tmp / "tuned.toml").write_text(result.tuned_toml)
        (tmp / "tune.md").write_text(markdown(result))
        summary = {k: v for k, v in result.__dict__.items() if k != "tuned_toml"}
        summary["objective"] = str(result.objective)
        summary["constraints"] = [str(c) for c in result.constraints]
        (tmp / MARKER).write_text(json.dumps(json_ready(summary), indent=2, allow_nan=False) + "\n")
    return out_dir
