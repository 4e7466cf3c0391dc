"""Leader–follower consensus under random multi-hop delay (SPEC §3) as a controller plug-in.

The paper's law (3) and the classical protocol (:mod:`coopsat.control.leader_follower`) on the
small-angle attitude model. Design-time: every follower must hear the leader; the tracking
error system (two delays: one and two hops) is formed from the network's routes and the gain,
and its exact constant-delay margin is computed (:mod:`coopsat.design.delay_exact`) and
compared with the largest single-hop delay the network can draw. The paper's metrics and
explanations live in :mod:`coopsat.analysis.papers.leader_follower_2018`.
"""

from typing import Annotated, Literal

from pydantic import Field

from coopsat.plugins import DesignCheck, DesignError, Plugin, register
from coopsat.plugins.tables import MAX_GAIN, Record, Table

Gain = Annotated[float, Field(ge=0, le=MAX_GAIN)]

ANALYSIS = "coopsat.analysis.papers.leader_follower_2018"

A_AXIS = [[0.0, 1.0], [0.0, 0.0]]
"""Per-axis state matrix of the small-angle model, x = (angle, rate)."""

B_AXIS = [[0.0], [1.0]]
"""Per-axis input matrix (unit inertia: the torque is the angular acceleration)."""


class LeaderFollowerTable(Table):
    """``kind = "leader-follower"``: followers track a free-flying leader over a delayed network."""

    kind: Literal["leader-follower"]
    period_s: float = Field(gt=0, le=1e5, description="Control period (zero-order hold), s.")
    protocol: Literal["law3", "classical"] = Field(
        "law3",
        description="law3: own state current, what is heard delayed (paper eq. 3); classical: the whole "
        "relative state delayed.",
    )
    gain: Record(Gain, Gain) = Field(description="K = [k_angle (N·m/rad), k_rate (N·m·s/rad)], every axis.")
    leader: str | None = Field(None, description="The leader spacecraft (default the first).")


def _leader_index(table, ctx):
    return ctx.index(table.leader or ctx.names[0], "controller.leader")


def follower_hops(table, ctx):
    """Hops and weights from every agent to every follower, epoch by epoch.

    Returns
    -------
    list of (hops, weights)
        Each (N, N + 1): row i is the i-th follower (state order), column 0 the leader, column
        1 + j the j-th follower; ``hops`` 0 where not heard.

    Raises
    ------
    DesignError
        A follower that cannot hear the leader in some epoch.
    """
    import numpy as np

    from coopsat.plugins.networks import route_epochs

    lead = _leader_index(table, ctx)
    followers = [k for k in range(ctx.n) if k != lead]
    agents = [lead, *followers]
    out = []
    for place, routes in zip(ctx.graph_places, route_epochs(ctx.scenario.network.delivery, ctx)):
        pairs = np.array(followers)[:, None], np.array(agents)[None, :]  # (followers, agents): receiver, transmitter
        hops = routes.heard.values_at(routes.hops, *pairs)
        deaf = [ctx.names[f] for f, h in zip(followers, hops[:, 0]) if h == 0]
        if deaf:
            raise DesignError(
                f"{place}: {', '.join(deaf)} cannot hear the leader {ctx.names[lead]} "
                "(give a link or a route, with network.delivery relay = true)"
            )
        out.append((hops, routes.heard.weights_at(*pairs)))
    return out


def _build(table, ctx):
    import numpy as np

    from coopsat.control.leader_follower import LeaderFollower
    from coopsat.sim.system import as_arrays

    if ctx.scenario.sim.attitude != "small-angle":
        raise DesignError('controller: leader-follower acts on small angles; it needs sim.attitude = "small-angle"')
    follower_hops(table, ctx)  # every follower hears the leader
    follower = np.ones(ctx.n)
    follower[_leader_index(table, ctx)] = 0.0
    return LeaderFollower(*as_arrays((np.asarray(table.gain, dtype=float), follower)), protocol=table.protocol)


def largest_hop_delay_s(ctx):
    """The largest single-hop delay the network can impose (fixed plus random bound), s; None
    when per-link delays differ (the margin of a single τ does not apply)."""
    from coopsat.plugins.networks import random_delay_periods

    delivery = ctx.scenario.network.delivery
    if delivery.kind == "ideal":
        return 0.0
    if delivery.link_delays:
        return None
    return delivery.delay_s + random_delay_periods(delivery, ctx)[1] * ctx.period_s


def error_system(table, ctx, gain=None):
    """Per-axis tracking-error system (A0, [(A_m, m)]) of the scenario at t = 0 (first epoch)."""
    from coopsat.design.delay_exact import leader_follower_error_system

    hops, weights = follower_hops(table, ctx)[0]
    k = [list(table.gain if gain is None else gain)]
    return leader_follower_error_system(A_AXIS, B_AXIS, k, hops, table.protocol, weights)


