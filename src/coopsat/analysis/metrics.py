"""Metrics of a run: synchronisation and tracking times, final errors, thruster use.

Pure NumPy on the recorded samples (a :class:`xarray.Dataset` from
:func:`coopsat.sim.recorder.to_dataset`). Times are resolved to the record interval: a
"settle time" is the first *recorded* instant after which a condition holds at every later
sample, and None (JSON null) when it does not hold at the last sample.
"""

import numpy as np

from coopsat.geometry.quaternion import quat_angle, quat_error, quat_rotate

EXACT_PAIRS_MAX_N = 64
"""Up to this many spacecraft every pair is compared; above it, each one against the first
(the pairwise maximum is then bounded by twice the reported value)."""


def quat_angle_between_deg(q_a, q_b, axis=-1):
    """Rotation angle between attitudes, deg, in [0, 180]; shapes (..., 4) -> (...) (``axis``:
    the component axis).

    Notes
    -----
    The angle of the error quaternion ``q_b* ⊗ q_a`` (sign invariant: q and −q are one
    attitude), formed from its vector part rather than ``acos`` of a dot product, which loses
    everything below about 1e-6 deg to rounding.
    """
    return np.degrees(np.asarray(quat_angle(quat_error(q_a, q_b, axis), axis)))


PAIRWISE_BLOCK_SAMPLES = 4096
"""Samples compared per block in :func:`_pairwise_max`: a block's temporaries stay in the
CPU's cache (a batch of 100 runs whole is 2.5× slower than in blocks)."""


def _pairwise_max(x, distance):
    """Largest ``distance(a, b, axis)`` over pairs of spacecraft at each sample; x (..., n, k) ->
    (...) (the leading axes: time, or run and time).

    The samples go in blocks of :data:`PAIRWISE_BLOCK_SAMPLES`, each block's pairs gathered
    component-major, (k, samples, pairs), so that each component is one contiguous array: the
    quaternion algebra then stacks whole rows, not strided elements."""
    n, k = x.shape[-2:]
    if n < 2:
        return np.zeros(x.shape[:-2])
    if n <= EXACT_PAIRS_MAX_N:
        i, j = np.triu_indices(n, k=1)
    else:
        i, j = np.arange(1, n), np.zeros(n - 1, dtype=int)
    flat = np.ascontiguousarray(np.moveaxis(np.reshape(x, (-1, n, k)), -1, 0))  # (k, samples, n)
    step = PAIRWISE_BLOCK_SAMPLES
    blocks = [distance(b[..., i], b[..., j], 0).max(axis=-1) for b in (flat[:, s:s + step] for s in
                                                                      range(0, flat.shape[1], step))]
    return np.concatenate(blocks).reshape(x.shape[:-2])


def pairwise_attitude_error_deg(q):
    """Largest attitude difference over pairs of spacecraft at each sample, deg.

    Parameters
    ----------
    q : ndarray, shape (..., T, n, 4)

    Returns
    -------
    ndarray, shape (..., T)
    """
    return _pairwise_max(q, quat_angle_between_deg)


def pairwise_rate_difference_rad_s(omega):
    """Largest ``|ω_i − ω_j|`` (body components, as law (3) compares them) at each sample, rad/s.

    Parameters
    ----------
    omega : ndarray, shape (..., T, n, 3)

    Returns
    -------
    ndarray, shape (..., T)
    """
    return _pairwise_max(omega, lambda a, b, axis: np.linalg.norm(a - b, axis=axis))


def settle_times_s(t_s, ok, hold_s=0.0, axis=0):
    """First sample time after which ``ok`` holds at every later sample, NaN where never:
    :func:`settle_time_s` over every other axis at once (runs of a batch, spacecraft).

    Parameters
    ----------
    t_s : ndarray, shape (T,)
    ok : ndarray of bool, T samples along ``axis``
    hold_s : float or ndarray
        As :func:`settle_time_s`; an array broadcasts against the result (one per run).
    axis : int
        The time axis of ``ok``.

    Returns
    -------
    ndarray of float
        ``ok``'s shape without ``axis``.
    """
    ok = np.moveaxis(np.asarray(ok, dtype=bool), axis, -1)
    last = ok.shape[-1] - 1
    # The sample after the last failing one (0 when none fails).
    first_good = np.where(ok.all(axis=-1), 0, last + 1 - np.argmax(~ok[..., ::-1], axis=-1))
    settled = t_s[np.minimum(first_good, last)]
    return np.where(ok[..., -1] & (t_s[-1] - settled >= hold_s), settled, np.nan)


