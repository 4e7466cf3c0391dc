"""The deep-space formation paper's metrics and explanations (SPEC §4).

* Formation error: each spacecraft's position relative to the formation's centroid against its
  target relative to the target's centroid (translation removed: the centroid is unobservable
  from relative measurements and is judged apart), largest over spacecraft, m.
* Fuel, the paper's ``J = Σ_i ∫|u_i| dt``: per axis (``Σ_i ∫|u_ix| dt``…), their sum (the L1
  reading) and ``Σ_i ∫‖u_i‖₂ dt`` (the 2-norm reading), N·s; from the thrusters' counters, so
  the dead zone and limits are in it.
* Centroid drift caused by the control: the centroid's displacement due to the net thrust,
  ``Δc(t) = ∫₀ᵗ Σ_i I_i(s) / (n m) ds`` with ``I_i`` the cumulative impulse of spacecraft i —
  what centroid holding is meant to cancel (the common solar pressure moves every spacecraft
  alike and is not the formation's doing).

The 10.6 % fuel saving the paper reports is a paired claim; a single run cannot check it, and
one tuned pair does not decide it either: ``coopsat tradeoff`` compares both designs' fuel at
the same settling time (:mod:`coopsat.analysis.tradeoff`).
"""

import numpy as np

from coopsat.analysis.metrics import run_rows, settle_times_s
from coopsat.analysis.surrogates import Surrogate, settled_by, time_weighted_error

FIGURES = "coopsat.plots.formation"
"""Module with this paper's figures (``figures(ds, built) -> {stem: Figure}``); the pipeline
draws them beside the standard ones."""


def formation_error_m(r_m, target_m, axes):
    """Largest distance of a spacecraft from its slot, translation removed, m.

    Parameters
    ----------
    r_m : (..., T, n, 3)
        Positions (any inertial origin), m; a leading axis: runs of a batch.
    target_m : (..., n, d)
        Target positions in the design axes, m (any origin), of each run.
    axes : sequence of int
        The design axes (length d); the other axes' targets are the initial plane (zero
        relative offset).

    Returns
    -------
    ndarray (..., T)
    """
    target_m = np.asarray(target_m, dtype=float)
    rel = r_m - r_m.mean(axis=-2, keepdims=True)
    goal = np.zeros((*target_m.shape[:-1], 3))
    goal[..., list(axes)] = target_m - target_m.mean(axis=-2, keepdims=True)
    return np.linalg.norm(rel - goal[..., None, :, :], axis=-1).max(axis=-1)


def centroid_drift_m(t_s, impulse_ns, mass_kg):
    """Displacement of the centroid caused by the net thrust, (..., T, 3), m.

    Parameters
    ----------
    t_s : (T,)
    impulse_ns : (..., T, n, 3)
        Cumulative signed impulse of each spacecraft's thrusters (inertial axes), N·s.
    mass_kg : float or ndarray (...)
        Mass of each spacecraft (equal masses), of each run.
    """
    from scipy.integrate import cumulative_trapezoid

    mass = np.asarray(mass_kg, dtype=float)[..., None, None]
    dv = impulse_ns.sum(axis=-2) / (impulse_ns.shape[-2] * mass)
    return cumulative_trapezoid(dv, t_s, axis=-2, initial=0.0)


def metrics(ds, built):
    """Formation, fuel and centroid metrics of a formation-observer run (:func:`batch_metrics`
    of a batch of one).

    Returns
    -------
    dict
        ``formation_error_final_m``, ``formation_error_late_max_m`` (last 10 % of the run),
        ``settling_time_s`` (error below ``analysis.formation_tolerance_m`` to the end, held
        ``settle_hold_s``), ``fuel_l1_ns`` with ``fuel_l1_x_ns`` … per axis, ``fuel_l2_ns``,
        ``centroid_drift_max_m``, ``centroid_drift_final_m``, ``relayed_lines_total``.
    """
    return run_rows(batch_metrics(ds.expand_dims("run"), [built]), 1)[0]


