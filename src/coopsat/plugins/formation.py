"""Deep-space formation control (SPEC §4) as a controller plug-in: observer-based linear
flight software, its gains designed by the LMIs of the paper or by Riccati LQR.

``kind = "formation-observer"`` with ``design = "lmi"`` (state feedback by ``min γ``, eq. 11;
reference gain F = −K_o M_ρ) or ``design = "lqr"`` (Riccati with Bryson's weights and the
non-zero set point of eq. 17). Both run the same observer (dual LMI) so that the comparison
isolates the gain; ``architecture`` says whose measurements each spacecraft uses
(decentralized: its own; centralized: the hub's, relayed). ``objective = "centroid-holding"``
removes the common-mode force from the law and feeds back an open-loop estimate of the
centroid's displacement (eq. 15). The in-loop part is
:class:`coopsat.control.formation.LinearFormationSoftware`; the design math is
:mod:`coopsat.design.formation_model` and :mod:`coopsat.design.formation_synthesis`; metrics and
the comparison with the paper are in :mod:`coopsat.analysis.papers.deep_space_2008`.
"""

from typing import Annotated, Literal

from pydantic import Field

from coopsat.plugins import DesignCheck, DesignError, Plugin, Tunable, register
from coopsat.plugins.tables import MAX_DISTANCE_M, MAX_FORCE_N, MAX_SPEED_M_S, FormationTolerance, Table

ANALYSIS = "coopsat.analysis.papers.deep_space_2008"

PLANES = {"xy": (0, 1), "xyz": (0, 1, 2)}
"""Design axes: the inertial plane of the formation, or all three axes."""

Length = Annotated[float, Field(ge=-MAX_DISTANCE_M, le=MAX_DISTANCE_M)]


class FormationObserverTable(Table):
    """``kind = "formation-observer"``: observer-based formation keeping on relative positions (SPEC §4)."""

    kind: Literal["formation-observer"]
    period_s: float = Field(gt=0, le=1e5, description="Control period (zero-order hold), s.")
    design: Literal["lmi", "lqr", "gain"] = Field(
        description="lmi: min-γ guaranteed-cost LMI (paper eq. 11); lqr: Riccati LQR with non-zero set point (eq. 17); "
        "gain: the state feedback given in `gain` (e.g. written by `coopsat tune`), with u_ff = −K x_ref."
    )
    gain: list[list[Annotated[float, Field(ge=-1e6, le=1e6)]]] | None = Field(
        None,
        description="design = gain: state-feedback gain K (N per m and per m/s of the relative coordinates), "
        "(n·d) rows × 2(n−1)d columns; u = K (x̂ − x_ref).",
    )
    architecture: Literal["decentralized", "centralized"] | None = Field(
        None,
        description="decentralized: each spacecraft from its own measurements; centralized: every command from the "
        "hub's measurements. Default: decentralized for lmi, centralized for lqr (the paper's pairing).",
    )
    objective: Literal["minimum-fuel", "centroid-holding"] = Field(
        "minimum-fuel", description="centroid-holding: no common-mode force, plus feedback of the centroid estimate (eq. 15)."
    )
    coordinates: Literal["hub", "orthonormal"] = Field(
        "hub", description="Relative coordinates of the design: positions relative to the hub (the paper's), or an orthonormal basis."
    )
    hub: str | None = Field(None, description="Hub spacecraft (default the first).")
    lmi_objective: Literal["gamma", "trace"] = Field(
        "gamma", description="design = lmi: min γ over the initial-error ball (paper), or min trace (returns the Riccati gain)."
    )
    plane: Literal["xy", "xyz"] = Field("xy", description="Design axes (inertial): the x–y plane, or all three.")
    target_m: list[list[Length]] = Field(
        description="Target position of each spacecraft relative to the initial centroid, design axes, m ([[spacecraft]] order)."
    )
    position_scale_m: float = Field(10.0, gt=0, le=MAX_DISTANCE_M, description="Bryson: acceptable relative position error, m.")
    velocity_scale_m_s: float = Field(0.05, gt=0, le=MAX_SPEED_M_S, description="Bryson: acceptable relative velocity, m/s.")
    force_scale_n: float = Field(0.1, gt=0, le=MAX_FORCE_N, description="Bryson: acceptable force per axis, N (the trade-off knob).")
    observer_bandwidth_rad_s: float = Field(
        0.02, gt=0, le=1e3,
        description="Observer (dual LMI) bandwidth ω_o, rad/s: weights as a Kalman filter with acceleration noise ω_o² "
        "per unit measurement noise, poles near ω_o·e^{±3πj/4} per coordinate.",
    )


