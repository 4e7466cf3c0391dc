"""Cartwheel formation keeping with impulse-bit micro-thrusters (SPEC §2) as a controller plug-in.

``kind = "cartwheel-keeping"``: the chief is uncontrolled; each deputy keeps its place on the
relative circle with a discrete LQR on the CW error (Bryson weights: the acceptable position
and velocity error and force), its target planned or estimated from its ring neighbours
(eqs. 7–11), and the chief may re-allocate the formation's phase ψ on board by PSO
(eqs. 15–16). The in-loop part is :class:`coopsat.control.cartwheel.CartwheelKeeping`; the
design model is :mod:`coopsat.design.cw`; metrics and the comparison with the paper are in
:mod:`coopsat.analysis.papers.cartwheel_keeping`.
"""

import math
from typing import Literal

from pydantic import Field

from coopsat.plugins import DesignCheck, DesignError, Plugin, register
from coopsat.plugins.tables import (
    MAX_DISTANCE_M,
    MAX_FORCE_N,
    MAX_GAIN,
    MAX_SPEED_M_S,
    MAX_TIME_S,
    FormationTolerance,
    Table,
    whole_ratio,
)

ANALYSIS = "coopsat.analysis.papers.cartwheel_keeping"

CW_RADIUS_RATIO_MAX = 1e-3
"""ρ/a above which the CW model's neglected terms (order ρ/a of the gravity difference) matter."""

CW_ECCENTRICITY_MAX = 0.01
"""Chief eccentricity above which a circular-orbit (CW) design model is meaningless."""

PLAN_HORIZON_MAX_RAD = 0.9 * math.pi
"""Longest planner transfer, in radians of orbit: the two-impulse CW transfer's Φrv is singular
at every half orbit (and at tan(nτ/2) = 3nτ/8 beyond), so keep clear below the first."""


class CartwheelTable(Table):
    """``kind = "cartwheel-keeping"``: deputies keep a tilted relative circle around an uncontrolled chief (SPEC §2)."""

    kind: Literal["cartwheel-keeping"]
    period_s: float = Field(gt=0, le=1e5, description="Control period (zero-order hold), s.")
    chief: str = Field(description="The uncontrolled chief: origin of the LVLH frame and centre of the circle.")
    deputies: list[str] = Field(min_length=1, description="The deputies in phase order: deputy k sits at φ = ψ + 2π(k − 1)/K.")
    radius_m: float = Field(1.5, gt=0, le=MAX_DISTANCE_M, description="Radius ρ of the relative circle, m.")
    psi_deg: float = Field(0.0, ge=-360, le=360, description="Planned formation phase ψ, deg.")
    targets: Literal["planned", "ring"] = Field(
        "ring", description="planned: each deputy steers to its planned circle point; ring: the target estimated from its "
        "ring neighbours' states (eqs. 7–11)."
    )
    chief_weight: float = Field(2.0, gt=0, le=MAX_GAIN, description="Weight of the chief's candidate in a deputy's target (eq. 10).")
    deputy_weight: float = Field(1.0, gt=0, le=MAX_GAIN, description="Weight of a neighbouring deputy's candidate (eq. 10).")
    delay_compensation: Literal["none", "linear", "cw"] = Field(
        "cw", description="Received states brought to the present: not at all, R + δt·V (the paper's), or the CW transition matrix."
    )
    position_scale_m: float = Field(2e-3, gt=0, le=MAX_DISTANCE_M, description="Bryson: acceptable position error per axis, m.")
    velocity_scale_m_s: float = Field(4e-5, gt=0, le=MAX_SPEED_M_S, description="Bryson: acceptable velocity error per axis, m/s.")
    force_scale_n: float = Field(1e-5, gt=0, le=MAX_FORCE_N, description="Bryson: acceptable force per axis, N (the accuracy–impulse knob).")
    replan_every_s: float = Field(0.0, ge=0, le=MAX_TIME_S, description="Time between the chief's PSO solves of ψ, s (0: never).")
    psi_bound_deg: float = Field(0.01, gt=0, le=180, description="The PSO searches ψ within psi_deg ± this, deg.")
    plan_horizon_s: float = Field(
        1000.0, gt=0, le=MAX_TIME_S, description="Transfer time of the planner's two-impulse cost, s (under 0.45 orbit)."
    )
    pso_particles: int = Field(16, ge=2, le=1000, description="PSO swarm size.")
    pso_iterations: int = Field(30, ge=1, le=10000, description="PSO iterations per solve.")


