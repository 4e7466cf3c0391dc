"""Sensors (``[[sensors]]``): star tracker, rate gyro, navigation (position / velocity) noise,
relative position between spacecraft, relative navigation in the chief's LVLH frame, a GNSS
receiver, an inter-satellite range / range-rate link, a camera's bearing to another spacecraft,
and the sun sensor and magnetometer of an Earth orbit.

Each table replaces one quantity the flight software reads by what a sensor measures; a
quantity no sensor measures is read perfectly. Every sensor may update more slowly than the
controller (``period_s``, a whole multiple of the control period); its reading is held in
between. Noise derives from the scenario's ``seed``, so a run replays bit for bit.
"""

from typing import Annotated, Literal

import numpy as np
from pydantic import Field, PlainValidator

from coopsat.plugins import DesignError, Plugin, register
from coopsat.plugins.tables import Record, Table, UnitVector, Vec3, whole_ratio


def _per_axis_sigma(v):
    """One number, or three ``[x, y, z]``; finite and ≥ 0 (one error message, not one per form)."""
    def number(x):
        return isinstance(x, (int, float)) and not isinstance(x, bool)

    if number(v):
        out = float(v)
    elif isinstance(v, (list, tuple)) and len(v) == 3 and all(number(x) for x in v):
        out = [float(x) for x in v]
    else:
        raise ValueError("must be one number, or one per axis [x, y, z]")
    if not np.all(np.isfinite(out)) or np.any(np.asarray(out) < 0.0):
        raise ValueError("must be finite and ≥ 0 (one number, or one per axis [x, y, z])")
    return out


PerAxis = Annotated[float | list[float], PlainValidator(_per_axis_sigma)]
"""A standard deviation: one number for every axis, or ``[x, y, z]``; finite, ≥ 0."""

_PERIOD = Field(
    None, gt=0, le=1e9, description="Update interval, s: a whole multiple of the control period (default: the control period)."
)


class StarTracker(Table):
    """``kind = "star-tracker"``: attitude with a small body-frame error rotation."""

    kind: Literal["star-tracker"]
    sigma_arcsec: PerAxis = Field(
        description="Standard deviation of the error rotation about each body axis, arcsec (one, or [x, y, z])."
    )
    period_s: float | None = _PERIOD


class Gyro(Table):
    """``kind = "gyro"``: body rate plus a random-walk bias plus white noise."""

    kind: Literal["gyro"]
    sigma_rad_s: PerAxis = Field(description="Standard deviation of the rate noise of one reading, rad/s, per body axis.")
    bias_rw_rad_s_sqrt_s: PerAxis = Field(
        0.0, description="Bias random walk σ_rw, rad/s/√s: the bias spreads σ_rw·√t after a time t (0: constant bias)."
    )
    bias0_rad_s: Vec3 = Field([0.0, 0.0, 0.0], description="Bias at t = 0, body frame, rad/s (every spacecraft).")
    period_s: float | None = _PERIOD


class PositionNoise(Table):
    """``kind = "position-noise"``: navigation error on the ECI position (needs ``[orbit]``)."""

    kind: Literal["position-noise"]
    sigma_m: PerAxis = Field(description="Standard deviation of the position error per ECI axis, m.")
    period_s: float | None = _PERIOD


class VelocityNoise(Table):
    """``kind = "velocity-noise"``: navigation error on the ECI velocity (needs ``[orbit]``)."""

    kind: Literal["velocity-noise"]
    sigma_m_s: PerAxis = Field(description="Standard deviation of the velocity error per ECI axis, m/s.")
    period_s: float | None = _PERIOD


class RelativePosition(Table):
    """``kind = "relative-position"``: each spacecraft measures the vector to every other in sight (needs ``[orbit]``)."""

    kind: Literal["relative-position"]
    sigma_m: PerAxis = Field(0.0, description="Standard deviation of each measured vector per inertial axis, m.")
    blocked: list[Record(str, str, float, float)] = Field(
        [], description="Blocked lines of sight: [spacecraft, spacecraft, t_start_s, t_end_s], both directions, for t in [start, end)."
    )
    period_s: float | None = _PERIOD