def _geometry(table, ctx):
    """Initial positions relative to the centroid (n, d), targets (n, d), common mass."""
    import numpy as np

    sc = ctx.scenario.spacecraft
    if ctx.scenario.orbit is None or any(s.r_eci_m is None for s in sc):
        raise DesignError("controller: formation-observer needs an [orbit] table and r_eci_m/v_eci_m_s for every spacecraft")
    masses = {s.mass_kg for s in sc}
    if None in masses:
        raise DesignError("spacecraft: formation-observer needs every spacecraft's mass_kg")
    if len(masses) != 1:
        raise DesignError(f"spacecraft: formation-observer designs for equal masses, got {sorted(masses)} kg")
    axes = PLANES[table.plane]
    r = np.asarray([s.r_eci_m for s in sc], dtype=float)
    p0 = (r - r.mean(axis=0))[:, axes]
    rows = [len(row) for row in table.target_m]  # checked before NumPy, which cannot make an array of ragged rows
    if rows != [len(axes)] * len(p0):
        raise DesignError(
            f"controller.target_m: needs one [{', '.join('xyz'[a] for a in axes)}] per spacecraft "
            f"({p0.shape[0]}×{p0.shape[1]}), got {len(rows)} rows of lengths {rows}"
        )
    target = np.asarray(table.target_m, dtype=float)
    return p0, target, masses.pop(), axes


def _thruster_model(ctx):
    """The dead zone and limit of the force actuator, N (none: 0 and no limit)."""
    tables = ctx.scenario.actuators if isinstance(ctx.scenario.actuators, list) else [ctx.scenario.actuators]
    for a in tables:
        if a.kind == "proportional-thrusters":
            return a.force_min_n, a.force_max_n
    return 0.0, MAX_FORCE_N


_DESIGNS = {}
"""Designs of this process by (scenario, force scale): the builder and the design check share
one solve."""


def design(table, ctx, force_scale_n=None):
    """Memoised :func:`_design` (same arguments and result)."""
    key = (ctx.scenario.model_dump_json(), force_scale_n)  # the whole scenario: masses, sensors, actuators…
    if key not in _DESIGNS:
        if len(_DESIGNS) > 64:
            _DESIGNS.clear()
        _DESIGNS[key] = _design(table, ctx, force_scale_n)
    return _DESIGNS[key]


