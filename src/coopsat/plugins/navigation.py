"""Navigation filters (``[navigation]``): the law flies on each spacecraft's estimate instead of on
truth.

``kind = "relative-ekf"``: every spacecraft's flight software runs an extended Kalman filter of
its state relative to the chief in the chief's LVLH frame (:mod:`coopsat.control.relative_ekf`)
on differential GNSS (the chief's fix over the network), inter-satellite range and range-rate,
and a camera's bearing to the chief, and the law reads the estimate as its ``x_lvlh``
(:mod:`coopsat.control.navigated`).
The filter's measurement noise is the sensors' own (their tables), its process noise the
table's. Design checks: every covariance positive definite, every measurement's rate a whole
multiple of the control period (the sensors' own check), the filter's sensors present.
"""

from typing import Literal

import numpy as np
from pydantic import Field

from coopsat.plugins import DesignCheck, DesignError, Plugin, register
from coopsat.plugins.sensors import PerAxis
from coopsat.plugins.tables import MAX_TIME_S, Table, whole_ratio

_SENSOR_QUANTITY = {"gnss": "gnss", "isl-range": "isl", "camera-bearing": "bearing"}


class FilterTable(Table):
    """What every navigation filter's table gives: its process noise and where it starts."""

    accel_psd_m2_s3: PerAxis = Field(
        description="Process noise: spectral density of the white acceleration the model leaves out, per axis of the "
                    "estimate's frame, m²/s³."
    )
    initial_sigma_m: PerAxis = Field(description="Initial standard deviation of the position per axis, m.")
    initial_sigma_m_s: PerAxis = Field(description="Initial standard deviation of the velocity per axis, m/s.")
    draw_initial_error: bool = Field(
        True, description="Start each filter from the scenario's initial state plus an error drawn from the initial "
                          "covariance (seeded); false: from the initial state itself."
    )


class RelativeEkf(FilterTable):
    """``kind = "relative-ekf"``: each spacecraft estimates its state relative to the chief (EKF)."""

    kind: Literal["relative-ekf"]
    chief: str = Field(description="The reference spacecraft: the origin of every estimated relative state.")
    measurements: list[Literal["gnss", "isl-range", "camera-bearing"]] = Field(
        min_length=1, description='The sensors the filter uses, by kind: "gnss" (differential, the chief\'s fix over '
                                  'the network), "isl-range" (range and range-rate to the chief), "camera-bearing" '
                                  '(the line of sight to the chief; needs "gnss").'
    )
    max_age_s: float = Field(
        0.0, ge=0, le=MAX_TIME_S,
        description="Oldest chief's fix processed (at its time stamp), s; older ones are dropped. A whole multiple of "
                    "the control period.",
    )


def sensor_table(ctx, kind):
    """The ``[[sensors]]`` table of ``kind`` the filter uses (DesignError when there is none)."""
    tables = [t for t in ctx.scenario.sensors if t.kind == kind]
    if not tables:
        raise DesignError(f'navigation.measurements: "{kind}" needs a [[sensors]] table kind = "{kind}"')
    return tables[0]


def _positive(name, values, where):
    """A per-axis value as (3,), every axis > 0; else one line naming the field (a covariance
    built from it would not be positive definite)."""
    v = np.broadcast_to(np.asarray(values, dtype=float), (3,))
    if np.any(v <= 0.0):
        raise DesignError(f"{where}: the filter needs {name} positive definite; every axis must be > 0, got {v.tolist()}")
    return v


def _gnss_noise(table):
    """Variance of the difference of two receivers' fixes per ECI axis (6,): white and own
    Gauss–Markov terms of both; the common term cancels."""
    pos = 2.0 * (np.square(np.broadcast_to(table.sigma_m, 3)) + np.square(np.broadcast_to(table.own_sigma_m, 3)))
    vel = 2.0 * (np.square(np.broadcast_to(table.sigma_m_s, 3)) + np.square(np.broadcast_to(table.own_sigma_m_s, 3)))
    r = np.concatenate([pos, vel]).astype(float)
    if np.any(r <= 0.0):
        raise DesignError(
            'navigation: the "gnss" sensor\'s noise (sigma_m, sigma_m_s, own_sigma_m, own_sigma_m_s) is zero on an axis, so '
            "the differential fix's covariance is not positive definite; give the sensor its noise"
        )
    return r