def _chief_orbit(table, ctx):
    """Semi-major axis, m, eccentricity, and mean motion, rad/s, of the chief's initial orbit."""
    import numpy as np

    mu = ctx.scenario.orbit.mu_m3_s2
    c = ctx.index(table.chief, "controller.chief")
    r, v = ctx.r_eci_m[c], ctx.v_eci_m_s[c]
    a = 1.0 / (2.0 / np.linalg.norm(r) - v @ v / mu)
    e = np.linalg.norm(np.cross(v, np.cross(r, v)) / mu - r / np.linalg.norm(r))
    if not a > 0:
        raise DesignError(f"controller.chief: the chief '{table.chief}' is not on a closed orbit (a = {a:.4g} m)")
    return float(a), float(e), float(np.sqrt(mu / a**3))


def design(table, ctx):
    """The keeping design: mean motion, phases, LQR gains, source weights, planner interval.

    Returns
    -------
    dict
        ``part`` (the arrays of :class:`~coopsat.control.cartwheel.CartwheelKeeping`), ``static``
        (its static fields), ``a_m``, ``e``, ``n_rad_s``, ``closed_loop_radius`` (spectral
        radius of the sampled CW loop under the gain), ``time_constants_s``.
    """
    import numpy as np

    from coopsat.design.cw import cw_matrices
    from coopsat.design.riccati import discretize

    _require_inputs(table, ctx)
    n_sc = ctx.n
    chief = ctx.index(table.chief, "controller.chief")
    deputies = [ctx.index(d, f"controller.deputies[{k}]") for k, d in enumerate(table.deputies)]
    if chief in deputies or len(set(deputies)) != len(deputies):
        raise DesignError(f"controller.deputies: must be distinct and exclude the chief, got {table.deputies}")
    a, e, n = _chief_orbit(table, ctx)
    period = ctx.period_s
    replan = _replan_periods(table, period, n)
    phase = np.zeros(n_sc)
    phase[deputies] = 2 * np.pi * np.arange(len(deputies)) / len(deputies)
    deputy = np.zeros(n_sc)
    deputy[deputies] = 1.0
    mass = np.array([s.mass_kg for s in ctx.scenario.spacecraft], dtype=float)
    a_cw, b_cw = cw_matrices(n)
    phi, gam = discretize(a_cw, b_cw, period)
    gain, radius = _keeping_gains(table, ctx, deputies, mass, (a_cw, b_cw, phi, gam))
    part = {
        "rho_m": table.radius_m, "n_rad_s": n, "phase_rad": phase, "deputy": deputy,
        "chief": np.int32(chief), "source_weight": _source_weights(table, ctx, chief, deputies, deputy), "gain": gain,
        "mass_kg": mass, "psi0_rad": math.radians(table.psi_deg), "psi_bound_rad": math.radians(table.psi_bound_deg),
        "horizon_s": table.plan_horizon_s,
    }
    static = {
        "period_s": float(period), "targets": table.targets, "compensation": table.delay_compensation, "replan_every": replan,
        "particles": table.pso_particles, "iterations": table.pso_iterations,
    }
    with np.errstate(divide="ignore"):
        tc = -period / np.log(np.abs(np.linalg.eigvals(phi - gam @ gain[deputies[0]])))
    return {"part": part, "static": static, "a_m": a, "e": e, "n_rad_s": n, "closed_loop_radius": radius, "time_constants_s": np.sort(tc)}


def _require_inputs(table, ctx):
    """The run has what cartwheel keeping reads and commands: translation, relative navigation
    about its chief, impulse-bit thrusters."""
    from coopsat.plugins.force_actuators import require_translation

    require_translation(ctx, "controller", "cartwheel keeping")
    if not any(s.kind == "relative-navigation" and s.chief == table.chief for s in ctx.scenario.sensors):
        raise DesignError(
            f'controller: cartwheel-keeping reads relative states; add [[sensors]] kind = "relative-navigation" with '
            f'chief = "{table.chief}"'
        )
    if not any(a.kind == "impulse-bit-thrusters" for a in ctx.scenario.actuator_list):
        raise DesignError('actuators: cartwheel-keeping is measured in impulse bits; add [[actuators]] kind = "impulse-bit-thrusters"')


