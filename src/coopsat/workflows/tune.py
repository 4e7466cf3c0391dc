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
"""

import json
import re
import time
from dataclasses import dataclass, field, replace

import numpy as np

from coopsat.analysis.surrogates import surrogates
from coopsat.workflows.folders import atomic_folder, check_folder, json_ready
from coopsat.workflows.pipeline import analyse, prepare, simulate_built
from coopsat.plugins import plugin_for
from coopsat.scenarios.build import scenario_tables
from coopsat.scenarios.load import ScenarioError, clip_echo, load_scenario, resolved_toml

MARKER = "tune.json"
"""Written into every tune folder: only a folder holding it is replaced by a new tuning."""


FIRST_STEP = 0.1
"""Length of SLSQP's first step in the scaled variables (10 % of each parameter's size)."""

LOG_BOUND = 3.0
"""Bound on the variable of a positive field tuned as ``θ0·e^z``: ``|z| ≤ 3``."""


class TuneError(ValueError):
    """A tuning that cannot be run as asked (one line)."""


@dataclass(frozen=True)
class Param:
    """One tuned field: where it is, its tunable, and how it is scaled.

    Attributes
    ----------
    path : str
        As given (``controller.alpha``, ``actuators.0.torque_max_nm``).
    place : str
        The table's place in the scenario file as an override prefix (``controller``).
    role : str
    index : int
        Position of the part among the parts of its role.
    name : str
        The table field.
    tunable : coopsat.plugins.Tunable
    log : bool
        Tuned as ``θ0·e^z`` (every entry positive), else ``θ0 + scale·z``.
    scale : ndarray
    """

    path: str
    place: str
    role: str
    index: int
    name: str
    tunable: object
    log: bool
    scale: np.ndarray

    @property
    def size(self):
        return int(np.size(self.tunable.value))

    def value(self, z):
        """The field's value for the variables ``z`` (JAX or NumPy), shape of the field."""
        import jax.numpy as jnp

        v0 = jnp.asarray(self.tunable.value, dtype=float)
        z = jnp.reshape(z, v0.shape)
        return v0 * jnp.exp(z) if self.log else v0 + jnp.asarray(self.scale) * z


@dataclass(frozen=True)
class Spec:
    """An objective (``bound`` None) or a constraint ``metric <= bound``."""

    metric: str
    bound: float | None = None

    def __str__(self):
        return self.metric if self.bound is None else f"{self.metric}<={self.bound:g}"


def parse_constraint(text):
    """``METRIC<=VALUE`` → :class:`Spec`."""
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


def _dotted(place):
    """``actuators[0]`` → ``actuators.0`` (the override syntax)."""
    return re.sub(r"\[(\d+)\]", r".\1", place)


