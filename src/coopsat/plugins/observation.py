"""Cooperative Earth observation (SPEC §5): ``kind = "observation"`` staring flight software.

Each spacecraft holds its sun-pointing attitude until the ground target rises above
``min_elevation_deg`` as it sees it, then stares at it; ``law = "cooperative"`` makes every
spacecraft but the reference fly law 23 on the difference of the two attitude errors, fed by
the reference's measurements over the network; ``law = "independent"`` flies law 8 on every
spacecraft (:mod:`coopsat.control.observation`).
"""

from typing import Annotated, Literal

from pydantic import Field

from coopsat.plugins import DesignCheck, DesignError, Plugin, register
from coopsat.plugins.earth_environment import epoch, require_earth_orbit
from coopsat.plugins.tables import MAX_GAIN, MAX_TORQUE_NM, Table

Latitude = Annotated[float, Field(ge=-90, le=90)]


class Observation(Table):
    """``kind = "observation"``: stare at a ground target, alone (law 8) or matched to a reference (law 23)."""

    kind: Literal["observation"]
    period_s: float = Field(gt=0, le=1e5, description="Control period (zero-order hold), s.")
    law: Literal["cooperative", "independent"] = Field(
        "cooperative", description="cooperative: followers fly law 23 on ΔQ_fr; independent: everyone flies law 8."
    )
    reference: str | None = Field(None, description="The reference spacecraft (default the first).")
    target_lat_deg: Latitude = Field(description="Target's geodetic latitude, deg (WGS-84).")
    target_lon_deg: float = Field(ge=-360, le=360, description="Target's longitude, deg east.")
    target_height_m: float = Field(0.0, ge=-1e4, le=1e5, description="Target's height above the ellipsoid, m.")
    k1: float = Field(gt=0, le=MAX_GAIN, description="Attitude gain k1, N·m per unit of the error quaternion's vector part.")
    k2: float = Field(gt=0, le=MAX_GAIN, description="Rate gain k2, N·m·s/rad.")
    torque_max_nm: float = Field(gt=0, le=MAX_TORQUE_NM, description="Each axis of the torque command is clipped to ±this, N·m.")
    min_elevation_deg: float = Field(
        10.0, ge=-10, lt=90, description="Staring starts when the target is this high above its horizon, deg."
    )
    dump_gain_1_s: float = Field(
        0.0, ge=0, le=MAX_GAIN,
        description="Momentum dumping gain, 1/s: dipole k (h × B)/|B|² from the magnetometer (needs magnetorquers).",
    )


def _reference(table, ctx):
    if table.reference is None:
        return 0
    if table.reference not in ctx.names:
        raise DesignError(f"controller.reference: '{table.reference}' is not a spacecraft ({', '.join(ctx.names)})")
    return ctx.names.index(table.reference)


def _dipole_max(scenario):
    """The magnetorquers' dipole limit, A·m² (inf without magnetorquers: no dumping then)."""
    return next((a.dipole_max_am2 for a in scenario.actuator_list if a.kind == "magnetorquers"), float("inf"))


def _kinds(items):
    return {t.kind for t in items}


def _check_orbits(ctx):
    """Every spacecraft on an elliptic orbit clear of the Earth (one line otherwise)."""
    from coopsat.astro.kepler import check_orbit_clear_of_body, rv_to_elements

    orbit = ctx.scenario.orbit
    for name, r, v in zip(ctx.names, ctx.r_eci_m, ctx.v_eci_m_s):
        try:
            el = rv_to_elements(r, v, orbit.mu_m3_s2)
            check_orbit_clear_of_body(el.a_m, el.e, orbit.r_body_m)
        except ValueError as err:
            raise DesignError(f"spacecraft {name}: {err}") from None


def sun_pointing(ctx):
    """Each spacecraft's sun-pointing attitude at t = 0, (n, 4)."""
    import numpy as np

    from coopsat.astro.sun import sun_direction_eci
    from coopsat.design.observation_geometry import sun_pointing_quaternion

    sun = np.asarray(sun_direction_eci(epoch(ctx).jd_tt))
    return np.array([sun_pointing_quaternion(sun, r) for r in ctx.r_eci_m])


