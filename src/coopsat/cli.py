"""Command line: ``coopsat list|show|validate|run|sil|report|export|plot|margin|design|topology|tradeoff|sweep|pair|tune|campaign|bench``.

Parses arguments and calls the pipeline's stages; nothing else. Bad input (a wrong scenario,
a graph that cannot do what is asked, a state that turns non-finite) prints one line on stderr
and exits with status 2, without a traceback and without leaving a half-written run folder. A
stage after the simulation that fails (a plug-in's metrics, the figures, the report) prints one
line naming it and exits with status 3, its run folder written without what that stage makes.
"""

import argparse
import os
import signal
import sys
import threading
import warnings

from coopsat.core.errors import CoopsatError, StageFailedError

EXIT_BAD_INPUT = CoopsatError.exit_status
EXIT_STAGE_FAILED = StageFailedError.exit_status
EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 143
EXIT_BROKEN_PIPE = 141


_process_configured = False


def configure_process(cache=True):
    """Set up the command's own process (and the test suite's): XLA's CPU options, the persistent
    compilation cache (:func:`coopsat.core.runtime.process_environment`), xarray's Dask check
    without ``dask.array`` (:mod:`coopsat.core.lazy_dask`). Idempotent; never at library import.

    Call before the first computation (XLA reads ``XLA_FLAGS`` when its CPU backend starts); JAX
    is not imported here (``coopsat list`` stays quick): unloaded, it reads the cache settings from
    ``JAX_*`` variables. float64 follows at the first build or run."""
    from coopsat.core import lazy_dask, runtime

    global _process_configured
    if _process_configured:
        return
    _process_configured = True
    jax_loaded = "jax" in sys.modules
    os.environ.update(runtime.process_environment(cache=cache and not jax_loaded))
    if cache and jax_loaded:
        for name, value in runtime.cache_settings().items():
            sys.modules["jax"].config.update(name, value)
    lazy_dask.install()


def _print_catalogue(names, description):
    """One line per bundled name, its description aligned after it."""
    width = max(len(n) for n in names)
    for name in names:
        print(f"{name:<{width}}  {description(name)}")
    return 0


def _cmd_list(args):
    from coopsat.scenarios.catalogue import bundled_names, description

    return _print_catalogue(bundled_names(), description)


def _cmd_show(args):
    from pathlib import Path

    from coopsat.scenarios.load import bundled_text, load_scenario, read_scenario_text, resolved_toml

    if args.resolved:
        print(resolved_toml(load_scenario(args.name)), end="")
    elif args.name.endswith(".toml") or len(Path(args.name).parts) > 1:
        print(read_scenario_text(Path(args.name)), end="")
    else:
        print(bundled_text(args.name), end="")
    return 0


def _cmd_validate(args):
    from coopsat.workflows.pipeline import prepare
    from coopsat.scenarios.load import load_scenario

    scenario = load_scenario(args.scenario, args.set)
    built = prepare(scenario)
    for note in built.warnings:
        print(f"warning: {note}", file=sys.stderr)
    print(
        f"ok: {scenario.name}: {len(built.names)} spacecraft, controller {scenario.controller.kind}, "
        f"actuators {', '.join(a.kind for a in scenario.actuator_list)}, "
        f"{built.n_records + 1} samples over {scenario.sim.t_final_s:g} s"
    )
    return 0


def _print(lines):
    for line in lines:
        print(line)


def _cmd_run(args):
    from coopsat.workflows.pipeline import REPORT_FILE, run_scenario, summary_lines

    result = run_scenario(
        args.scenario,
        out_dir=args.out,
        overrides=args.set,
        progress=not args.quiet,
        figures=bool(args.figures),
        on_warning=lambda note: print(f"warning: {note}", file=sys.stderr),
        allow_long=args.allow_long,
        report=not args.no_report,
    )
    print(f"wrote {result.out_dir}  (compile {result.compile_s:.2f} s, run {result.run_s:.2f} s)")
    if not args.quiet:
        _print(summary_lines(result))
    if not args.no_report:  # the last line: where to look
        print(f"report: {result.out_dir / REPORT_FILE}")
    return 0