def _design(table, ctx, force_scale_n=None):
    """The formation's gains and the flight software's matrices.

    Parameters
    ----------
    force_scale_n : float, optional
        Overrides ``table.force_scale_n`` (the trade-off sweep).

    Returns
    -------
    dict
        ``part`` (arrays of :class:`~coopsat.control.formation.LinearFormationSoftware`
        keyword arguments), ``gain``, ``observer``, ``centroid`` (the design results),
        ``x_ref``, ``p0``, ``target``, ``decomposition``, ``axes``, ``closed_loop_radius`` (spectral
        radius of the sampled closed loop without the dead zone).

    Raises
    ------
    DesignError
        Uncontrollable or unobservable pair, an LMI not certified (the message names it).
    """
    import numpy as np

    from coopsat.design.formation_model import formation_model, observability_decomposition, reference_state
    from coopsat.design.lti import FormationDesignError, bryson_weights
    from coopsat.design.riccati import discretize

    p0, target, mass, axes = _geometry(table, ctx)
    n, d = p0.shape
    hub = ctx.index(table.hub or ctx.names[0], "controller.hub")
    scale = table.force_scale_n if force_scale_n is None else force_scale_n
    try:
        model = formation_model(n, d, mass)
        dec = observability_decomposition(model, table.coordinates, hub)
        ny = (n - 1) * d
        c_y = np.hstack([np.eye(ny), np.zeros((ny, ny))])
        q, r = bryson_weights(
            np.r_[np.full(ny, table.position_scale_m), np.full(ny, table.velocity_scale_m_s)], np.full(n * d, scale)
        )
        x_ref = reference_state(dec, target)
        x_start = reference_state(dec, p0)
        gain, k, u_ff = _state_feedback(table, dec, q, r, c_y, x_ref, x_start, (n, d))
        observer = _observer(dec, c_y, table.observer_bandwidth_rad_s)
        centroid, c_u, u_ff = _centroid_law(table, dec, k, u_ff, scale, (n, d))
    except FormationDesignError as err:
        raise DesignError(f"controller: {err}") from None
    part = _software(table, ctx, (dec, c_y, observer, centroid), {"c_u": c_u, "u_ff": u_ff}, (n, d, mass, hub))
    a_d, b_d = discretize(dec.a_o, dec.b_o, ctx.period_s)
    radius = float(np.max(np.abs(np.linalg.eigvals(closed_loop_matrix(a_d, b_d, c_y, part, np)))))
    return {
        "part": part, "k": k, "plant_d": (a_d, b_d, c_y), "gain": gain, "observer": observer, "centroid": centroid, "x_ref": x_ref, "p0": p0,
        "target": target, "decomposition": dec, "closed_loop_radius": radius, "axes": axes,
    }


def _state_feedback(table, dec, q, r, c_y, x_ref, x_start, shape):
    """The state feedback ``u = k x + u_ff`` of the formation's relative state, by the table's
    ``design``: the given gain, the min-γ LMI (eq. 11) or Riccati LQR with the non-zero set point
    (eq. 17). ``shape``: (spacecraft, axes).

    Returns
    -------
    gain : the design's result (None for a given gain), k : ndarray, u_ff : ndarray
    """
    import numpy as np

    from coopsat.design.formation_synthesis import lmi_state_feedback
    from coopsat.design.lti import FormationDesignError, nonzero_setpoint_feedforward
    from coopsat.design.riccati import lqr

    n, d = shape
    ny = (n - 1) * d
    if table.design == "gain":
        k = _given_gain(table, n * d, 2 * ny)
        return None, k, -k @ x_ref
    if table.design == "lmi":
        e0 = float(np.linalg.norm(x_start - x_ref)) or 1.0
        gain = lmi_state_feedback(dec.a_o, dec.b_o, q, r, np.eye(2 * ny) / e0**2, objective=table.lmi_objective)
        return gain, gain.gain, -gain.gain @ x_ref
    try:
        k_lqr = lqr(dec.a_o, dec.b_o, q, r).K
    except ValueError as err:
        raise FormationDesignError(f"state feedback (LQR): {err}") from None
    return k_lqr, -k_lqr, nonzero_setpoint_feedforward(dec.a_o, dec.b_o, c_y, k_lqr) @ (c_y @ x_ref)


def _centroid_law(table, dec, k, u_ff, scale, shape):
    """The law's output map and feedforward: for centroid holding, the common mode removed from
    ``k`` and ``u_ff`` and the centroid's own gain added (eq. 15). ``shape``: (spacecraft, axes).

    Returns
    -------
    centroid : the centroid gain's design (None without centroid holding), c_u : ndarray, u_ff : ndarray
    """
    import numpy as np

    from coopsat.design.formation_model import common_mode_projector
    from coopsat.design.formation_synthesis import centroid_gain
    from coopsat.design.lti import bryson_weights

    if table.objective != "centroid-holding":
        return None, k, u_ff
    n, d = shape
    q_c, r_c = bryson_weights(np.r_[np.full(d, table.position_scale_m), np.full(d, table.velocity_scale_m_s)], np.full(d, scale))
    centroid = centroid_gain(dec, q_c, r_c)
    proj = common_mode_projector(n, d)
    c_u = np.hstack([proj @ k, np.kron(np.ones((n, 1)), np.eye(d)) @ centroid.gain])
    return centroid, c_u, proj @ u_ff


