"""``coopsat tradeoff``: fuel against settling time for formation designs, swept over their
weight and compared at matched settling time (SPEC §4).

For every scenario given and every set of relative coordinates asked for, the controller's
Bryson force scale (``controller.force_scale_n``, the weight that trades speed for fuel) is
swept; the runs of one series share a structure and run as one vmapped batch
(:func:`coopsat.workflows.sweep.run_batch`). Each run's settling time and fuel come from the paper
module's metrics on the exact closed loop (dead zone, saturation, noise, solar pressure), so
the fronts are the tool's honest figures, not a linear model's. Designs are compared by the
fuel of their Pareto fronts at the same settling time
(:func:`coopsat.analysis.tradeoff.matched_saving`).
"""

import json
from pathlib import Path

import numpy as np

from coopsat.core.errors import InputError
from coopsat.analysis.tradeoff import formation_fuel_bound_ns, fuel_on_front, matched_saving, pareto_front
from coopsat.workflows.folders import atomic_folder, check_folder

DEFAULT_SCALES_N = (0.03, 0.04, 0.05, 0.07, 0.1, 0.14, 0.2, 0.3)
"""Force scales swept by default, N (Bryson's acceptable force per axis)."""

PUBLISHED_SAVING_PERCENT = 10.6
"""The paper's fuel saving of the decentralized LMI design against Riccati-LQR (§4.2)."""


TUNED_RADIUS_MAX = 0.999
"""A fuel-tuned gain must keep the sampled closed loop's spectral radius below this: without
it the tuner finds gains that arrive in time and then drift (radius 1.0006 measured), since
the run's horizon is all the fuel objective sees."""


class TradeoffError(InputError):
    """A trade-off that cannot be run as asked (one line)."""


def sweep(ref, scales_n, coordinates, progress=False):
    """Run one series: a scenario in one set of coordinates at every force scale.

    Returns
    -------
    (rows, histories, compile_s, run_s)
        ``rows``: per run, ``scenario``, ``design``, ``coordinates``, ``force_scale_n`` and the
        run's metrics (``settling_time_s``, ``fuel_l1_ns``, ``fuel_l2_ns``, …);
        ``histories``: per run, ``t_s`` and the cumulative fuel against time (``fuel_l1_ns``
        (T, 3) per axis, ``fuel_l2_ns`` (T,)).
    """
    from coopsat.workflows.analyse import analyse
    from coopsat.scenarios.load import load_scenario
    from coopsat.workflows.sweep import run_batch

    kind = load_scenario(ref).controller.kind
    if kind != "formation-observer":
        raise TradeoffError(f"{ref}: tradeoff sweeps a formation-observer controller, this one is {kind}")
    runs, compile_s, run_s = run_batch(
        ref, [[f"controller.force_scale_n={s!r}", f"controller.coordinates={coordinates!r}"] for s in scales_n], progress
    )
    rows, histories = [], []
    for s, (built, ds) in zip(scales_n, runs):
        metrics, _ = analyse(built, ds, compare=False)
        c = built.scenario.controller
        rows.append({"scenario": built.scenario.name, "design": c.design, "coordinates": coordinates, "force_scale_n": float(s), **metrics})
        histories.append({
            "t_s": ds["time"].values,
            "fuel_l1_ns": ds["abs_force_impulse"].values.sum(axis=1),  # (T, 3) per axis
            "fuel_l2_ns": ds["norm_force_impulse"].values.sum(axis=1) if "norm_force_impulse" in ds else None,
        })
    return rows, histories, compile_s, run_s


def _name(ref):
    from coopsat.scenarios.load import load_scenario

    return load_scenario(ref).name


def _finite(v):
    return np.nan if v is None else float(v)


def compare(rows, fuel="fuel_l1_ns"):
    """LMI against LQR at matched settling time, for every pairing of their coordinates.

    Returns
    -------
    list of dict
        ``lmi``/``lqr`` (the coordinates of each side), ``fuel``, and the fields of
        :func:`~coopsat.analysis.tradeoff.matched_saving` (as lists). Same-coordinate pairs
        first: they isolate the gain; the crossed pairs show what the coordinates alone do.
    """
    coords = list(dict.fromkeys(r["coordinates"] for r in rows))
    pairs = [(c, c) for c in coords] + [(a, b) for a in coords for b in coords if a != b]
    out = []
    for ca, cb in pairs:
        a = [r for r in rows if r["coordinates"] == ca and r["design"] == "lmi"]
        b = [r for r in rows if r["coordinates"] == cb and r["design"] == "lqr"]
        if not a or not b:
            continue
        m = matched_saving(
            [_finite(r["settling_time_s"]) for r in a], [_finite(r.get(fuel)) for r in a],
            [_finite(r["settling_time_s"]) for r in b], [_finite(r.get(fuel)) for r in b],
        )
        out.append({"lmi": ca, "lqr": cb, "fuel": fuel, **{k: (list(map(float, v)) if isinstance(v, np.ndarray) else v) for k, v in m.items()}})
    return out