def resolve_params(built, paths):
    """The :class:`Param` of every ``--params`` path.

    Raises
    ------
    TuneError
        A path that names no table, or a field its plug-in does not offer for tuning (the
        message lists the ones it does).
    """
    tables = scenario_tables(built.scenario)
    by_place, counters = {}, {}
    for role, place, table in tables:
        index = counters.get(role, 0)
        counters[role] = index + 1
        dotted = _dotted(place)
        # Also by the names a user writes: `network` for its delivery table, `sensors` for
        # the only sensor; the tuned file is written at the table's own place.
        for alias in {dotted, dotted.replace("network.delivery", "network")}:
            by_place[alias] = (role, index, table, dotted)
        if dotted.endswith(".0") and sum(1 for r, _, _ in tables if r == role) == 1:
            by_place[dotted[:-2]] = (role, index, table, dotted)
    params = []
    for path in paths:
        alias, _, name = path.rpartition(".")
        if alias not in by_place:
            raise TuneError(f"--params {clip_echo(path)}: no table '{clip_echo(alias)}' in this scenario "
                            f"(tables: {', '.join(sorted(by_place))})")
        role, index, table, place = by_place[alias]
        plugin = plugin_for(role, table)
        part = _part(built.system, role, index)
        offered = plugin.tunables(table, built.context, part) if plugin.tunables else {}
        if name not in offered:
            what = ", ".join(f"{alias}.{k}" for k in offered) or "none"
            raise TuneError(f"--params {clip_echo(path)}: {table.kind} cannot tune '{clip_echo(name)}' (tunable here: {what})")
        tunable = offered[name]
        v0 = np.asarray(tunable.value, dtype=float)
        log = bool(np.all(v0 > 0))  # gains and graph weights stay positive
        # Each entry's own size, at least 5 % of the largest of its column (a gain matrix's
        # columns have different units: N/m beside N·s/m, three orders apart here).
        big = np.abs(v0).max(axis=0, keepdims=True) if v0.ndim == 2 else np.abs(v0).max()
        scale = np.maximum(np.abs(v0), 0.05 * np.where(big > 0, big, max(float(np.abs(v0).max()), 1e-12)))
        params.append(Param(path, place, role, index, name, tunable, bool(log), scale))
    if not params:
        raise TuneError("--params: name at least one field to tune")
    if len({p.path for p in params}) != len(params):
        raise TuneError("--params: a field is named twice")
    return params


def _part(system, role, index):
    """The built part of a role (the controller and the network are single)."""
    return getattr(system, role) if role in ("controller", "network") else getattr(system, role + "s")[index]


def with_params(system, params, values):
    """``system`` with every parameter's value in its part (traceable)."""
    for p, v in zip(params, values):
        if p.role in ("controller", "network"):
            system = replace(system, **{p.role: p.tunable.apply(getattr(system, p.role), v)})
        else:
            parts = list(getattr(system, p.role + "s"))
            parts[p.index] = p.tunable.apply(parts[p.index], v)
            system = replace(system, **{p.role + "s": tuple(parts)})
    return system


def smooth_system(system):
    """``system`` with every part that has a smooth surrogate replaced by it, and the notes
    saying what each is."""
    notes = []

    def sub(part):
        make = getattr(part, "surrogate", None)
        if make is None:
            return part
        smooth, note = make()
        notes.append(note)
        return smooth

    system = replace(
        system,
        controller=sub(system.controller),
        actuators=tuple(sub(a) for a in system.actuators),
        sensors=tuple(sub(s) for s in system.sensors),
        disturbances=tuple(sub(d) for d in system.disturbances),
    )
    return system, notes


def _split(params, z):
    """Flat variables → one array per parameter."""
    out, k = [], 0
    for p in params:
        out.append(p.value(z[k: k + p.size]))
        k += p.size
    return out


def loss_function(built, params, objective, constraints, smooth=True):
    """``z -> (objective, constraints (m,))`` of one run: pure JAX, differentiable.

    The objective is the metric's surrogate (not yet normalised); each constraint is ≤ 0 when
    it holds (dimensionless).
    """
    import jax.numpy as jnp

    from coopsat.sim.engine import run_samples

    table = surrogates(built)
    for spec in (objective, *constraints):
        if spec.metric not in table:
            raise TuneError(
                f"'{spec.metric}': no differentiable stand-in for this metric in this scenario "
                f"(metrics that can be tuned on here: {', '.join(sorted(table)) or 'none'})"
            )
        s = table[spec.metric]
        if (spec.bound is None and s.objective is None) or (spec.bound is not None and s.constraint is None):
            raise TuneError(f"'{spec.metric}' can be tuned on only as {'a constraint' if s.objective is None else 'an objective'}")
    system = smooth_system(built.system)[0] if smooth else built.system
    t_s = np.arange(built.n_records + 1) * built.record_interval_s
    n = built.n_records

    def f(z):
        tuned = with_params(system, params, _split(params, z))
        samples = run_samples(tuned, n)
        obj = table[objective.metric].objective(samples, t_s, built, tuned)
        cons = [table[c.metric].constraint(samples, t_s, built, tuned, c.bound) for c in constraints]
        return obj, jnp.stack(cons) if cons else jnp.zeros((0,))

    return f


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