class RelativeNavigation(Table):
    """``kind = "relative-navigation"``: each spacecraft's state relative to the chief, in its LVLH frame (needs ``[orbit]``)."""

    kind: Literal["relative-navigation"]
    chief: str = Field(description="The reference spacecraft: its LVLH frame, and the origin of every relative state.")
    sigma_m: PerAxis = Field(0.0, description="Standard deviation of the relative position error per LVLH axis, m.")
    sigma_m_s: PerAxis = Field(0.0, description="Standard deviation of the relative velocity error per LVLH axis, m/s.")
    period_s: float | None = _PERIOD


class Gnss(Table):
    """``kind = "gnss"``: each spacecraft's own ECI position and velocity fix with white, own
    Gauss–Markov and common Gauss–Markov errors (needs ``[orbit]``)."""

    kind: Literal["gnss"]
    sigma_m: PerAxis = Field(0.0, description="Standard deviation of the white position error per ECI axis, m.")
    sigma_m_s: PerAxis = Field(0.0, description="Standard deviation of the white velocity error per ECI axis, m/s.")
    own_sigma_m: PerAxis = Field(
        0.0, description="Stationary standard deviation of each receiver's own Gauss–Markov position error per ECI axis, m."
    )
    own_sigma_m_s: PerAxis = Field(
        0.0, description="Stationary standard deviation of each receiver's own Gauss–Markov velocity error per ECI axis, m/s."
    )
    own_tau_s: float = Field(600.0, gt=0, le=1e9, description="Correlation time of each receiver's own error, s.")
    common_sigma_m: PerAxis = Field(
        0.0, description="Stationary standard deviation of the Gauss–Markov position error every receiver shares, per ECI axis, m."
    )
    common_sigma_m_s: PerAxis = Field(
        0.0, description="Stationary standard deviation of the Gauss–Markov velocity error every receiver shares, per ECI axis, m/s."
    )
    common_tau_s: float = Field(1800.0, gt=0, le=1e9, description="Correlation time of the common error, s.")
    period_s: float | None = _PERIOD


class IslRange(Table):
    """``kind = "isl-range"``: each spacecraft's range and range-rate to one target spacecraft (needs ``[orbit]``)."""

    kind: Literal["isl-range"]
    to: str = Field(description="The target spacecraft every other measures its range and range-rate to.")
    sigma_m: float = Field(0.0, ge=0, description="Standard deviation of the white range noise, m.")
    sigma_m_s: float = Field(0.0, ge=0, description="Standard deviation of the white range-rate noise, m/s.")
    bias_m: float = Field(0.0, description="Constant range bias, m (every spacecraft).")
    bias_m_s: float = Field(0.0, description="Constant range-rate bias, m/s (every spacecraft).")
    max_range_m: float | None = Field(None, gt=0, description="Longest range of a valid link, m (default: no limit).")
    period_s: float | None = _PERIOD


class CameraBearing(Table):
    """``kind = "camera-bearing"``: each spacecraft's unit line of sight to one target spacecraft in its body axes,
    when the target is in the camera's view (needs ``[orbit]``)."""

    kind: Literal["camera-bearing"]
    to: str = Field(description="The target spacecraft every other's camera looks at.")
    sigma_rad: float = Field(
        0.0, ge=0, le=1.0, description="Standard deviation of the angular error about each axis across the line of sight, rad."
    )
    boresight_b: UnitVector = Field((1.0, 0.0, 0.0), description="The camera's axis, body frame (a unit vector; normalised).")
    fov_half_angle_deg: float = Field(
        gt=0, le=180, description="Half angle of the field of view about the boresight, deg (180: the whole sky)."
    )
    max_range_m: float | None = Field(None, gt=0, description="Farthest target seen, m (default: no limit).")
    period_s: float | None = _PERIOD


class SunSensor(Table):
    """``kind = "sun-sensor"``: the direction to the Sun in body axes, none in the Earth's shadow (needs an Earth ``[orbit]``)."""

    kind: Literal["sun-sensor"]
    sigma_deg: PerAxis = Field(description="Standard deviation of the angular error across the line of sight, deg, per body axis.")
    period_s: float | None = _PERIOD


class Magnetometer(Table):
    """``kind = "magnetometer"``: the geomagnetic field in body axes (needs an Earth ``[orbit]``)."""

    kind: Literal["magnetometer"]
    sigma_t: PerAxis = Field(description="Standard deviation of the noise per body axis, T (0.3 nT = 3e-10).")
    bias_t: Vec3 = Field([0.0, 0.0, 0.0], description="Constant bias, body axes, T (every spacecraft).")
    period_s: float | None = _PERIOD