def tune_front(ref, rows, coordinates, max_iter=100, report=None):
    """Tune a linear gain for least L1 fuel at each settling time of an LQR series' front.

    For every front point (force scale s, settling time T) :func:`coopsat.workflows.tune.tune` starts
    from that Riccati gain (decentralized: every spacecraft from its own observer, the LMI
    design's information) and minimises ``fuel_l1_ns`` subject to ``settling_time_s ≤ T`` and
    the closed-loop spectral radius ≤ :data:`TUNED_RADIUS_MAX`, on the smoothed thrusters;
    the figures are the exact re-run's.

    Returns
    -------
    list of dict
        One row per front point: ``scenario`` (the LQR's name + `` (tuned gain)``),
        ``design`` = "tuned", ``coordinates``, ``force_scale_n``, ``start_fuel_l1_ns``,
        ``start_settling_time_s``, ``tune_iterations``, ``tune_s``, and the exact metrics.
    """
    from coopsat.workflows.tune import tune

    series = [r for r in rows if r["design"] == "lqr" and r["coordinates"] == coordinates]
    settle = [_finite(r["settling_time_s"]) for r in series]
    out = []
    for k in pareto_front(settle, [_finite(r.get("fuel_l1_ns")) for r in series]):
        r = series[k]
        res = tune(
            # the settling bound to 6 digits, as the table prints it
            ref, "fuel_l1_ns", {"settling_time_s": float(f"{settle[k]:g}"), "closed_loop_spectral_radius": TUNED_RADIUS_MAX},
            ["controller.gain"], max_iter=max_iter, report=report or (lambda line: None),
            overrides=[f"controller.force_scale_n={r['force_scale_n']!r}", f"controller.coordinates={coordinates!r}",
                       'controller.architecture="decentralized"'],
        )
        out.append({
            **res.metrics_after, "scenario": f"{r['scenario']} (tuned gain)", "design": "tuned", "coordinates": coordinates,
            "force_scale_n": r["force_scale_n"], "start_fuel_l1_ns": r.get("fuel_l1_ns"),
            "start_settling_time_s": settle[k], "tune_iterations": res.iterations,
            "tune_s": res.compile_s + res.optimise_s + res.rerun_s, "tune_warnings": res.warnings,
        })
    return out


def bound_curve(ref, settle_s):
    """The rest-to-rest lower bound on L1 fuel (:func:`formation_fuel_bound_ns`) of a
    scenario's reconfiguration at each settling time, with its thrust limit and tolerance."""
    from coopsat.workflows.pipeline import prepare
    from coopsat.scenarios.load import load_scenario

    built = prepare(load_scenario(ref))
    detail = built.checks["formation-design"].detail
    sc = built.scenario
    f_max = next(a.force_max_n for a in sc.actuator_list if a.kind == "proportional-thrusters")
    disp = detail["target"] - detail["p0"]
    return np.array([formation_fuel_bound_ns(disp, t, sc.spacecraft[0].mass_kg, f_max, sc.analysis.formation_tolerance_m)
                     for t in settle_s])