def batch_metrics(ds, builds):
    """:func:`metrics` of every run of a batch at once (``ds``: its record, ``run`` first), each
    an array over the runs (NaN for a time never reached)."""
    from coopsat.plugins.formation import PLANES

    tables = [b.scenario.controller for b in builds]
    tolerance, hold = (np.array([getattr(b.scenario.analysis, f) for b in builds], dtype=float)
                       for f in ("formation_tolerance_m", "settle_hold_s"))
    t = ds["time"].values
    targets = np.stack([np.asarray(tb.target_m, dtype=float) for tb in tables])  # (R, n, d)
    err = formation_error_m(ds["r_eci"].values, targets, PLANES[tables[0].plane])  # (R, T); the plane is structure
    late = t >= t[0] + 0.9 * (t[-1] - t[0])
    m = {
        "formation_error_final_m": err[:, -1],
        "formation_error_late_max_m": err[:, late].max(axis=-1),
        "settling_time_s": settle_times_s(t, err < tolerance[:, None], hold, axis=1),
    }
    if "abs_force_impulse" in ds:
        per_axis = ds["abs_force_impulse"].values[:, -1].sum(axis=1)  # (R, 3)
        m.update({f"fuel_l1_{c}_ns": per_axis[:, k] for k, c in enumerate("xyz")})
        m["fuel_l1_ns"] = per_axis.sum(axis=-1)
    if "norm_force_impulse" in ds:
        m["fuel_l2_ns"] = ds["norm_force_impulse"].values[:, -1].reshape(len(builds), -1).sum(axis=-1)
    if "force_impulse" in ds:
        mass = np.array([float(b.scenario.spacecraft[0].mass_kg) for b in builds])
        drift = np.linalg.norm(centroid_drift_m(t, ds["force_impulse"].values, mass), axis=-1)  # (R, T)
        m["centroid_drift_max_m"] = drift.max(axis=-1)
        m["centroid_drift_final_m"] = drift[:, -1]
    if "relayed_lines" in ds:
        m["relayed_lines_total"] = ds["relayed_lines"].values.reshape(len(builds), -1).sum(axis=-1).astype(float)
    return m


EXPLAINERS = {}
"""No bundled deep-space scenario compares a single run with a published number: the paper's
10.6 % is a paired claim, judged by ``coopsat tradeoff``."""


def _formation_error(samples, built):
    """:func:`formation_error_m` in JAX on the run's samples, (T,), m."""
    import jax.numpy as jnp

    from coopsat.plugins.formation import PLANES

    table = built.scenario.controller
    axes = list(PLANES[table.plane])
    target = np.asarray(table.target_m, dtype=float)
    goal = np.zeros((target.shape[0], 3))
    goal[:, axes] = target - target.mean(axis=0)
    r = samples["r_eci"]
    rel = r - r.mean(axis=1, keepdims=True)
    # A smooth largest distance over spacecraft (the exact metric's max), in metres.
    dist = jnp.sqrt(jnp.sum((rel - goal) ** 2, axis=-1) + 1e-12)
    return jnp.max(dist, axis=-1)


def _fuel(samples, t_s, built, system):
    return samples["abs_force_impulse"][-1].sum()


def _settling_constraint(samples, t_s, built, system, bound_s):
    return settled_by(t_s, _formation_error(samples, built) / built.scenario.analysis.formation_tolerance_m, bound_s)


def _settling_objective(samples, t_s, built, system):
    return time_weighted_error(t_s, _formation_error(samples, built))


def _final_error_constraint(samples, t_s, built, system, bound_m):
    return _formation_error(samples, built)[-1] / bound_m - 1.0


def _radius_constraint(samples, t_s, built, system, bound):
    """The sampled closed loop's spectral radius (plant, observer, law; no dead zone) of the
    tuned flight software, over ``bound``, minus 1."""
    import jax.numpy as jnp

    from coopsat.analysis.surrogates import spectral_radius_bound
    from coopsat.plugins.formation import closed_loop_matrix

    a_d, b_d, c_y = built.checks["formation-design"].detail["plant_d"]
    c = system.controller
    m = {"c_u": c.c_u, "gamma_y": c.gamma_y, "gamma_u": c.gamma_u, "phi": c.phi}
    return spectral_radius_bound(closed_loop_matrix(jnp.asarray(a_d), jnp.asarray(b_d), jnp.asarray(c_y), m, jnp)) / bound - 1.0


SURROGATES = {
    "closed_loop_spectral_radius": Surrogate(
        None, _radius_constraint,
        "Gelfand's ‖M^k‖^(1/k), k = 2^14, of the sampled closed loop with the tuned gains: a smooth upper bound of the "
        "spectral radius (the eigenvalues repeat across coordinates, where |eig| has no derivative)",
    ),
    "fuel_l1_ns": Surrogate(
        _fuel, lambda s, t, b, sys, bound: _fuel(s, t, b, sys) / bound - 1.0,
        "Σ∫|F| dt from the thrusters' counter, on the smoothed thrusters", exact_in_metric_units=True,
    ),
    "settling_time_s": Surrogate(
        _settling_objective, _settling_constraint,
        "objective: ∫t·e(t)dt/∫t dt of the formation error e (ITAE); constraint: log-sum-exp of e/tolerance over "
        "the samples at or after the bound, ≤ 1 (an upper bound of the max: slightly conservative)",
    ),
    "formation_error_final_m": Surrogate(
        lambda s, t, b, sys: _formation_error(s, b)[-1], _final_error_constraint,
        "the formation error at the last sample (the metric itself, on the smoothed loop)", exact_in_metric_units=True,
    ),
}