def _cmd_sil(args):
    from coopsat.workflows.sil.run import parse_externals, parse_fault, sil_command

    return sil_command(
        args.scenario, out_dir=args.out, overrides=args.set, kill=[parse_fault(f, "kill") for f in args.kill],
        pause=[parse_fault(f, "pause") for f in args.pause], externals=parse_externals(args.external),
        fault_command=args.fault_command, realtime=args.realtime, answer_s=args.answer_timeout,
        handshake_s=args.start_timeout, figures=bool(args.figures), report=not args.no_report, quiet=args.quiet,
        err=lambda line: print(line, file=sys.stderr, flush=True))


def _cmd_report(args):
    from coopsat.api import report

    print(f"wrote {report(args.run_dir, args.out)}")
    return 0


def _cmd_export(args):
    from coopsat.api import export

    print(f"wrote {export(args.run_dir, args.format, args.out)}")
    return 0


def _cmd_plot(args):
    from coopsat.api import plot

    print(f"wrote {', '.join(str(p) for p in plot(args.run_dir, what=args.what, out=args.out))}")
    return 0


def _cmd_margin(args):
    from coopsat.workflows.delay_gain import margin_lines

    _print(margin_lines(args.scenario, args.set))
    return 0


def _cmd_design_delay_gain(args):
    from coopsat.workflows.delay_gain import analyse_lines, design_gain_scenario, progress_text
    from coopsat.workflows.stage_lines import StageLines

    if args.analyse:
        _print(analyse_lines(args.scenario, args.set))
        return 0
    stages = None if args.quiet else StageLines(sys.stderr, progress_text, prefix="design: ")
    try:
        result = design_gain_scenario(args.scenario, args.set, h=args.h, out=args.out,
                                      max_evaluations=args.max_evaluations, progress=stages)
    finally:
        if stages is not None:
            stages.close()  # a terminal's progress line ends before the result or the error
    _print(result)
    return 0


def _cmd_topology(args):
    from coopsat.workflows.topology import compare_topologies, table_lines

    rows = compare_topologies(args.graphs, args.nodes, args.link_reliability, args.monte_carlo)
    _print(table_lines(rows, args.nodes, args.link_reliability))
    return 0


def _cmd_tradeoff(args):
    from coopsat.workflows.deep_space_tradeoff import parse_options, run_tradeoff, summary_lines

    scales, coords = parse_options(args.scales, args.coordinates)
    out = args.out or "runs/tradeoff"
    report = (lambda line: None) if args.quiet else (lambda line: print(line, file=sys.stderr, flush=True))
    rows, comparisons, compile_s, run_s = run_tradeoff(args.scenarios, out, scales, coords, progress=not args.quiet,
                                                       tune_fuel=args.tune_fuel, tune_iter=args.tune_iter, report=report)
    print(f"wrote {out}  ({len(rows)} runs; compile {compile_s:.2f} s, run {run_s:.2f} s)")
    _print(summary_lines(rows, comparisons))
    print(f"  (comparison.md, tradeoff.png in {out})")
    return 0


def _cmd_sweep(args):
    from coopsat.workflows.sweep import parse_plot, parse_vary, run_sweep, summary_lines

    varies = [parse_vary(spec) for spec in args.vary]
    metrics = list(dict.fromkeys(m.strip() for m in args.metrics.split(","))) if args.metrics is not None else None
    plots = [parse_plot(spec) for spec in args.plot]
    result = run_sweep(args.scenario, varies, n_seeds=args.seeds, metrics=metrics, overrides=args.set,
                       out_dir=args.out, plots=plots, progress=not args.quiet)
    _print(summary_lines(result, args.scenario, args.seeds, metrics, args.out))
    if args.out:
        print(f"wrote {args.out}")
    return 0