@dataclass
class Optimum:
    """What :func:`minimise` found.

    Attributes
    ----------
    z : ndarray (starts, n_var)
        Final variables of every start.
    values : ndarray (starts, 1 + m)
        Objective and constraints there.
    best : int
        The start kept (:func:`_ranked`).
    history : list of dict
        Per iteration, every start's objective and constraints.
    iterations : int
    compile_s, optimise_s : float
    warnings : list of str
    """

    z: np.ndarray
    values: np.ndarray
    best: int
    history: list
    iterations: int
    compile_s: float
    optimise_s: float
    warnings: list


def minimise(stacked, z0, m, bounds, max_iter=50, report=None, ftol=1e-10, polish=1):
    """Minimise ``stacked(z)[0]`` subject to ``stacked(z)[1:] ≤ 0`` from several starts.

    Every start is screened in one ``jax.vmap`` (values and Jacobians together); SLSQP then
    runs from the ``polish`` best of them (lowest objective among those meeting the
    constraints, then least violation), one after the other, with the Jacobian by reverse
    mode. The objective is divided by its gradient's norm at the first start over
    :data:`FIRST_STEP`. (Stacking every start into one SLSQP problem was tried first: one start
    that meets a bad step stops all of them.)

    Parameters
    ----------
    stacked : callable
        ``z (n_var,) -> (1 + m,)`` JAX function: objective, then constraints.
    z0 : ndarray (starts, n_var)
    m : int
        Number of constraints.
    bounds : list of (lo, hi)
        Per variable (``None``: unbounded).
    report : callable, optional
        ``(iteration, values (1 + m,))`` per iteration of the start being polished.
    polish : int
        How many of the screened starts SLSQP refines.

    Returns
    -------
    Optimum
        ``z``, ``values``: every start's final point and values (those not polished stay at
        their start).
    """
    import jax
    import jax.numpy as jnp
    from scipy.optimize import minimize

    starts, n_var = z0.shape
    both = lambda z: (stacked(z), jax.jacrev(stacked)(z))  # noqa: E731
    t0 = time.perf_counter()
    one = jax.jit(both)
    if starts == 1:  # no screening to do: one compiled program, not two
        vals0, jac0 = (np.asarray(a)[None] for a in one(jnp.asarray(z0[0])))
    else:
        vals0, jac0 = (np.asarray(a) for a in jax.jit(jax.vmap(both))(jnp.asarray(z0)))
        one(jnp.asarray(z0[0]))
    compile_s = time.perf_counter() - t0
    if not (np.all(np.isfinite(vals0[0])) and np.all(np.isfinite(jac0[0]))):
        raise TuneError("the surrogate objective or a constraint is not finite at the scenario's own values")
    vals0 = np.where(np.isfinite(vals0), vals0, np.inf)
    # SLSQP's first step is the negative gradient (its Hessian estimate starts as I): scaled so,
    # that step moves the variables by FIRST_STEP at most, not across the whole stable region.
    norm = max(float(np.linalg.norm(jac0[0, 0])) / FIRST_STEP, 1e-300)
    cache, good = {}, {}

    def evaluate(x):
        key = x.tobytes()
        if key not in cache:
            cache.clear()
            v, j = (np.array(a) for a in one(jnp.asarray(x)))
            if np.all(np.isfinite(v)) and np.all(np.isfinite(j)):
                good["x"] = x.copy()
            else:
                # A step that destabilises the loop gives NaN or inf: report it as far worse
                # than the start, objective and constraints alike, sloping back towards the
                # last point that ran, so that SLSQP has a way out.
                back = x - good.get("x", x)
                v = 1e3 * (np.abs(vals0[0]) + 1.0) + np.sum(back**2)
                j = np.broadcast_to(2.0 * back, j.shape).copy()
            cache[key] = (v, j)
        return cache[key]

    history, z, values, iterations, warnings = [], z0.copy(), vals0.copy(), 0, []
    t0 = time.perf_counter()
    for s in _ranked(vals0)[:polish]:

        seen = []

        def record(x, s=s, seen=seen):
            v = evaluate(x)[0]
            seen.append((x.copy(), v))
            history.append({"start": int(s), "iteration": len(history), "objective": float(v[0]), "constraints": v[1:].tolist()})
            if report is not None:
                report(len(history) - 1, v)

        record(z0[s])
        res = minimize(
            lambda x: float(evaluate(x)[0][0] / norm), z0[s], jac=lambda x: evaluate(x)[1][0] / norm,
            method="SLSQP", bounds=bounds,
            constraints=[{"type": "ineq", "fun": lambda x: -evaluate(x)[0][1:], "jac": lambda x: -evaluate(x)[1][1:]}] if m else [],
            options={"maxiter": max_iter, "ftol": ftol}, callback=record,
        )
        seen.append((res.x, evaluate(res.x)[0]))
        # SLSQP returns its last iterate, which past an iteration limit may be worse than one
        # it has been through (even infeasible after a feasible start): keep the best seen.
        keep = _ranked(np.array([v for _, v in seen]))[0]
        z[s], values[s] = seen[keep]
        iterations += int(res.nit)
        if not res.success:
            warnings.append(f"SLSQP from start {s} stopped: {res.message}")
    return Optimum(
        z=z, values=values, best=_ranked(values)[0], history=history, iterations=iterations,
        compile_s=compile_s, optimise_s=time.perf_counter() - t0, warnings=warnings,
    )