def _software(table, ctx, estimator, law, formation):
    """The flight software's matrices (:class:`~coopsat.control.formation.LinearFormationSoftware`
    keyword arguments): the sampled estimator (``estimator``: the decomposition, the outputs
    ``c_y``, the observer and the centroid gain) and the law ``law`` (``c_u``, ``u_ff``);
    ``formation``: spacecraft, axes, mass and hub.

    The estimator is the observer of eq. (12) and, for centroid holding, the centroid's
    open-loop displacement driven by the force expected to act (eq. 14 with x̂_ō from the start).
    """
    import numpy as np
    from scipy.linalg import block_diag

    from coopsat.design.riccati import discretize

    dec, c_y, observer, centroid = estimator
    n, d, mass, hub = formation
    ny = (n - 1) * d
    ell = observer.gain
    f, g_y, g_u = dec.a_o + ell @ c_y, -ell, dec.b_o
    if centroid is not None:
        a_c = np.block([[np.zeros((d, d)), np.eye(d)], [np.zeros((d, 2 * d))]])
        b_c = np.vstack([np.zeros((d, n * d)), np.kron(np.ones((1, n)), np.eye(d)) / (n * mass)])
        f, g_y, g_u = block_diag(f, a_c), np.vstack([g_y, np.zeros((2 * d, ny))]), np.vstack([g_u, b_c])
    phi, gam = discretize(f, np.hstack([g_y, g_u]), ctx.period_s)
    nz = f.shape[0]
    f_min, f_max = _thruster_model(ctx)
    return {
        "phi": phi,
        "gamma_y": gam[:, :ny],
        "gamma_u": gam[:, ny:],
        "c_u": law["c_u"],
        "u_ff": law["u_ff"],
        "c_y": np.hstack([c_y, np.zeros((ny, nz - 2 * ny))]),
        "y_map": np.kron(dec.basis, np.eye(d)),
        "z0_map": np.vstack([np.eye(ny), np.zeros((nz - ny, ny))]),
        "force_min_n": f_min,
        "force_max_n": f_max,
        "source": np.arange(n) if _architecture(table) == "decentralized" else np.full(n, hub),
    }


def closed_loop_matrix(a_d, b_d, c_y, m, xp):
    """The sampled closed loop without the dead zone over one period: the relative state
    (``a_d``, ``b_d``, outputs ``c_y``) and the flight software's estimate (``m``: phi,
    gamma_y, gamma_u, c_u) together. ``xp``: numpy, or jax.numpy (traced, for ``coopsat tune``)."""
    top = xp.hstack([a_d, b_d @ m["c_u"]])
    bottom = xp.hstack([m["gamma_y"] @ c_y, m["phi"] + m["gamma_u"] @ m["c_u"]])
    return xp.vstack([top, bottom])


def _given_gain(table, rows, cols):
    """``table.gain`` as an array, checked against the design's shape."""
    import numpy as np

    if table.gain is None:
        raise DesignError("controller.gain: design = \"gain\" needs the state-feedback gain `gain`")
    k = np.asarray(table.gain, dtype=float)
    if k.ndim != 2 or k.shape != (rows, cols):
        raise DesignError(f"controller.gain: needs {rows} rows (spacecraft × design axes) of {cols} numbers, got shape {k.shape}")
    return k


def _observer(dec, c_y, omega):
    """Observer gain L (A_o + L C_y Hurwitz) by the dual LMI, posed in units where it is well
    conditioned.

    Time in units of 1/ω_o and velocities times 1/ω_o turn the relative double integrators
    into ``ẋ = [[0, I], [0, 0]] x``; the dual problem's weights are a Kalman filter's (unit
    acceleration noise on the velocities, unit measurement noise), whose poles sit at
    e^{±3πj/4}. Back in SI: ``L = diag(ω_o I, ω_o² I) L_n``. Posed directly in SI the
    problem spans ω_o⁴ ≈ 10⁻⁷ against 1 and the interior-point solvers stall.
    """
    import dataclasses

    import numpy as np

    from coopsat.design.formation_synthesis import lmi_observer_gain

    ny = c_y.shape[0]
    a_n = np.block([[np.zeros((ny, ny)), np.eye(ny)], [np.zeros((ny, 2 * ny))]])
    if not np.allclose(dec.a_o, a_n):
        raise DesignError("controller: the observer's normalisation assumes relative double integrators")
    q_n = np.diag(np.r_[np.zeros(ny), np.ones(ny)])
    unit = lmi_observer_gain(a_n, c_y, q_n, np.eye(ny))
    gain = np.r_[np.full(ny, omega), np.full(ny, omega**2)][:, None] * unit.gain
    return dataclasses.replace(unit, gain=gain, closed_loop_eigs=np.linalg.eigvals(dec.a_o + gain @ c_y))