def _cmd_pair(args):
    from coopsat.workflows.pair import check_pair_folder, run_pair, table_lines, write_pair_folder

    if args.out:
        check_pair_folder(args.out)  # before the runs, not after
    result = run_pair(args.a, args.b, n_seeds=args.seeds, overrides=args.set, progress=not args.quiet)
    _print(table_lines(result, args.metrics.split(",") if args.metrics else None))
    if args.out:
        from coopsat.plots.pair import pair_figure

        write_pair_folder(args.out, result, pair_figure(result.names, result.series) if result.series else None)
        print(f"wrote {args.out}/pair.md, {'pair.nc, pair.png, ' if result.series else ''}pair.json")
    return 0


def _cmd_tune(args):
    from pathlib import Path

    from coopsat.workflows.tune import MARKER, TuneError, check_folder, parse_constraint, report_lines, tune, write_tune_folder

    out = Path(args.out) if args.out else None
    if out is not None:
        check_folder(out, MARKER, "tune", TuneError)  # before minutes of work, not after
    report = (lambda line: None) if args.quiet else (lambda line: print(line, file=sys.stderr, flush=True))
    constraints = [parse_constraint(c) for c in args.constraint]
    result = tune(args.scenario, args.objective, constraints, args.params, overrides=args.set, starts=args.starts,
                  spread=args.spread, max_iter=args.max_iter, seed=args.seed, polish=args.polish, report=report)
    _print(report_lines(result))
    if out is not None:
        write_tune_folder(out, result)
        print(f"wrote {out}/tuned.toml, tune.md, tune.json")
    return 0


def _cmd_campaign_list(args):
    from coopsat.workflows.campaign.catalogue import bundled_names, description

    return _print_catalogue(bundled_names(), description)


def _cmd_campaign_run(args):
    from coopsat.workflows.campaign.runner import run_campaign
    from coopsat.workflows.campaign.spec import CampaignError

    if args.workers is not None and args.workers < 1:
        raise CampaignError(f"--workers {args.workers}: must be at least 1")
    out = run_campaign(args.file, args.out, workers=args.workers, scheduler=args.scheduler, progress=not args.quiet)
    print(f"{args.file}: {out['runs']} runs in {out['batches']} batches ({out['skipped_batches']} already on disk); "
          f"{out['failed']} failed in this call; {out['wall_s']:.1f} s; results in {args.out}/batches")
    for note in out["build_notes"]:
        print(f"batches: {note}")
    return 0


def _cmd_campaign_replay(args):
    from coopsat.workflows.campaign.runner import replay

    result = replay(args.dir, args.run_id)
    print("\n".join(result.report_lines))
    return 0 if result.identical else 1


def _cmd_campaign_report(args):
    from coopsat.workflows.campaign.report import write_report

    print(f"wrote {write_report(args.dir)}")
    return 0


def _cmd_bench(args):
    from coopsat.workflows.bench import run_benchmarks

    return run_benchmarks(args.sizes, args.steps, args.batch, not args.no_native, args.orbit_sizes) or 0


_SET_HELP = "override a field before validation, e.g. --set controller.period_s=0.01 (repeatable)"


def _set_option(parser, applied=""):
    """The ``--set KEY.PATH=VALUE`` option every scenario command takes (``applied``: to which
    runs, for the help)."""
    parser.add_argument("--set", action="append", default=[], metavar="KEY.PATH=VALUE", help=_SET_HELP + applied)


def _add_list(sub):
    sub.add_parser("list", help="list the bundled scenarios").set_defaults(func=_cmd_list)


def _add_show(sub):
    show = sub.add_parser("show", help="print a scenario's TOML (bundled name or file)")
    show.add_argument("name")
    show.add_argument("--resolved", action="store_true", help="with every default filled in and 'extends' resolved")
    show.set_defaults(func=_cmd_show)


def _add_validate(sub):
    val = sub.add_parser("validate", help="validate a scenario (file or bundled name) and run its design checks")
    val.add_argument("scenario")
    _set_option(val)
    val.set_defaults(func=_cmd_validate)