def settle_time_s(t_s, ok, hold_s=0.0):
    """First sample time after which ``ok`` holds at every later sample; None if never.

    Parameters
    ----------
    t_s : ndarray, shape (T,)
    ok : ndarray of bool, shape (T,) or (T, k)
        With a second axis, returns one time per column.
    hold_s : float
        The condition must have held for at least this long by the end of the run; a
        condition met only in the last moments is not called settled.

    Returns
    -------
    float or None, or list of those
    """
    times = settle_times_s(t_s, ok, hold_s)
    return none_for_nan(times) if times.ndim == 0 else [none_for_nan(v) for v in times]


def none_for_nan(value):
    """A metric's number as JSON has it: a Python float, None for NaN (a time never reached;
    no metric is NaN otherwise, metrics.json refuses it)."""
    value = float(value)
    return None if np.isnan(value) else value


def arrival_time_s(t_s, ok, hold_s=0.0):
    """First sample time from which ``ok`` holds for at least ``hold_s``; None if never.

    Unlike :func:`settle_time_s` the condition may fail again later (a keeping error that
    arrives in its band and then rattles about its edge has still arrived).

    Parameters
    ----------
    t_s : ndarray, shape (T,)
    ok : ndarray of bool, shape (T,)
    hold_s : float

    Returns
    -------
    float or None
    """
    ok = np.asarray(ok, dtype=bool)
    # End of the run of consecutive True samples each sample belongs to (its own time if False).
    idx = np.arange(ok.size)
    next_bad = np.minimum.accumulate(np.where(~ok, idx, ok.size)[::-1])[::-1]
    run_end = t_s[np.maximum(next_bad - 1, 0)]
    held = ok & (run_end - t_s >= hold_s)
    return float(t_s[np.argmax(held)]) if held.any() else None


def inertial_angular_momentum_nms(q, omega, inertia_kgm2, h_wheels_b_nms=0.0):
    """Total angular momentum of the formation in inertial components, N·m·s.

    Parameters
    ----------
    q : ndarray, shape (..., T, n, 4)
    omega : ndarray, shape (..., T, n, 3)
    inertia_kgm2 : ndarray, shape (..., n, 3, 3)
    h_wheels_b_nms : ndarray, shape (..., n, 3) or (..., T, n, 3), optional
        Wheel momentum relative to each body, body components.

    Returns
    -------
    ndarray, shape (..., T, 3)
        ``Σ_i C(q_i) (I_i ω_i + h_w,i)``. Law (3) pushes on each spacecraft in its own body axes, so it
        does not conserve this exactly, but near agreement its torques nearly cancel: a
        formation that starts with momentum ends spinning together, not at rest.
    """
    h_w = np.asarray(h_wheels_b_nms, dtype=float)
    if h_w.ndim == np.ndim(omega) - 1:  # constant over time
        h_w = np.expand_dims(h_w, -3)
    h_b = np.einsum("...nij,...tnj->...tni", inertia_kgm2, omega) + h_w
    return np.asarray(quat_rotate(q, h_b)).sum(axis=-2)


TORQUE_UNITS = "N m"
"""``units`` of every recorded torque (actuators and disturbances alike, docs/scenarios.md)."""


def attitude_moves(ds, initial_rate_rad_s=None, initial_angle_rad=None):
    """Whether the run simulates attitude motion: something can torque a spacecraft (the record
    holds a torque, in :data:`TORQUE_UNITS`) or one starts turning or turned.

    A translation-only run (deep space, cartwheel keeping) carries a constant attitude at rest:
    its rates, attitude errors and angular momentum are zero because they are not simulated,
    not because a controller achieved it.

    Parameters
    ----------
    ds : xarray.Dataset
        Run record (only its variables' ``units`` are read, and ``omega``/``angle`` at t = 0
        unless given).
    initial_rate_rad_s, initial_angle_rad : array_like, optional
        Initial body rates and small angles (n, 3), rad/s and rad, in place of the record's
        first sample (the scenario's values, for a stand-in record).

    Returns
    -------
    bool
    """
    if records_torque(ds):
        return True
    rate = ds["omega"].values[0] if initial_rate_rad_s is None else initial_rate_rad_s
    angle = (ds["angle"].values[0] if "angle" in ds else 0.0) if initial_angle_rad is None else initial_angle_rad
    return bool(np.any(np.asarray(rate) != 0.0) or np.any(np.asarray(angle) != 0.0))