def check_delay_margin(table, ctx):
    """The exact constant-delay margin of the protocol with this gain, against the network's
    largest single-hop delay."""
    import math

    from coopsat.design.delay_exact import exact_delay_margin

    margin = exact_delay_margin(*error_system(table, ctx))
    bound = largest_hop_delay_s(ctx)
    metrics = {"delay_margin_s": margin.tau_s, "delay_margin_omega_rad_s": margin.omega_rad_s}
    what = f"{table.protocol} with K = [{table.gain[0]:g}, {table.gain[1]:g}]"
    if not margin.stable_without_delay:
        return DesignCheck("delay-margin", False, f"{what}: the error system is unstable even without delay", metrics, margin)
    text = (
        "stable for every constant delay (no imaginary-axis crossing)" if math.isinf(margin.tau_s)
        else f"exact constant single-hop delay margin {margin.tau_s:.6g} s (crossing at {margin.omega_rad_s:.4g} rad/s)"
    )
    if bound is None:
        return DesignCheck("delay-margin", True, f"{what}: {text}; per-link delays differ, not compared", metrics, margin)
    metrics["largest_hop_delay_s"] = bound
    ok = bound < margin.tau_s
    verdict = "within it" if ok else "ABOVE it: expect oscillation or divergence at the largest delays"
    return DesignCheck("delay-margin", ok, f"{what}: {text}; the network's largest hop delay {bound:g} s is {verdict}", metrics, margin)




GAIN_BOUNDS = ((0.05, 20.0), (0.05, 20.0))
"""Search box of K = [k_angle, k_rate] for the delay-gain design (N·m/rad, N·m·s/rad)."""


def certify(table, ctx, h_s, gain=None):
    """The delay-dependent LMI for time-varying single-hop delay 0 ≤ d(t) ≤ h: the largest
    decay rate α certified at ``h_s`` (0 and not certified when none is).

    Returns
    -------
    coopsat.design.delay_bounds.CertifiedBound
    """
    from coopsat.design.delay_bounds import max_decay_rate

    return max_decay_rate(*error_system(table, ctx, gain), h_s)


def largest_certified_h(table, ctx, gain=None):
    """Analysis mode: the largest h the LMI certifies for the scenario's (or the given) gain.

    Returns
    -------
    coopsat.design.delay_bounds.CertifiedBound
    """
    from coopsat.design.delay_bounds import max_certified_delay

    return max_certified_delay(*error_system(table, ctx, gain))


def design(table, ctx, h_s, max_evaluations=100, progress=None):
    """Synthesis: the gain K the LMI certifies for every time-varying single-hop delay up to
    ``h_s`` with the largest decay rate (derivative-free search over K, one convex problem per
    candidate, at most ``max_evaluations`` gains), checked against the exact constant-delay
    margin of the design. ``progress``: see :func:`coopsat.design.delay_gain.design_gain`.

    Returns
    -------
    (coopsat.design.delay_gain.DelayGainDesign, coopsat.design.delay_exact.DelayMargin)

    Raises
    ------
    DesignError
        No gain is certified at ``h_s`` (the message gives the largest h found), or the
        certificate exceeds the exact margin (an inconsistency that must never pass).
    """
    import numpy as np

    from coopsat.design.delay_exact import exact_delay_margin
    from coopsat.design.delay_gain import design_gain

    try:
        result = design_gain(
            lambda k: error_system(table, ctx, np.ravel(k)), h_s, np.asarray([table.gain], dtype=float), GAIN_BOUNDS,
            max_evaluations=max_evaluations, progress=progress,
        )
    except ValueError as err:
        raise DesignError(f"design delay-gain: {err}") from None
    margin = exact_delay_margin(*error_system(table, ctx, np.ravel(result.gain)))
    if result.h > margin.tau_s:
        raise DesignError(
            f"design delay-gain: the LMI certified h = {result.h:g} s above the exact constant-delay margin "
            f"{margin.tau_s:g} s of its gain: the certificate is wrong and is not used"
        )
    return result, margin


def check_time_varying(table, ctx):
    """With a random (time-varying) delay: does the LMI certify the gain for d(t) up to the
    network's largest single-hop delay, and at what decay rate?"""
    from coopsat.plugins.networks import random_delay_periods

    delivery = ctx.scenario.network.delivery
    bound = largest_hop_delay_s(ctx)
    if delivery.kind == "ideal" or random_delay_periods(delivery, ctx)[1] == 0 or not bound:
        return None
    found = certify(table, ctx, bound)
    r = found.result
    what = f"time-varying delay 0 ≤ d(t) ≤ {bound:g} s"
    metrics = {"lmi_certified": float(r.certified), "lmi_decay_rate_1_s": found.value}
    if r.certified:
        note = f"{table.protocol}: the delay-dependent LMI certifies {what}, V(t) ≤ V(0)·exp(−{found.value:.4g} t) ({r.solver})"
    else:
        note = f"{table.protocol}: the delay-dependent LMI does not certify {what} for this gain ({r.status}); not a proof of instability"
    return DesignCheck("delay-lmi", bool(r.certified), note, metrics, found)


register(
    Plugin("controller", "leader-follower", LeaderFollowerTable, _build, (check_delay_margin, check_time_varying), ANALYSIS)
)