def _add_run(sub):
    run = sub.add_parser("run", help="run a scenario and write its run folder")
    run.add_argument("scenario", help="bundled scenario name or path to a .toml file")
    run.add_argument("--out", help="run folder (default runs/<scenario name>)")
    _set_option(run)
    run.add_argument("--figures", action=argparse.BooleanOptionalAction, help="also draw the PNG figures (or: coopsat plot)")
    run.add_argument("--no-report", action="store_true", help="skip report.html (the interactive report)")
    run.add_argument("--quiet", "-q", action="store_true", help="no progress bar, no metrics on stdout")
    run.add_argument("--allow-long", action="store_true", help="run even when the estimated wall time is above 30 min")
    run.set_defaults(func=_cmd_run)


def _add_sil(sub):
    from coopsat.workflows.sil.options import DESCRIPTION, OPTIONS  # data only: coopsat list stays quick
    sil = sub.add_parser("sil", help=DESCRIPTION.split(";")[0], description=DESCRIPTION)
    for flags, options in OPTIONS:
        sil.add_argument(*flags, **options)
    _set_option(sil)
    sil.set_defaults(func=_cmd_sil)


def _add_report(sub):
    rep = sub.add_parser(
        "report", help="make a run folder's report.html again (3D view, network, time series, checks, metrics)",
        description="Write the interactive report of a run folder from its result.nc, metrics and comparison: one "
                    "self-contained HTML file that works offline (docs/report.md).")
    rep.add_argument("run_dir", help="a run folder written by coopsat run")
    rep.add_argument("--out", metavar="FILE.html", help="the file to write (default RUN_DIR/report.html)")
    rep.set_defaults(func=_cmd_report)


def _add_export(sub):
    exp = sub.add_parser(
        "export", help="write a run folder as a CCSDS OEM (orbits), a CCSDS AEM (attitudes) or a CZML scene",
        description="Write a run folder's states in a standard format (docs/export.md): oem, CCSDS OEM 2.0 of the "
                    "positions and velocities (the run's frame and clock: GCRF, TT; km); aem, CCSDS AEM 1.0 of the attitude quaternions "
                    "(inertial to SC_BODY_1, A2B, scalar first); czml, a Cesium scene of an Earth orbit. A CCSDS "
                    "message holds one spacecraft: a formation's OEM or AEM is a folder of one file per spacecraft.")
    exp.add_argument("run_dir", help="a run folder written by coopsat run")
    # No argparse choices: the formats are coopsat.exports.FORMATS, which the parser does not
    # import (coopsat list stays quick); an unknown one is a one-line error from the export.
    exp.add_argument("--format", required=True, metavar="oem|aem|czml", help="the format to write")
    exp.add_argument("--out", metavar="PATH",
                     help="the file (a folder for an OEM or AEM of several spacecraft); default RUN_DIR/<scenario>.<format> "
                          "or RUN_DIR/<scenario>-<format>/")
    exp.set_defaults(func=_cmd_export)


def _add_plot(sub):
    plt = sub.add_parser(
        "plot", help="draw a run folder's figures again from its result.nc",
        description="Redraw the figures of a run folder (the standard ones and its papers') from result.nc and the "
                    "scenario kept in it; no simulation is run.")
    plt.add_argument("run_dir", help="a run folder written by coopsat run")
    plt.add_argument("--what", nargs="+", metavar="NAME",
                     help="figures to draw, by file stem (attitude, rates, torque_sat1, …); default all")
    plt.add_argument("--out", metavar="DIR", help="folder for the PNG files (default RUN_DIR)")
    plt.set_defaults(func=_cmd_plot)


def _add_margin(sub):
    margin = sub.add_parser("margin", help="exact constant-delay margin of a scenario's delayed consensus law")
    margin.add_argument("scenario")
    _set_option(margin)
    margin.set_defaults(func=_cmd_margin)