def records_torque(ds):
    """Whether a run record holds a torque (a variable in :data:`TORQUE_UNITS`): something can
    turn its spacecraft."""
    return any(v.attrs.get("units") == TORQUE_UNITS for v in ds.data_vars.values())


def run_metrics(ds, names, inertia_kgm2, h_wheels_b_nms=0.0, attitude=True):
    """Metrics every run has, as a flat dict of named numbers (unit at the end of each name).

    A paper's own metrics (synchronisation and tracking times, …) come from its analysis
    module (:mod:`coopsat.analysis.papers`).

    Parameters
    ----------
    ds : xarray.Dataset
        From :func:`coopsat.sim.recorder.to_dataset` (single run).
    names : sequence of str
        Spacecraft names.
    inertia_kgm2 : ndarray, shape (n, 3, 3)
    h_wheels_b_nms : ndarray, shape (n, 3) or (T, n, 3), optional
        Wheel momentum of each spacecraft (in the formation's angular momentum).
    attitude : bool
        Whether the run simulates attitude motion (:func:`attitude_moves`); without it the
        rate and angular momentum metrics are left out.

    Returns
    -------
    dict of str -> float, int or None
        Final largest rate and the formation's inertial angular momentum at both ends
        (rigid-body attitude model), when attitude is simulated; per spacecraft every actuator
        counter the run recorded (impulse, thruster on-time and firings).
    """
    h_w = np.expand_dims(np.asarray(h_wheels_b_nms, dtype=float), 0)
    return run_rows(batch_run_metrics(ds.expand_dims("run"), names, np.expand_dims(inertia_kgm2, 0), h_w, attitude), 1)[0]


def batch_run_metrics(ds, names, inertia_kgm2, h_wheels_b_nms=0.0, attitude=True):
    """:func:`run_metrics` of every run of a batch at once: each metric an array over the runs.

    Parameters
    ----------
    ds : xarray.Dataset
        The batch's record, dimension ``run`` first (:func:`coopsat.sim.recorder.to_dataset`
        with ``batched=True``).
    names : sequence of str
        Spacecraft names (the same in every run of a batch).
    inertia_kgm2 : ndarray, shape (R, n, 3, 3)
    h_wheels_b_nms : ndarray, shape (R, n, 3), optional
    attitude : bool
        Whether the runs simulate attitude motion (the same in all of them).

    Returns
    -------
    dict of str -> ndarray, shape (R,)
        Integer counters as integers; :func:`run_rows` makes one dict per run.

    Notes
    -----
    ``h_wheels_b_nms`` is read only where the record has no ``h_wheels`` series.
    """
    omega = ds["omega"].values
    m = {"final_rate_max_rad_s": np.linalg.norm(omega[:, -1], axis=-1).max(axis=-1)} if attitude else {}
    if attitude and "q" in ds:  # the rigid-body attitude model (the small-angle model has no inertial attitude)
        ends = [0, -1]  # only the first and last samples are reported
        h_w = ds["h_wheels"].values[:, ends] if "h_wheels" in ds else h_wheels_b_nms
        h = inertial_angular_momentum_nms(ds["q"].values[:, ends], omega[:, ends], inertia_kgm2, h_w)
        m["angular_momentum_initial_nms"] = np.linalg.norm(h[:, 0], axis=-1)
        m["angular_momentum_final_nms"] = np.linalg.norm(h[:, -1], axis=-1)
    counters = [("impulse", "impulse_nms"), ("thruster_on_time", "on_time_s"), ("thruster_firings", "firings")]
    for var, unit in counters:
        if var in ds and (var != "thruster_firings" or "thruster_on_time" in ds):
            total = ds[var].values[:, -1].sum(axis=-1)  # (R, n)
            m.update({f"{name}_{unit}": total[:, i] for i, name in enumerate(names)})
    return m


def run_rows(metrics, runs):
    """One dict per run of a batch's metrics (``{name: array (runs,)}``): integers as ``int``,
    other numbers as ``float``, NaN (a time never reached) as None."""
    columns = [_column(np.asarray(v)) for v in metrics.values()]
    return [dict(zip(metrics, row)) for row in zip(*columns)] if columns else [{} for _ in range(runs)]


def _column(values):
    if values.dtype.kind in "iu":
        return values.tolist()
    return [None if v != v else v for v in values.astype(float).tolist()]  # v != v: NaN
