"""The leader–follower delay designs of ``coopsat margin`` and ``coopsat design delay-gain``
(SPEC §3): the exact constant-delay margin, the delay bound the LMI certifies for a scenario's
gain, and a gain certified for a time-varying delay written out as a scenario that extends the
one it was designed for. Each returns the lines the command prints; the design, which runs for
a minute, also reports its stages through a ``progress`` callback (the command prints them on
stderr) and writes one file only, the one named by ``out`` (or its default, named last).
"""

from pathlib import Path

from coopsat.plugins import DesignError
from coopsat.scenarios.load import ScenarioError, load_scenario
from coopsat.workflows import interrupt
from coopsat.workflows.folders import unwritable_parent, write_text_atomically
from coopsat.workflows.pipeline import prepare

#: The stage reported while the scenario is loaded and its design checks run (seconds: the
#: checks solve the delay LMI for the scenario's own gain).
CHECKS_STAGE = "scenario checks"


def _prepared(ref, overrides):
    return prepare(load_scenario(ref, overrides))


def margin_lines(ref, overrides=()):
    """The exact constant-delay margin of a scenario's delayed consensus law, as printed lines.

    Raises
    ------
    ScenarioError
        When the controller has no delay margin, or the margin could not be computed.
    """
    built = _prepared(ref, overrides)
    check = built.checks.get("delay-margin")
    if check is None:
        raise ScenarioError(
            f"{built.scenario.name}: controller {built.scenario.controller.kind} has no delay margin "
            "(the leader-follower controller has one)"
        )
    if check.detail is None:
        raise ScenarioError(check.note)
    m = check.detail
    lines = [
        check.note,
        f"  delay_margin_s = {m.tau_s:.9g}",
        f"  crossing_omega_rad_s = {m.omega_rad_s:.9g}",
        f"  stable_without_delay = {str(m.stable_without_delay).lower()}",
    ]
    if "largest_hop_delay_s" in check.metrics:
        lines.append(f"  largest_hop_delay_s = {check.metrics['largest_hop_delay_s']:g}")
    return lines


def _leader_follower(built):
    """``built`` (a prepared scenario), refused unless its controller is leader–follower."""
    if built.scenario.controller.kind != "leader-follower":
        raise ScenarioError(
            f"{built.scenario.name}: design delay-gain needs a leader-follower controller, not {built.scenario.controller.kind}"
        )
    return built


def _certificate_lines(result):
    return [f"    {name}: relative eigenvalue margin {value:.3g}" for name, value in result.relative_margins.items()]


def analyse_lines(ref, overrides=()):
    """No synthesis: the largest delay bound h the LMI certifies for the scenario's own gain,
    beside the exact constant-delay margin, as printed lines."""
    from coopsat.plugins.leader_follower import largest_certified_h

    built = _leader_follower(_prepared(ref, overrides))
    table = built.scenario.controller
    found = largest_certified_h(table, built.context)
    margin = built.checks["delay-margin"].detail
    return [
        f"{table.protocol} with K = [{table.gain[0]:g}, {table.gain[1]:g}]: the LMI certifies 0 <= d(t) <= "
        f"{found.value:.6g} s (exact constant-delay margin {margin.tau_s:.6g} s)",
        f"  condition: {found.result.condition}",
        f"  solver {found.result.solver}, status {found.result.status}, {found.n_solves} problems solved",
        *_certificate_lines(found.result),
    ]


def gain_scenario_toml(source, result, gain, path):
    """The scenario file ``path`` that extends ``source`` with the designed ``gain`` (two
    numbers), its certificate in the header comment."""
    return (
        f"# Written by coopsat design delay-gain: K certified by the delay-dependent LMI for every\n"
        f"# time-varying single-hop delay 0 <= d(t) <= {result.h:g} s; decay rate {result.alpha:.4g} 1/s;\n"
        f"# {result.solver}, {result.status}. Run it: coopsat run {path}\n"
        f'extends = "{source}"\n\n[controller]\ngain = [{gain[0]!r}, {gain[1]!r}]\n'
    )


def progress_text(stage, done, total, best):
    """One progress line of :func:`design_gain_scenario` (the arguments of its ``progress``)."""
    if stage == CHECKS_STAGE:
        return "loading the scenario and running its design checks (delay margin, LMI)"
    if done == 0:
        return f"{stage}: up to {total} gains, each a bisection over LMI solves"
    found = (
        "none certified yet" if best is None
        else f"best so far: decay rate {best.value:.4g} 1/s with K = [{best.gain.flat[0]:.4g}, {best.gain.flat[1]:.4g}]"
    )
    return f"{stage}: {done}/{total} gains, {found}"