def _add_design(sub):
    design_p = sub.add_parser("design", help="design-time synthesis")
    design_sub = design_p.add_subparsers(dest="what", required=True)
    dg = design_sub.add_parser(
        "delay-gain", help="gain certified by a delay-dependent LMI for time-varying delay up to h (leader-follower)",
        description="Search the gain K = [k_angle, k_rate] whose certified decay rate at the delay bound h is largest "
                    "(a minute), and write it as a scenario that extends the one given. Progress goes to stderr (a "
                    "line per stage and per tenth of the search); the result to stdout, its last line 'wrote FILE'.")
    dg.add_argument("scenario")
    dg.add_argument("--h", type=float, help="delay bound to certify, s (default: the network's largest single-hop delay)")
    dg.add_argument("--analyse", action="store_true", help="no synthesis: the largest h the LMI certifies for the scenario's K")
    dg.add_argument("--out", metavar="FILE.toml",
                    help="the scenario file written, the only one (default <scenario>-delay-gain.toml in the current "
                         "folder); the last line printed is 'wrote FILE'")
    dg.add_argument("--max-evaluations", type=int, default=100, metavar="N",
                    help="gains the search evaluates at most, about a second each (default 100; it stops sooner "
                         "when it converges)")
    dg.add_argument("--quiet", "-q", action="store_true", help="no progress lines on stderr")
    _set_option(dg)
    dg.set_defaults(func=_cmd_design_delay_gain)


def _add_topology(sub):
    topo = sub.add_parser("topology", help="compare communication graphs: path length, reliability, connectivity")
    topo.add_argument("graphs", nargs="+", metavar="GRAPH",
                      help="star, ring, mesh, chain; a scenario (its network); or an adjacency file (.csv or .txt)")
    topo.add_argument("--nodes", type=int, default=4, help="nodes of a named graph (default 4)")
    topo.add_argument("--link-reliability", type=float, default=0.8, help="probability that a link works (default 0.8)")
    topo.add_argument("--monte-carlo", type=int, metavar="K", help="estimate reliability from K random link states")
    topo.set_defaults(func=_cmd_topology)


def _add_tradeoff(sub):
    trade = sub.add_parser("tradeoff", help="fuel against settling time of formation designs, swept over their weight (SPEC §4)")
    trade.add_argument("scenarios", nargs="+", metavar="SCENARIO", help="formation-observer scenarios (e.g. the -lmi and -lqr pair)")
    trade.add_argument("--scales", help="comma-separated Bryson force scales to sweep, N (default 0.03 … 0.3)")
    trade.add_argument("--coordinates", default="hub,orthonormal", help="relative coordinates to sweep (default hub,orthonormal)")
    trade.add_argument("--out", help="output folder (default runs/tradeoff)")
    trade.add_argument("--tune-fuel", action="store_true",
                       help="also tune a gain for least fuel at each settling time of the LQR front (coopsat tune; minutes per point)")
    trade.add_argument("--tune-iter", type=int, default=100, help="SLSQP iterations per tuned point (default 100)")
    trade.add_argument("--quiet", "-q", action="store_true", help="no progress bar")
    trade.set_defaults(func=_cmd_tradeoff)


def _add_sweep(sub):
    sweep = sub.add_parser(
        "sweep", help="run a scenario over values of any field(s) and tabulate its metrics",
        description="Run a scenario once per value of one or more fields and tabulate its metrics. Several --vary "
                    "with the same number of values are zipped: run k takes the k-th value of each (no cross product). "
                    "Runs that share a compiled structure run as one vmapped batch; each run's metrics are those of "
                    "coopsat run with the same --set.")
    sweep.add_argument("scenario", help="bundled scenario name or path to a .toml file")
    sweep.add_argument("--vary", action="append", required=True, metavar="FIELD=V1,V2,...",
                       help="field and the values it takes, each a --set value (e.g. controller.period_s=0.01,0.02 or "
                            "spacecraft.0.omega_b_rad_s=[0,0,0.1],[0,0,0.2]); repeatable, zipped")
    sweep.add_argument("--seeds", type=int, default=1, metavar="K",
                       help="runs per point, with seeds seed … seed+K-1; the table shows mean / max over them (default 1)")
    sweep.add_argument("--metrics", metavar="M1,M2,...", help="metrics to tabulate (default: every scalar metric; at most 6 printed)")
    sweep.add_argument("--plot", action="append", default=[], metavar="X:Y",
                       help="draw metric Y against X (a metric or a varied field) into DIR/sweep_X_Y.png; needs --out (repeatable)")
    sweep.add_argument("--out", metavar="DIR", help="folder for sweep.csv (one row per run), sweep.json and the plots")
    _set_option(sweep, "; applied to every run")
    sweep.add_argument("--quiet", "-q", action="store_true", help="no progress bar")
    sweep.set_defaults(func=_cmd_sweep)