def _build(table, ctx):
    import numpy as np

    from coopsat.control.observation import ObservationSoftware
    from coopsat.design.observation_geometry import target_ecef
    from coopsat.sim.system import as_arrays

    scenario = ctx.scenario
    require_earth_orbit(ctx, "controller: observation")
    _check_orbits(ctx)
    actuators = _kinds(scenario.actuator_list)
    dump = table.dump_gain_1_s > 0.0
    if dump and "magnetorquers" not in actuators:
        raise DesignError("controller.dump_gain_1_s: momentum dumping needs a magnetorquers actuator")
    if dump and "magnetometer" not in _kinds(scenario.sensors):
        raise DesignError("controller.dump_gain_1_s: momentum dumping reads the field; add a magnetometer sensor")
    lat, lon = np.radians(table.target_lat_deg), np.radians(table.target_lon_deg)
    r_target, up = target_ecef(lat, lon, table.target_height_m)
    return ObservationSoftware(
        *as_arrays((
            sun_pointing(ctx).T, r_target, up, epoch(ctx).earth, scenario.orbit.mu_m3_s2, np.moveaxis(ctx.inertia_kgm2, 0, -1),
            table.k1, table.k2, table.torque_max_nm, table.dump_gain_1_s, _dipole_max(scenario),
            np.radians(table.min_elevation_deg),
            _reference(table, ctx), table.period_s,
        )),
        cooperative=table.law == "cooperative" and ctx.n > 1, wheels="reaction-wheels" in actuators, dump=dump,
    )


def check_visibility(table, ctx):
    """When the target rises above ``min_elevation_deg`` for each spacecraft (two-body + J2
    propagation of the initial state); a warning when it does not rise within the run."""
    import numpy as np

    from coopsat.design.observation_geometry import first_visible_s, target_ecef

    orbit = ctx.scenario.orbit
    if orbit is None:
        return None
    r_target, up = target_ecef(np.radians(table.target_lat_deg), np.radians(table.target_lon_deg), table.target_height_m)
    t_final = ctx.scenario.sim.t_final_s
    earth = epoch(ctx).earth
    rises, metrics = [], {}
    for name, r, v in zip(ctx.names, ctx.r_eci_m, ctx.v_eci_m_s):
        t = first_visible_s(r, v, r_target, up, earth, np.radians(table.min_elevation_deg), max(t_final, 86400.0),
                            orbit.mu_m3_s2, orbit.j2 if orbit.gravity == "j2" else 0.0, orbit.r_body_m)
        rises.append((name, t))
        metrics[f"target_rise_s_{name}"] = float("nan") if t is None else t
    late = [(name, t) for name, t in rises if t is None or t > t_final]
    say = "; ".join(f"{name}: {'not within a day' if t is None else f'{t:.0f} s'}" for name, t in rises)
    if late:
        return DesignCheck(
            "target-visibility", False,
            f"the target is below {table.min_elevation_deg:g}° elevation for the whole run ({t_final:g} s) for "
            f"{', '.join(name for name, _ in late)}, which keep pointing at the Sun; it rises at {say}",
            metrics,
        )
    return DesignCheck("target-visibility", True, f"the target rises above {table.min_elevation_deg:g}° at {say}", metrics)


def check_sun_start(table, ctx):
    """The spacecraft start in their sun-pointing attitude (the paper's initial mode)."""
    import numpy as np

    if ctx.scenario.orbit is None:
        return None
    q_s = sun_pointing(ctx)
    q0 = np.array([sc.q_bi for sc in ctx.scenario.spacecraft], dtype=float)
    q0 /= np.linalg.norm(q0, axis=1, keepdims=True)
    angle = np.degrees(2.0 * np.arccos(np.clip(np.abs(np.sum(q0 * q_s, axis=1)), 0.0, 1.0)))
    worst = int(np.argmax(angle))
    return DesignCheck(
        "sun-pointing-start", bool(angle[worst] < 1.0),
        f"initial attitude {angle[worst]:.3g}° from sun-pointing (worst: {ctx.names[worst]}; "
        f"sun-pointing q_bi = {np.round(q_s[worst], 9).tolist()})",
        {"initial_sun_pointing_error_deg": float(angle[worst])},
    )


def check_sampled_loop(table, ctx):
    """Law 8 linearised about its desired motion: per principal moment J a double integrator with
    ``θ̈ = −(k1/2J) θ − (k2/J) θ̇``, the command held over the period (spectral radius < 1)."""
    import numpy as np

    from coopsat.design.sampled_data import sampled_pd_radius

    moments = np.concatenate([np.linalg.eigvalsh(i) for i in ctx.inertia_kgm2])
    radii = [sampled_pd_radius(table.k1 / (2 * j), table.k2 / j, 0.0, table.period_s) for j in moments]
    worst = int(np.argmax(radii))
    stable = radii[worst] < 1.0
    return DesignCheck(
        "observation-sampled-loop", stable,
        f"staring law sampled at T = {table.period_s:g} s {'stable' if stable else 'UNSTABLE'}: spectral radius "
        f"{radii[worst]:.6f} (worst on {moments[worst]:.4g} kg·m²)",
        {"observation_spectral_radius": float(radii[worst])},
    )