def _isl_noise(table, ctx, chief):
    if ctx.index(table.to, "sensors.to") != chief:
        raise DesignError(f'navigation: the "isl-range" sensor ranges to {table.to}, the filter estimates relative to the chief')
    r = np.array([table.sigma_m, table.sigma_m_s], dtype=float) ** 2
    if np.any(r <= 0.0):
        raise DesignError('navigation: the "isl-range" sensor\'s sigma_m and sigma_m_s must be > 0 (the filter needs R positive definite)')
    return r


def _bearing_noise(table, ctx, chief, use):
    """Variance of the bearing's angular error about each axis across the line of sight, rad²."""
    if ctx.index(table.to, "sensors.to") != chief:
        raise DesignError(f'navigation: the "camera-bearing" sensor looks at {table.to}, the filter estimates relative to the chief')
    if "gnss" not in use:
        raise DesignError('navigation.measurements: "camera-bearing" needs "gnss" too (its own fix gives the LVLH axes of the line of sight)')
    if table.sigma_rad <= 0.0:
        raise DesignError('navigation: the "camera-bearing" sensor\'s sigma_rad must be > 0 (the filter needs R positive definite)')
    return table.sigma_rad**2


def filter_noise(table):
    """The process noise's spectral density (3,) and the initial standard deviations (6,) of a
    filter's table; one line naming the field when a covariance is not positive definite."""
    q = _positive("accel_psd_m2_s3 (Q)", table.accel_psd_m2_s3, "navigation.accel_psd_m2_s3")
    sigma0 = np.concatenate([
        _positive("initial_sigma_m (P0)", table.initial_sigma_m, "navigation.initial_sigma_m"),
        _positive("initial_sigma_m_s (P0)", table.initial_sigma_m_s, "navigation.initial_sigma_m_s"),
    ])
    return q, sigma0


def sensor_every(ctx, kind):
    period = sensor_table(ctx, kind).period_s
    return 1 if period is None else whole_ratio(period, ctx.period_s)


def chief_mean_motion(ctx, chief):
    """The chief's mean motion from its initial state, rad/s (its osculating semi-major axis)."""
    from coopsat.astro.kepler import rv_to_elements

    mu = ctx.scenario.orbit.mu_m3_s2
    try:
        a_m = rv_to_elements(ctx.r_eci_m[chief], ctx.v_eci_m_s[chief], mu)[0]
    except ValueError as err:
        raise DesignError(f"navigation.chief: {err}") from None
    return float(np.sqrt(mu / a_m**3))


def relative_model(n_rad_s, period_s, q_m2_s3, max_periods):
    """The relative filter's model over 0..``max_periods + 1`` control periods.

    Parameters
    ----------
    n_rad_s : float
        The chief's mean motion, rad/s.
    period_s : float
        Control period T, s.
    q_m2_s3 : (3,)
        Spectral density of the white acceleration noise per LVLH axis, m²/s³.
    max_periods : int
        The oldest fix processed, in periods (≥ 0).

    Returns
    -------
    phi_k : (max_periods + 2, 6, 6)
        Φ(jT) for j = 0..max_periods + 1 (``phi_k[1]`` is the one-period transition).
    gamma : (6, 3)
        ZOH input matrix over one period, s and s² (input: acceleration, m/s²).
    q_k : (max_periods + 2, 6, 6)
        Process noise accumulated over j periods, ``Q_j = Σ_{m<j} Φ^m Q Φ^mᵀ``.

    Notes
    -----
    The Clohessy–Wiltshire equations (SPEC §2 eq. 1, :func:`coopsat.dynamics.cw.cw_matrices`)
    held over each period (:func:`coopsat.design.riccati.discretize`) under white acceleration
    noise (:func:`coopsat.design.riccati.sampled_noise`).
    """
    from coopsat.design.riccati import discretize, sampled_noise
    from coopsat.dynamics.cw import cw_matrices

    a, b = (np.asarray(m) for m in cw_matrices(n_rad_s))
    phi, gamma = discretize(a, b, period_s)
    q = sampled_noise(a, b @ np.diag(q_m2_s3) @ b.T, period_s)
    phi_k, q_k = [np.eye(6)], [np.zeros((6, 6))]
    for _ in range(max_periods + 1):
        q_k.append(phi @ q_k[-1] @ phi.T + q)
        phi_k.append(phi @ phi_k[-1])
    return np.stack(phi_k), gamma, np.stack(q_k)