def _add_pair(sub):
    pair = sub.add_parser(
        "pair", help="run two scenarios on the same seeds and compare them (paired differences)",
        description="Run scenarios A and B on the same seeds (same sensor noise and disturbance realisations; they must "
                    "share [[sensors]], [[disturbances]], [[spacecraft]], [orbit] and [sim]) and compare every metric "
                    "and the paper's paired series (B - A over time).")
    pair.add_argument("a", help="scenario A (bundled name or .toml)")
    pair.add_argument("b", help="scenario B (bundled name or .toml)")
    pair.add_argument("--seeds", type=int, default=3, metavar="K", help="seeds seed(A) … seed(A)+K-1 (default 3)")
    pair.add_argument("--metrics", metavar="M1,M2,...", help="metrics to print (default all common ones)")
    pair.add_argument("--out", metavar="DIR", help="folder for pair.md, pair.nc (series and B - A), pair.png, pair.json")
    _set_option(pair, "; applied to both")
    pair.add_argument("--quiet", "-q", action="store_true", help="no progress bar")
    pair.set_defaults(func=_cmd_pair)


def _add_tune(sub):
    tn = sub.add_parser(
        "tune", help="tune scenario fields (gains) by gradient through the closed loop, then re-run it exactly",
        description="Minimise a run metric over continuous scenario fields under constraints on others, with JAX "
        "gradients of the whole closed loop (smooth surrogates stand in for dead zones, saturation and threshold "
        "times; docs/tuning.md); the tuned scenario is re-run on the exact loop and those figures are reported.",
    )
    tn.add_argument("scenario", help="bundled scenario name or path to a .toml file")
    tn.add_argument("--objective", required=True, metavar="METRIC", help="metric to minimise (e.g. fuel_l1_ns, sync_time_s)")
    tn.add_argument("--constraint", action="append", default=[], metavar="METRIC<=VALUE", help="a constraint (repeatable)")
    tn.add_argument("--params", nargs="+", required=True, metavar="PATH", help="fields to tune (controller.alpha controller.beta)")
    tn.add_argument("--starts", type=int, default=1, help="initial points, screened together in one vmap (default 1)")
    tn.add_argument("--polish", type=int, default=1, help="how many of the best starts SLSQP refines (default 1)")
    tn.add_argument("--spread", type=float, default=0.3, help="relative spread of the drawn starts (default 0.3)")
    tn.add_argument("--max-iter", type=int, default=50, help="SLSQP iterations (default 50)")
    tn.add_argument("--seed", type=int, default=0, help="seed of the drawn starts")
    tn.add_argument("--out", metavar="DIR", help="folder for tuned.toml, tune.md and tune.json")
    _set_option(tn)
    tn.add_argument("--quiet", "-q", action="store_true", help="no per-iteration lines")
    tn.set_defaults(func=_cmd_tune)


def _add_campaign(sub):
    camp = sub.add_parser("campaign", help="Monte Carlo campaigns: dispersed runs on Dask, resumable (docs/campaigns.md)")
    camp_sub = camp.add_subparsers(dest="campaign_command", required=True)
    camp_sub.add_parser("list", help="bundled campaigns with a one-line description").set_defaults(func=_cmd_campaign_list)
    c_run = camp_sub.add_parser("run", help="run (or resume) a campaign file into a folder")
    c_run.add_argument("file", help="campaign .toml, or a bundled campaign's name (coopsat campaign list)")
    c_run.add_argument("--out", required=True, metavar="DIR", help="campaign folder (resumed when it holds this campaign)")
    where = c_run.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, help="local worker processes (default 1)")
    where.add_argument("--scheduler", metavar="tcp://HOST:PORT", help="an existing Dask scheduler")
    c_run.add_argument("--quiet", "-q", action="store_true",
                       help="no progress (a bar on a terminal, a line per tenth of the runs otherwise)")
    c_run.set_defaults(func=_cmd_campaign_run)
    c_rep = camp_sub.add_parser("replay", help="run one stored run again (in its batch, on the path it took) and compare it bit for bit")
    c_rep.add_argument("dir", help="campaign folder")
    c_rep.add_argument("run_id", type=int)
    c_rep.set_defaults(func=_cmd_campaign_replay)
    c_report = camp_sub.add_parser("report", help="statistics, failures, sensitivities and figures in DIR/report/index.html")
    c_report.add_argument("dir", help="campaign folder")
    c_report.set_defaults(func=_cmd_campaign_report)