def tuned_markdown(rows):
    """The tuned gains against LQR (their start) and the LMI at the same settling time, and the
    rest-to-rest bound."""
    tuned = [r for r in rows if r["design"] == "tuned"]
    if not tuned:
        return ""
    lines = [
        "## A gain tuned on the fuel itself (`coopsat tune`)",
        "",
        "LQR minimises a quadratic cost, not fuel. At each settling time of the LQR front a linear gain (same "
        "information as the decentralized design) is tuned by gradient through the closed loop to minimise Σ∫|u| dt, "
        f"with the settling time no later and the closed loop's spectral radius ≤ {TUNED_RADIUS_MAX} (stable beyond "
        "the run). Every figure is an exact re-run. The bound is bang-coast-bang from rest to rest per axis at the "
        "thrust limit (a common translation free): no design can spend less.",
        "",
        "| LQR force scale (N) | settling asked (s) | LQR fuel (N s) | LMI front at that time (N s) | tuned fuel (N s) | "
        "tuned settling (s) | tuned radius | saving vs LQR (%) | bound (N s) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in tuned:
        t = r["start_settling_time_s"]
        lmi = [x for x in rows if x["design"] == "lmi" and x["coordinates"] == r["coordinates"]]
        f_lmi = float(fuel_on_front([_finite(x["settling_time_s"]) for x in lmi], [_finite(x.get("fuel_l1_ns")) for x in lmi], [t])[0]) if lmi else np.nan
        settle = "never" if r["settling_time_s"] is None else f"{r['settling_time_s']:.0f}"
        lines.append(
            f"| {r['force_scale_n']:g} | {t:.0f} | {r['start_fuel_l1_ns']:.4g} | {f_lmi:.4g} | {r['fuel_l1_ns']:.4g} | {settle} | "
            f"{r['closed_loop_spectral_radius']:.5f} | {100 * (1 - r['fuel_l1_ns'] / r['start_fuel_l1_ns']):+.1f} | "
            f"{r['fuel_bound_ns']:.4g} |"
        )
    return "\n".join(lines) + "\n"


def comparison_markdown(rows, comparisons):
    """The verdict on the paper's 10.6 % fuel saving, from the matched comparison."""
    lines = [
        "# Fuel against settling time: LMI (decentralized) vs Riccati-LQR",
        "",
        f"Published (SPEC §4, §4.2 of the paper): the LMI design saves about {PUBLISHED_SAVING_PERCENT} % fuel against "
        "Riccati-LQR. Here each design is swept over its force weight and compared on its Pareto front at the same "
        "settling time (formation error within the scenario's tolerance to the end of the run). A verdict "
        "agrees when the median saving over the overlap is within 3 points of 10.6 %.",
        "",
    ]
    lines += ["| LMI coordinates | LQR coordinates | overlap (s) | median LMI saving (%) | range (%) | verdict on 10.6 % |", "|---|---|---|---|---|---|"]
    for c in comparisons:
        if c["overlap_s"] is None:
            lines.append(f"| {c['lmi']} | {c['lqr']} | none | — | — | not comparable |")
            continue
        p = np.asarray(c["saving_percent"])
        verdict = "agrees" if abs(float(np.median(p)) - PUBLISHED_SAVING_PERCENT) <= 3.0 else "differs"
        lines.append(
            f"| {c['lmi']} | {c['lqr']} | {c['overlap_s'][0]:.0f}–{c['overlap_s'][1]:.0f} | {np.median(p):+.2f} | "
            f"{p.min():+.2f} … {p.max():+.2f} | {verdict} |"
        )
    lines.append("")
    for c in comparisons:
        lines.append(f"## LMI in {c['lmi']} coordinates against LQR in {c['lqr']} coordinates ({c['fuel']})")
        if c["overlap_s"] is None:
            lines += ["", "The fronts do not overlap in settling time: no matched comparison.", ""]
            continue
        lines += ["", "| settling time (s) | LMI fuel (N s) | LQR fuel (N s) | LMI saving (%) |", "|---|---|---|---|"]
        for t, fa, fb, p in zip(c["settle_s"], c["fuel_a"], c["fuel_b"], c["saving_percent"]):
            lines.append(f"| {t:.0f} | {fa:.4g} | {fb:.4g} | {p:+.2f} |")
        lines.append("")
    lines += [
        "Why: on the same quadratic cost and coordinates the LMI's best is the Riccati gain (min trace returns it; "
        "min γ bounds the worst case over the initial-error ball and leaves the gain free among many optima), so a "
        "saving can come only from the coordinates (hub vs orthonormal weights are different costs), the thrust dead "
        "zone and limit, the observer, or the decentralization — not from the LMI itself. Unmatched pairs (one tuned "
        "point each) make any saving appear by choosing a slower design.",
        "",
        "| series | force scale (N) | settling time (s) | fuel L1 (N s) | fuel 2-norm (N s) | final error (m) | on front |",
        "|---|---|---|---|---|---|---|",
    ]
    for key in dict.fromkeys((r["scenario"], r["coordinates"]) for r in rows):
        series = [r for r in rows if (r["scenario"], r["coordinates"]) == key]
        front = set(pareto_front([_finite(r["settling_time_s"]) for r in series], [_finite(r.get("fuel_l1_ns")) for r in series]))
        for k, r in enumerate(series):
            settle = "never" if r["settling_time_s"] is None else f"{r['settling_time_s']:.0f}"
            lines.append(
                f"| {key[0]} ({key[1]}) | {r['force_scale_n']:g} | {settle} | {r.get('fuel_l1_ns', float('nan')):.4g} | "
                f"{r.get('fuel_l2_ns', float('nan')):.4g} | {r['formation_error_final_m']:.3g} | {'yes' if k in front else ''} |"
            )
    return "\n".join(lines) + "\n"


def parse_options(scales, coordinates):
    """``coopsat tradeoff``'s ``--scales`` and ``--coordinates`` (comma-separated text; scales
    None: :data:`DEFAULT_SCALES_N`) as ``(scales_n, coordinates)``.

    Raises
    ------
    TradeoffError
        A scale that is not a number, or an unknown coordinate system.
    """
    try:
        scales_n = [float(v) for v in scales.split(",")] if scales else list(DEFAULT_SCALES_N)
    except ValueError:
        raise TradeoffError(f"--scales {scales}: give comma-separated force scales in N, e.g. 0.01,0.1,1") from None
    coords = tuple(coordinates.split(","))
    bad = [c for c in coords if c not in ("hub", "orthonormal")]
    if bad:
        raise TradeoffError(f"--coordinates: unknown {bad} (known: hub, orthonormal)")
    return scales_n, coords


def run_tradeoff(refs, out_dir, scales_n=DEFAULT_SCALES_N, coordinates=("hub", "orthonormal"), progress=False, figures=True,
                 tune_fuel=False, tune_iter=100, report=None):
    """Sweep every scenario in every coordinates, compare, and write the folder.

    With ``tune_fuel``, every LQR front is also tuned for fuel (:func:`tune_front`) and the
    tuned series and the rest-to-rest bound join the figure and comparison.md.

    Writes ``tradeoff.json`` (every run's metrics and the comparisons), ``comparison.md`` and,
    with ``figures``, ``tradeoff.png`` and ``fuel_time.png`` (fuel against time of every series
    at the sweep's middle force scale, Fig. 5); atomically (nothing half-written on failure).

    Returns
    -------
    (rows, comparisons, compile_s, run_s)
    """
    out_dir = Path(out_dir)
    check_folder(out_dir, "tradeoff.json", "tradeoff", TradeoffError)
    if not scales_n or any(not (s > 0) for s in scales_n):
        raise TradeoffError(f"--scales: force scales must be positive numbers, got {list(scales_n)}")
    rows, middle, compile_s, run_s = [], [], 0.0, 0.0
    for ref in refs:
        for coords in coordinates:
            r, h, c, t = sweep(ref, list(scales_n), coords, progress)
            k = len(r) // 2
            middle.append((r[k], h[k]))
            rows += r
            compile_s += c
            run_s += t
    comparisons = compare(rows)
    bound = None
    if tune_fuel:
        for ref in refs:
            for coords in coordinates:
                rows += tune_front(ref, [r for r in rows if r["scenario"] == _name(ref)], coords, tune_iter, report)
        tuned = [r for r in rows if r["design"] == "tuned"]
        for r in tuned:
            r["fuel_bound_ns"] = float(bound_curve(refs[0], [r["start_settling_time_s"]])[0])
        settle = [r["settling_time_s"] for r in rows if r["settling_time_s"] is not None]
        if settle:
            t = np.linspace(min(settle), max(settle), 40)
            bound = (t, bound_curve(refs[0], t))
    with atomic_folder(out_dir, TradeoffError) as tmp:
        (tmp / "tradeoff.json").write_text(
            json.dumps({"runs": rows, "comparisons": comparisons}, indent=2, default=lambda v: None) + "\n"
        )
        (tmp / "comparison.md").write_text(comparison_markdown([r for r in rows if r["design"] != "tuned"], comparisons)
                                           + tuned_markdown(rows))
        if figures:
            from coopsat.plots.formation import fuel_time_figure, tradeoff_figure

            tradeoff_figure(rows, comparisons, bound=bound).savefig(tmp / "tradeoff.png", dpi=120)
            fuel_time_figure(middle).savefig(tmp / "fuel_time.png", dpi=120)
    return rows, comparisons, compile_s, run_s


def summary_lines(rows, comparisons):
    """What ``coopsat tradeoff`` prints after :func:`run_tradeoff`: each tuned point against
    the LQR point it started from, and each LMI front against the LQR front at matched settling
    time (the paper's 10.6 % claim, SPEC §4)."""
    lines = []
    for r in (r for r in rows if r["design"] == "tuned"):
        settle = "never" if r["settling_time_s"] is None else f"{r['settling_time_s']:.0f} s"
        lines.append(f"  tuned gain ({r['coordinates']}) at LQR {r['force_scale_n']:g} N: fuel {r['fuel_l1_ns']:.4g} N s against "
                     f"LQR's {r['start_fuel_l1_ns']:.4g} (settling {settle}, asked {r['start_settling_time_s']:.0f} s; "
                     f"rest-to-rest bound {r['fuel_bound_ns']:.4g} N s)")
    for c in comparisons:
        what = f"  LMI {c['lmi']:<12} vs LQR {c['lqr']:<12}"
        if c["overlap_s"] is None:
            lines.append(f"{what}: the fronts do not overlap in settling time")
            continue
        p = c["saving_percent"]
        lines.append(f"{what}: at matched settling time {c['overlap_s'][0]:.0f}–{c['overlap_s'][1]:.0f} s the LMI saves "
                     f"{min(p):+.1f} … {max(p):+.1f} % (median {sorted(p)[len(p) // 2]:+.1f} %; published 10.6 %)")
    return lines