def _architecture(table):
    return table.architecture or ("decentralized" if table.design == "lmi" else "centralized")


def _build(table, ctx):
    from coopsat.control.formation import LinearFormationSoftware
    from coopsat.sim.system import as_arrays

    if not any(s.kind == "relative-position" for s in ctx.scenario.sensors):
        raise DesignError('controller: formation-observer reads relative positions; add a [[sensors]] kind = "relative-position"')
    out = design(table, ctx)
    return LinearFormationSoftware(**as_arrays(out["part"]), axes=out["axes"])


def check_design(table, ctx):
    """The sampled closed loop (plant, observer, law; no dead zone) is stable, and the gains' figures."""
    out = design(table, ctx)
    radius = out["closed_loop_radius"]
    metrics = {"closed_loop_spectral_radius": radius}
    if table.design == "lmi" and out["gain"] is not None:
        metrics["lmi_gamma"] = out["gain"].gamma
    ok = radius < 1.0
    what = f"{table.design} ({_architecture(table)}, {table.coordinates} coordinates, {table.objective})"
    note = (
        f"{what}: sampled closed loop with the observer has spectral radius {radius:.6f}"
        + (" (< 1, stable without the dead zone)" if ok else " (>= 1: UNSTABLE)")
    )
    return DesignCheck("formation-design", ok, note, metrics, out)


def check_centroid(table, ctx):
    """Centroid holding with a target whose centroid is not the start's: the centroid must move."""
    import numpy as np

    if table.objective != "centroid-holding":
        return None
    p0, target, _, _ = _geometry(table, ctx)
    shift = float(np.linalg.norm(target.mean(axis=0)))
    ok = shift < 1e-6 * max(1.0, float(np.abs(target).max()))
    note = (
        "centroid holding: the target's centroid is the initial one" if ok
        else f"centroid holding: the target's centroid is {shift:.3g} m from the initial one; holding the centroid "
        "cannot reach it (the formation ends offset by that much)"
    )
    return DesignCheck("centroid-target", ok, note, {"target_centroid_offset_m": shift})


def tunables(table, ctx, part):
    """``gain``: the state feedback K (n·d × 2(n−1)d) of any design; the observer, the
    coordinates and the set point stay (u_ff = −K x_ref, the centroid-holding projection kept).

    The tuned file says ``design = "gain"`` with K: a spacecraft still computes its own rows
    from its own observer's estimate of every relative coordinate (the decentralized design's
    information)."""
    from dataclasses import replace

    import jax.numpy as jnp
    import numpy as np

    from coopsat.design.formation_model import common_mode_projector

    out = design(table, ctx)
    k0, x_ref = out["k"], jnp.asarray(out["x_ref"])
    n, d = out["p0"].shape
    # Centroid holding removes the common-mode force from the law (as the design does).
    proj = jnp.asarray(np.eye(n * d) if table.objective == "minimum-fuel" else common_mode_projector(n, d))

    def apply(p, k):
        return replace(p, c_u=p.c_u.at[:, : k.shape[1]].set(proj @ k), u_ff=proj @ (-k @ x_ref))

    return {"gain": Tunable(np.asarray(k0), apply, lambda k: {"design": "gain", "gain": np.asarray(k).tolist()})}


register(Plugin("controller", "formation-observer", FormationObserverTable, _build, (check_design, check_centroid), ANALYSIS, tunables,
                thresholds=FormationTolerance))