def _replan_periods(table, period, n):
    """Control periods between the chief's PSO solves (0: never), after checking that the
    planner's transfer stays clear of the CW transfer's singularity (mean motion ``n``)."""
    replan = 0
    if table.replan_every_s > 0:
        replan = whole_ratio(table.replan_every_s, period)
        if replan is None:
            raise DesignError(f"controller.replan_every_s ({table.replan_every_s:g} s) must be a whole number of control periods ({period:g} s)")
    if table.plan_horizon_s * n > PLAN_HORIZON_MAX_RAD:
        raise DesignError(
            f"controller.plan_horizon_s ({table.plan_horizon_s:g} s) must be under {PLAN_HORIZON_MAX_RAD / (2 * math.pi):.2f} "
            f"orbit ({PLAN_HORIZON_MAX_RAD / n:.0f} s): the two-impulse CW transfer is singular at half an orbit"
        )
    return replan


def _keeping_gains(table, ctx, deputies, mass, cw):
    """Each deputy's discrete LQR gain on its CW error (Bryson weights), shape (n, 3, 6), zero
    for the others, and the largest spectral radius of the sampled loops. ``cw``: the CW
    matrices, continuous and sampled (a, b, Φ, Γ)."""
    import numpy as np

    from coopsat.design.lti import bryson_weights
    from coopsat.design.riccati import lqr

    a_cw, b_cw, phi, gam = cw
    gain = np.zeros((ctx.n, 3, 6))
    radius = 0.0
    for i in deputies:
        # Bryson on the force F = m f: the specific force's scale is F_scale / m.
        scales = [table.position_scale_m] * 3 + [table.velocity_scale_m_s] * 3
        q, r = bryson_weights(scales, [table.force_scale_n / mass[i]] * 3)
        try:
            gain[i] = lqr(a_cw, b_cw, q, r, discrete_dt_s=ctx.period_s).K
        except ValueError as err:
            raise DesignError(f"controller: keeping gain of {ctx.names[i]}: {err}") from None
        radius = max(radius, float(np.abs(np.linalg.eigvals(phi - gam @ gain[i])).max()))
    return gain, radius


def _source_weights(table, ctx, chief, deputies, deputy):
    """The weight with which each deputy takes each neighbour's candidate target (eq. 10): the
    chief's and the deputies' weights on the links of the first graph, none for the chief."""
    import numpy as np

    adjacency = ctx.adjacencies[0]
    weight = np.where(adjacency > 0, table.deputy_weight, 0.0)
    weight[:, chief] = np.where(adjacency[:, chief] > 0, table.chief_weight, 0.0)
    weight *= deputy[:, None]
    if table.targets == "ring":
        lonely = [ctx.names[i] for i in deputies if weight[i].sum() == 0]
        if lonely:
            raise DesignError(f"network: deputy {lonely[0]} hears no neighbour in [network] to estimate its target from (targets = \"ring\")")
    return weight


def _build(table, ctx):
    from coopsat.control.cartwheel import CartwheelKeeping
    from coopsat.sim.system import as_arrays

    out = design(table, ctx)
    return CartwheelKeeping(**as_arrays(out["part"]), **out["static"])


def check_design(table, ctx):
    """The sampled CW loop under the LQR gain is stable, and its time constants."""
    out = design(table, ctx)
    radius, tc = out["closed_loop_radius"], out["time_constants_s"]
    ok = radius < 1.0
    note = (
        f"LQR keeping on the CW model sampled at {ctx.period_s:g} s: spectral radius {radius:.6f}, time constants "
        f"{tc.min():.3g}–{tc.max():.3g} s" + ("" if ok else " (>= 1: UNSTABLE)")
    )
    return DesignCheck("cartwheel-design", ok, note, {"closed_loop_spectral_radius": radius, "slowest_time_constant_s": float(tc.max())}, out)


def check_cw_validity(table, ctx):
    """The CW model needs a near-circular chief orbit and a circle small against the orbit."""
    a, e, _ = _chief_orbit(table, ctx)
    ratio = table.radius_m / a
    ok = e <= CW_ECCENTRICITY_MAX and ratio <= CW_RADIUS_RATIO_MAX
    note = (
        f"CW design model: chief eccentricity {e:.2g} (≤ {CW_ECCENTRICITY_MAX:g}), radius/orbit ρ/a = {ratio:.2g} "
        f"(≤ {CW_RADIUS_RATIO_MAX:g})" + ("" if ok else ": the CW model is not meaningful here, expect model error")
    )
    return DesignCheck("cw-validity", ok, note, {"chief_eccentricity": e, "radius_over_orbit": ratio})


register(Plugin("controller", "cartwheel-keeping", CartwheelTable, _build, (check_design, check_cw_validity), ANALYSIS,
                thresholds=FormationTolerance))