def _out_path(out, name):
    """The scenario file the design will write (``out``, or ``<name>-delay-gain.toml`` in the
    current folder), checked before the search: a bad path is refused in one line, not after
    a minute of work."""
    path = Path(out) if out else Path(f"{name}-delay-gain.toml")
    if path.is_dir():
        raise ScenarioError(f"--out {path}: is a folder; name the file, e.g. {path / f'{name}-delay-gain.toml'}")
    if path.suffix != ".toml":
        raise ScenarioError(f"--out {path}: a scenario file must end in .toml")
    parent = unwritable_parent(path)
    if parent is not None:
        raise ScenarioError(f"--out {path}: cannot write under {parent}")
    return path


def _observed(progress, h):
    """The search's callback: a safe point for an interrupt between gains (nothing is written
    yet, so stopping there leaves nothing behind), then ``progress`` if given, the stage named
    with the delay bound ``h`` (s) designed for."""
    def observe(stage, done, total, best):
        interrupt.check()
        if progress is not None:
            progress(f"{stage} at h = {h:g} s", done, total, best)

    return observe


def design_gain_scenario(ref, overrides=(), h=None, out=None, max_evaluations=100, progress=None):
    """Design a gain certified for every time-varying single-hop delay ``0 ≤ d(t) ≤ h`` and
    write it as a scenario extending ``ref``; returns the printed lines, the last naming the
    file written (the only file written).

    Parameters
    ----------
    ref : str
        A leader–follower scenario (bundled name or .toml file).
    h : float, optional
        Delay bound to certify, s (default: the network's largest single-hop delay).
    out : str or Path, optional
        The file to write, ending in .toml; missing folders are made (default
        ``<scenario name>-delay-gain.toml`` in the current folder).
    max_evaluations : int
        Gains the search evaluates at most (each a bisection over LMI solves, about a second).
    progress : callable, optional
        ``progress(stage, done, total, best)``: first the stage :data:`CHECKS_STAGE` (``total``
        0), then the search's reports (:func:`coopsat.design.delay_gain.design_gain`); see
        :func:`progress_text`. It only observes.

    Raises
    ------
    ScenarioError
        Not a leader–follower scenario, a bad ``out`` or ``max_evaluations``, no delay to
        design for, or no gain found.
    """
    from coopsat.plugins.leader_follower import design, largest_hop_delay_s

    if max_evaluations < 1:
        raise ScenarioError(f"--max-evaluations {max_evaluations}: must be at least 1")
    scenario = load_scenario(ref, overrides)
    path = _out_path(out, scenario.name)
    if progress is not None:
        progress(CHECKS_STAGE, 0, 0, None)
    built = _leader_follower(prepare(scenario))
    table, ctx = built.scenario.controller, built.context
    h = h if h is not None else largest_hop_delay_s(ctx)
    if not h:
        raise ScenarioError("design delay-gain: give --h (the scenario's network has no delay to design for)")
    try:
        result, margin = design(table, ctx, h, max_evaluations, _observed(progress, h))
    except DesignError as err:
        raise ScenarioError(str(err)) from None
    k = [float(v) for v in result.gain.ravel()]
    source = str(Path(ref).resolve()) if str(ref).endswith(".toml") else ref
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_text_atomically(path, gain_scenario_toml(source, result, k, path))
    except OSError as err:
        # Give the gain in the one line: it took a minute to find.
        raise ScenarioError(f"--out {path}: cannot write it ({err.strerror}); the gain found is K = {k!r}, "
                            f"certified at h = {result.h:g} s") from None
    return [
        f"{table.protocol}: K = [{k[0]:.6g}, {k[1]:.6g}] certified for 0 <= d(t) <= {result.h:g} s, "
        f"V(t) <= V(0) exp(-{result.alpha:.4g} t)",
        f"  condition: {result.condition} ({result.reference})",
        f"  solver {result.solver}, status {result.status}, {result.n_evaluations} gains evaluated",
        *_certificate_lines(result.result),
        f"  exact constant-delay margin of this K: {margin.tau_s:.6g} s (>= the certified h, as it must be)",
        f"wrote {path}",
    ]