def check_disturbance_budget(table, ctx):
    """What a random torque drawn every control period does to law 8 and to the wheels.

    Law 8 linearised about its desired motion is ``J θ̈ + k2 θ̇ + (k1/2) θ = τ`` per axis; a
    torque held over each period T with standard deviation σ has the low-frequency spectrum
    ``σ² T``, so the attitude jitter is ``σ_θ = σ √(T / (2 (k1/2) k2))`` whatever J. The
    momentum it leaves in the wheels walks as ``σ √(T t)``: its 3σ reaches the wheels'
    capacity on the weakest body axis after ``(h_cap / 3σ)² / T``. Fails when the 3σ jitter
    exceeds ``analysis.pointing_converged_deg`` or the walk fills the wheels within the run.
    """
    import math

    import numpy as np

    from coopsat.astro.magnetic import IGRF2020_DIPOLE_T, IGRF_RADIUS_M
    from coopsat.plugins.wheel_actuators import momentum_capacity_nms

    sigmas = [np.broadcast_to(np.asarray(d.sigma_nm, dtype=float), (3,)) for d in ctx.scenario.disturbances
              if d.kind == "random-torque"]
    if not sigmas:
        return None
    sigma = float(np.sqrt(np.sum(np.square(sigmas), axis=0)).max())
    period = ctx.period_s
    jitter_deg = float(np.degrees(sigma * np.sqrt(period / (2.0 * (table.k1 / 2.0) * table.k2))))
    saturating = math.erfc(table.torque_max_nm / (sigma * math.sqrt(2.0)))
    metrics = {"random_torque_jitter_deg": jitter_deg, "random_torque_saturating_fraction": saturating}
    say = (f"random torque {sigma:.3g} N·m per axis each {period:g} s ({sigma / table.torque_max_nm:.1%} of the "
           f"{table.torque_max_nm:g} N·m command limit, exceeding it on an axis in {saturating:.2%} of periods): "
           f"predicted jitter {jitter_deg:.3g}° (1σ, law 8 linearised)")
    ok = 3.0 * jitter_deg < ctx.scenario.analysis.pointing_converged_deg
    wheels = next((a for a in ctx.scenario.actuator_list if a.kind == "reaction-wheels"), None)
    if wheels is not None:
        h_cap = float(momentum_capacity_nms(wheels).min())
        fill_s = (h_cap / (3.0 * sigma)) ** 2 / period
        metrics["random_torque_wheel_fill_s"] = fill_s
        say += f"; its momentum's 3σ walk fills the weakest axis's {h_cap:.3g} N·m·s in {fill_s:.3g} s"
        ok = ok and fill_s > ctx.scenario.sim.t_final_s
    torquers = next((a for a in ctx.scenario.actuator_list if a.kind == "magnetorquers"), None)
    if torquers is not None:
        r_max = max(float(np.linalg.norm(r)) for r in ctx.r_eci_m)
        field_t = float(np.linalg.norm(IGRF2020_DIPOLE_T)) * (IGRF_RADIUS_M / r_max) ** 3
        say += (f"; magnetorquers give at most {torquers.dipole_max_am2 * field_t:.2g} N·m "
                f"(field ≥ {field_t * 1e6:.3g} µT), dumping {torquers.dipole_max_am2 * field_t * ctx.scenario.sim.t_final_s:.3g} "
                "N·m·s over the run at full dipole")
    return DesignCheck("disturbance-budget", ok, say, metrics)


class PointingThreshold(Table):
    """``[analysis]`` threshold of the observation paper's convergence metrics (SPEC §5)."""

    pointing_converged_deg: float = Field(
        0.05, gt=0, le=180, description="Staring attitude error that counts as converged after the switch, deg (SPEC §5)."
    )


register(Plugin(
    "controller", "observation", Observation, _build,
    (check_visibility, check_sun_start, check_sampled_loop, check_disturbance_budget),
    analysis="coopsat.analysis.papers.observation_2019",
    thresholds=PointingThreshold,
))