def _add_bench(sub):
    bench = sub.add_parser("bench", help="measure engine throughput (spacecraft-steps per second)")
    bench.add_argument("--sizes", type=int, nargs="+", default=[1, 5, 1000, 10000], help="formation sizes N")
    bench.add_argument("--steps", type=int, default=None, help="ticks per timed run (default: scaled to N)")
    bench.add_argument("--batch", type=int, default=1000, help="runs of N = 5 in one batch (0: skip)")
    bench.add_argument("--orbit-sizes", type=int, nargs="*", default=[100, 1000], help="orbit rows' sizes (none: skip)")
    bench.add_argument("--no-native", action="store_true", help="keep the whole loop in XLA (no native CPU kernel)")
    bench.set_defaults(func=_cmd_bench)


def build_parser():
    """The argument parser (exposed for tests and documentation)."""
    p = argparse.ArgumentParser(prog="coopsat", description="Cooperative control of spacecraft formations.")
    sub = p.add_subparsers(dest="command", required=True)
    for add in (_add_list, _add_show, _add_validate, _add_run, _add_sil, _add_report, _add_export, _add_plot, _add_margin, _add_design, _add_topology, _add_tradeoff, _add_sweep, _add_pair, _add_tune, _add_campaign, _add_bench):
        add(sub)
    return p


def _show_notice(message, category, filename, lineno, file=None, line=None):
    """coopsat's own warnings (such as the native kernels' fallback) as one line on stderr;
    any other as Python shows it."""
    if category.__module__.startswith("coopsat."):
        print(f"coopsat: notice: {message}", file=sys.stderr)
    else:
        sys.stderr.write(warnings.formatwarning(message, category, filename, lineno, line))


def main(argv=None):
    """Entry point of the ``coopsat`` command; returns the exit status.

    Bad input: one line, status 2. After SIGINT (Ctrl-C) or SIGTERM the status is 130 or 143,
    never 0: a command stops at its next safe point (after compiling, after a compiled chunk of
    the loop, between stages, right before its folder is renamed into place) and its last line
    says either "nothing written" or which folder is complete (:mod:`coopsat.workflows.interrupt`).
    """
    from coopsat.workflows import interrupt

    args = build_parser().parse_args(argv)
    configure_process()
    in_main_thread = threading.current_thread() is threading.main_thread()
    previous = interrupt.install() if in_main_thread else {}
    stop = None
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _show_notice
            status = args.func(args)
    except CoopsatError as err:  # every coopsat error, its status by cause (coopsat.core.errors)
        print(f"coopsat: error: {err}", file=sys.stderr)
        return err.exit_status
    except (KeyboardInterrupt, interrupt.Interrupted) as err:
        stop = getattr(err, "signum", signal.SIGINT)
    except BrokenPipeError:
        # The reader closed stdout (coopsat list | head): end as a Unix tool killed by SIGPIPE
        # would, without a traceback, and keep the interpreter's final flush from failing again.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_BROKEN_PIPE
    finally:
        pending = interrupt.restore(previous)  # a signal during the command's last steps counts too
    stop = stop or pending
    if stop is None:
        return status
    print(f"coopsat: {interrupt.stop_line(stop)}", file=sys.stderr)
    return EXIT_TERMINATED if stop == signal.SIGTERM else EXIT_INTERRUPTED


def command():
    """The ``coopsat`` script: :func:`main`, then :func:`coopsat.core.process_exit.end`."""
    from coopsat.core.process_exit import end

    end(main())


if __name__ == "__main__":
    command()