def _initial_relative(ctx, chief):
    """Every spacecraft's initial state relative to the chief, LVLH, (6, n)."""
    from coopsat.geometry.frames import eci_to_lvlh

    rho, rho_dot = eci_to_lvlh(ctx.r_eci_m[chief], ctx.v_eci_m_s[chief], ctx.r_eci_m, ctx.v_eci_m_s)
    return np.concatenate([np.asarray(rho), np.asarray(rho_dot)], axis=1).T


def _build(table, ctx):
    from coopsat.control.relative_ekf import RelativeEkf as Part
    from coopsat.sim.system import as_arrays

    if ctx.scenario.orbit is None:
        raise DesignError("navigation: relative-ekf estimates relative orbits; it needs an [orbit] table")
    chief = ctx.index(table.chief, "navigation.chief")
    masses = [sc.mass_kg for sc in ctx.scenario.spacecraft]
    if any(m is None for m in masses):
        raise DesignError("navigation: relative-ekf turns commanded forces into accelerations; give every spacecraft mass_kg")
    q, sigma0 = filter_noise(table)
    max_age = 0 if table.max_age_s == 0.0 else whole_ratio(table.max_age_s, ctx.period_s)
    if max_age is None:
        raise DesignError(
            f"navigation.max_age_s ({table.max_age_s:g} s) must be a whole multiple of the control period ({ctx.period_s:g} s)"
        )
    use = set(table.measurements)
    r_gnss = _gnss_noise(sensor_table(ctx, "gnss")) if "gnss" in use else np.ones(6)
    r_isl = _isl_noise(sensor_table(ctx, "isl-range"), ctx, chief) if "isl-range" in use else np.ones(2)
    r_bearing = _bearing_noise(sensor_table(ctx, "camera-bearing"), ctx, chief, use) if "camera-bearing" in use else 1.0
    phi_k, gamma, q_k = relative_model(chief_mean_motion(ctx, chief), ctx.period_s, q, max_age)
    arrays = (phi_k, q_k, gamma, _initial_relative(ctx, chief), sigma0, r_gnss, r_isl, r_bearing,
              np.asarray(masses, dtype=float), np.int32(chief), ctx.period_s)
    return Part(
        *as_arrays(arrays),
        gnss_every=sensor_every(ctx, "gnss") if "gnss" in use else 0,
        isl_every=sensor_every(ctx, "isl-range") if "isl-range" in use else 0,
        bearing_every=sensor_every(ctx, "camera-bearing") if "camera-bearing" in use else 0,
        draw_initial=table.draw_initial_error,
    )


def check_steady_state(table, ctx):
    """The filter's steady state on differential GNSS alone (the discrete Riccati equation of its
    model, fixes every period): the position standard deviation it settles to per LVLH axis."""
    if "gnss" not in table.measurements or ctx.scenario.orbit is None:
        return None
    from coopsat.design.riccati import steady_kalman

    chief = ctx.index(table.chief, "navigation.chief")
    q = np.broadcast_to(np.asarray(table.accel_psd_m2_s3, dtype=float), (3,))
    every = sensor_every(ctx, "gnss")
    phi_k, _, q_k = relative_model(chief_mean_motion(ctx, chief), ctx.period_s * every, q, 0)
    r = np.diag(_gnss_noise(sensor_table(ctx, "gnss")))  # isotropic noise: the same in LVLH axes
    _, posterior = steady_kalman(phi_k[1], np.eye(6), q_k[1], r)
    sigma = np.sqrt(np.diag(posterior)[:3])
    return DesignCheck(
        "relative-ekf", True,
        f"relative-ekf steady state on differential GNSS every {ctx.period_s * every:g} s: position σ "
        f"{', '.join(f'{s * 1e3:.2f}' for s in sigma)} mm (x, y, z LVLH)",
        {"relative_ekf_steady_sigma_m": float(np.max(sigma))},
    )


register(Plugin("navigation", "relative-ekf", RelativeEkf, _build, (check_steady_state,),
                analysis="coopsat.analysis.papers.navigation"))