def tune(ref, objective, constraints=(), params=(), overrides=(), starts=1, spread=0.3, max_iter=50, seed=0,
         polish=1, retries=1, report=print):
    """Tune the named fields of a scenario by gradient, then re-run it exactly.

    Parameters
    ----------
    ref : str
        Bundled scenario name or path.
    objective : str
        Metric to minimise.
    constraints : sequence of str
        ``METRIC<=VALUE`` each.
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
    import jax.numpy as jnp

    if starts < 1:
        raise TuneError(f"--starts {starts}: must be at least 1")
    if max_iter < 1:
        raise TuneError(f"--max-iter {max_iter}: must be at least 1")
    if not spread > 0:
        raise TuneError(f"--spread {spread}: must be positive")
    obj_spec = Spec(objective)
    cons_specs = [parse_constraint(c) for c in constraints]
    built = prepare(load_scenario(ref, overrides))
    par = resolve_params(built, params)
    notes = smooth_system(built.system)[1]
    n_var = sum(p.size for p in par)
    m = len(cons_specs)
    if not 1 <= polish <= starts:
        raise TuneError(f"--polish {polish}: must be between 1 and --starts ({starts})")
    rng = np.random.default_rng(seed)
    z0 = np.zeros((starts, n_var))
    z0[1:] = spread * rng.standard_normal((starts - 1, n_var))
    # A positive field moves at most a factor e^3 ≈ 20 either way from its start.
    bounds = [(-LOG_BOUND, LOG_BOUND) if p.log else (None, None) for p in par for _ in range(p.size)]
    z0 = np.clip(z0, [lo if lo is not None else -np.inf for lo, _ in bounds], [hi if hi is not None else np.inf for _, hi in bounds])

    t0 = time.perf_counter()
    before, _, _ = _exact_metrics(ref, overrides)
    rerun_s = time.perf_counter() - t0
    used, history, warnings, iterations, compile_s, optimise_s = cons_specs, [], [], 0, 0.0, 0.0
    for attempt in range(1 + retries):
        f = loss_function(built, par, obj_spec, used)

        def stacked(z, f=f):  # (objective, constraints...) of one start
            obj, cons = f(z)
            return jnp.concatenate([obj[None], cons])

        def line(k, v, used=used):
            cons = ", ".join(f"{c}: {g:+.3g}" for c, g in zip(used, v[1:]))
            return f"  iter {k:3d}  {obj_spec.metric} surrogate {v[0]:.6g}" + (f"  constraints (≤ 0) {cons}" if m else "")

        opt = minimise(stacked, z0, m, bounds, max_iter, lambda k, v: report(line(k, v)), polish=polish)
        history += [{**h, "attempt": attempt} for h in opt.history]
        iterations, compile_s, optimise_s = iterations + opt.iterations, compile_s + opt.compile_s, optimise_s + opt.optimise_s
        warnings += opt.warnings
        best, v = opt.best, opt.values
        values = [np.asarray(x) for x in _split(par, jnp.asarray(opt.z[best]))]
        tuned = _overrides(par, values)
        t0 = time.perf_counter()
        try:
            after, _, tuned_built = _exact_metrics(ref, [*overrides, *tuned])
        except ScenarioError as err:
            raise TuneError(f"the tuned values do not make a valid scenario: {err}") from None
        rerun_s += time.perf_counter() - t0
        missed = [k for k, c in enumerate(cons_specs) if not constraint_met(c, after.get(c.metric))]
        if not missed or attempt == retries:
            break
        # The exact loop (real dead zone, real saturation, the metric's own threshold) missed
        # a constraint the smoothed loop met: ask the surrogate for that much more, from here.
        used = [_tightened(u, c, after.get(c.metric)) if k in missed else u for k, (u, c) in enumerate(zip(used, cons_specs))]
        warnings.append("exact loop missed " + ", ".join(f"{cons_specs[k]} ({_figure(after.get(cons_specs[k].metric))})" for k in missed)
                        + "; tuned again with the surrogate asked for " + ", ".join(str(used[k]) for k in missed))
        z0 = opt.z[best][None]
        polish = 1
        report(warnings[-1])
    return TuneResult(
        scenario=built.scenario.name, params=[p.path for p in par], objective=obj_spec, constraints=cons_specs,
        surrogate_notes=[surrogates(built)[s.metric].what for s in (obj_spec, *cons_specs)] + notes,
        history=history, best_start=int(best), starts=starts,
        values={p.path: np.asarray(x).tolist() for p, x in zip(par, values)},
        tuned_toml=resolved_toml(tuned_built.scenario), overrides=tuned,
        exact_before={s.metric: before.get(s.metric) for s in (obj_spec, *cons_specs)},
        exact_after={s.metric: after.get(s.metric) for s in (obj_spec, *cons_specs)}, metrics_after=after,
        surrogate_after={"objective": float(v[best, 0]), "constraints": v[best, 1:].tolist()},
        objective_in_metric_units=surrogates(built)[obj_spec.metric].exact_in_metric_units,
        iterations=iterations, compile_s=compile_s, optimise_s=optimise_s, rerun_s=rerun_s,
        warnings=[*warnings, *(f"tuned scenario: {w}" for w in tuned_built.warnings)],
    )


def _tightened(used, spec, exact):
    """The surrogate's bound for a constraint the exact loop missed: lowered by the excess
    (``exact − bound``), or by 10 % of the bound's size when the exact figure is missing (a
    time never reached)."""
    excess = exact - spec.bound if exact is not None and np.isfinite(exact) else 0.1 * max(abs(spec.bound), 1e-12)
    return Spec(used.metric, used.bound - excess)


def _ranked(values):
    """Starts from best to worst: those meeting every constraint by objective, then the rest
    by total violation. ``values``: (starts, 1 + m)."""
    violation = np.maximum(values[:, 1:], 0.0).sum(axis=1) if values.shape[1] > 1 else np.zeros(len(values))
    feasible = violation <= 1e-6
    order = np.lexsort((values[:, 0], np.where(feasible, 0.0, violation), ~feasible))
    return [int(k) for k in order]


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