_QUANTITY = {
    "star-tracker": "q", "gyro": "omega", "position-noise": "r_eci", "velocity-noise": "v_eci", "relative-position": "rho",
    "relative-navigation": "x_lvlh", "gnss": "gnss", "isl-range": "isl", "camera-bearing": "bearing",
    "sun-sensor": "sun_b", "magnetometer": "b_b",
}
"""The measured quantity each kind replaces."""


def _place(table, ctx):
    """The table's place in the scenario, ``sensors[k]``."""
    k = next((k for k, t in enumerate(ctx.scenario.sensors) if t is table), None)
    return "sensors" if k is None else f"sensors[{k}]"


def _every(table, ctx):
    """Control periods between updates; checks the period and that the quantity is measured once."""
    where = _place(table, ctx)
    quantity = _QUANTITY[table.kind]
    for k, other in enumerate(ctx.scenario.sensors):
        if other is table:
            break
        if _QUANTITY[other.kind] == quantity:
            raise DesignError(
                f"{where}: measures {quantity} like sensors[{k}]; give one sensor per measured quantity"
            )
    if quantity in ("r_eci", "v_eci", "rho", "x_lvlh", "gnss", "isl", "bearing") and ctx.scenario.orbit is None:
        raise DesignError(
            f'{where}: kind = "{table.kind}" measures {quantity}, which needs an [orbit] table (this run is attitude only)'
        )
    if quantity in ("sun_b", "b_b"):
        from coopsat.plugins.earth_environment import require_earth_orbit

        require_earth_orbit(ctx, f'{where}: kind = "{table.kind}"')
    if table.period_s is None:
        return 1
    every = whole_ratio(table.period_s, ctx.period_s)
    if every is None:
        raise DesignError(
            f"{where}.period_s ({table.period_s:g} s) must be a whole multiple of the control period ({ctx.period_s:g} s)"
        )
    return every


def _per_axis(v, scale=1.0):
    return np.broadcast_to(np.asarray(v, dtype=float) * scale, (3,)).copy()


def _build_star_tracker(table, ctx):
    from coopsat.sensors.noise import ARCSEC_RAD
    from coopsat.sensors.parts import StarTracker as Part
    from coopsat.sim.system import as_arrays

    every = _every(table, ctx)
    return Part(*as_arrays((_per_axis(table.sigma_arcsec, ARCSEC_RAD),)), every=every)


def _build_gyro(table, ctx):
    from coopsat.sensors.parts import Gyro as Part
    from coopsat.sim.system import as_arrays

    every = _every(table, ctx)
    arrays = (
        _per_axis(table.sigma_rad_s), _per_axis(table.bias_rw_rad_s_sqrt_s), _per_axis(table.bias0_rad_s), ctx.period_s,
    )
    return Part(*as_arrays(arrays), every=every)


def _build_navigation(table, ctx):
    from coopsat.sensors.parts import NavigationNoise as Part
    from coopsat.sim.system import as_arrays

    every = _every(table, ctx)
    sigma = table.sigma_m if table.kind == "position-noise" else table.sigma_m_s
    return Part(*as_arrays((_per_axis(sigma),)), quantity=_QUANTITY[table.kind], every=every)


def _build_relative(table, ctx):
    from coopsat.sensors.parts import RelativePosition as Part
    from coopsat.sim.system import as_arrays

    every = _every(table, ctx)
    where = _place(table, ctx)
    pairs, windows = [], []
    for k, (a, b, t0, t1) in enumerate(table.blocked):
        for name in (a, b):
            if name not in ctx.names:
                raise DesignError(f"{where}.blocked[{k}]: unknown spacecraft '{name}' (known: {', '.join(ctx.names)})")
        if a == b:
            raise DesignError(f"{where}.blocked[{k}]: a line of sight joins two different spacecraft, got {a} twice")
        if not 0.0 <= t0 < t1:
            raise DesignError(f"{where}.blocked[{k}]: needs 0 <= t_start_s < t_end_s, got [{t0:g}, {t1:g}]")
        pairs.append((ctx.names.index(a), ctx.names.index(b)))
        windows.append((t0, t1))
    if not pairs:  # a window that never opens keeps the arrays' shapes fixed
        pairs, windows = [(0, 0)], [(0.0, 0.0)]
    arrays = (_per_axis(table.sigma_m), np.asarray(pairs, dtype=np.int32), np.asarray(windows, dtype=float), ctx.period_s)
    return Part(*as_arrays(arrays), names=tuple(ctx.names), every=every)


def _build_relative_navigation(table, ctx):
    from coopsat.sensors.parts import RelativeNavigation as Part
    from coopsat.sim.system import as_arrays

    every = _every(table, ctx)
    chief = ctx.index(table.chief, f"{_place(table, ctx)}.chief")
    sigma = np.concatenate([_per_axis(table.sigma_m), _per_axis(table.sigma_m_s)])
    return Part(*as_arrays((sigma, np.int32(chief))), every=every)


def _build_gnss(table, ctx):
    from coopsat.sensors.navigation_sensors import Gnss as Part
    from coopsat.sim.system import as_arrays

    every = _every(table, ctx)
    arrays = (
        np.concatenate([_per_axis(table.sigma_m), _per_axis(table.sigma_m_s)]),
        np.concatenate([_per_axis(table.own_sigma_m), _per_axis(table.own_sigma_m_s)]), table.own_tau_s,
        np.concatenate([_per_axis(table.common_sigma_m), _per_axis(table.common_sigma_m_s)]), table.common_tau_s,
        ctx.period_s,
    )
    return Part(*as_arrays(arrays), every=every)


def _build_isl_range(table, ctx):
    from coopsat.sensors.navigation_sensors import IslRange as Part
    from coopsat.sim.system import as_arrays

    every = _every(table, ctx)
    target = ctx.index(table.to, f"{_place(table, ctx)}.to")
    max_range_m = np.inf if table.max_range_m is None else table.max_range_m
    arrays = (
        np.array([table.sigma_m, table.sigma_m_s]), np.array([table.bias_m, table.bias_m_s]), np.int32(target), max_range_m,
    )
    return Part(*as_arrays(arrays), every=every)


def _build_camera_bearing(table, ctx):
    from coopsat.sensors.navigation_sensors import CameraBearing as Part
    from coopsat.sim.system import as_arrays

    every = _every(table, ctx)
    target = ctx.index(table.to, f"{_place(table, ctx)}.to")
    boresight = np.asarray(table.boresight_b, dtype=float)
    max_range_m = np.inf if table.max_range_m is None else table.max_range_m
    arrays = (
        np.float64(table.sigma_rad), boresight / np.linalg.norm(boresight), np.cos(np.radians(table.fov_half_angle_deg)),
        np.int32(target), max_range_m,
    )
    return Part(*as_arrays(arrays), every=every)


def _build_sun_sensor(table, ctx):
    from coopsat.plugins.earth_environment import epoch
    from coopsat.sensors.environment_sensors import SunSensor as Part
    from coopsat.sim.system import as_arrays

    every = _every(table, ctx)
    return Part(*as_arrays((_per_axis(table.sigma_deg, np.pi / 180.0), epoch(ctx).jd_tt)), every=every)


def _build_magnetometer(table, ctx):
    from coopsat.plugins.earth_environment import epoch
    from coopsat.sensors.environment_sensors import Magnetometer as Part
    from coopsat.sim.system import as_arrays

    every = _every(table, ctx)
    return Part(*as_arrays((_per_axis(table.sigma_t), _per_axis(table.bias_t), epoch(ctx).earth)), every=every)


register(Plugin("sensor", "star-tracker", StarTracker, _build_star_tracker))
register(Plugin("sensor", "gyro", Gyro, _build_gyro))
register(Plugin("sensor", "position-noise", PositionNoise, _build_navigation))
register(Plugin("sensor", "velocity-noise", VelocityNoise, _build_navigation))
register(Plugin("sensor", "relative-position", RelativePosition, _build_relative))
register(Plugin("sensor", "relative-navigation", RelativeNavigation, _build_relative_navigation))
register(Plugin("sensor", "gnss", Gnss, _build_gnss))
register(Plugin("sensor", "isl-range", IslRange, _build_isl_range))
register(Plugin("sensor", "camera-bearing", CameraBearing, _build_camera_bearing))
register(Plugin("sensor", "sun-sensor", SunSensor, _build_sun_sensor))
register(Plugin("sensor", "magnetometer", Magnetometer, _build_magnetometer))
