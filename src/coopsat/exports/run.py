"""What an export reads from a finished run: names, times, epoch, central body and the states.

A run is read once into a :class:`RunStates` (NumPy, SI); the format modules only format it.
What a format needs and a run lacks is refused here, in one line naming the cause
(:func:`require_positions`, :func:`require_attitude`).

Frames and time (docs/time-and-frames.md): a run records its inertial frame and clock in
``result.nc`` (``inertial_frame``, ``time_scale``, ``epoch_tt``): the GCRF with the IAU 2006
Earth, ``EME2000`` (J2000-like axes) with the papers' GMST Earth; the clock is TT. Times are
``epoch_tt + t`` on TT. A result written before runs recorded them (no ``epoch_tt``) is read
as it was flown then: ``[orbit] epoch_utc + t`` on UTC, axes EME2000.
"""

import tomllib
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from coopsat.core.errors import InputError
from coopsat.astro.constants import central_body_name


class ExportError(InputError):
    """A run that cannot be exported in the format asked, or an output that cannot be written:
    one line naming the cause."""


@dataclass(frozen=True)
class RunStates:
    """The states of one run, as recorded (SI, NumPy).

    Attributes
    ----------
    scenario_name : str
    names : tuple of str
        Spacecraft names, in the run's order (n of them).
    t_s : ndarray, shape (T,)
        Sample times since t = 0, s.
    epoch : numpy.datetime64
        Date-time of t = 0 on ``time_system`` (microseconds).
    epoch_note : str
        Where the epoch comes from (written as a comment in each file).
    time_system : str
        CCSDS ``TIME_SYSTEM`` of ``epoch + t``: ``"TT"`` (or ``"UTC"`` for an older result).
    ref_frame : str
        CCSDS ``REF_FRAME`` of the inertial axes: ``"GCRF"`` or ``"EME2000"``.
    epoch_utc : numpy.datetime64
        t = 0 in UTC (CZML's scale), microseconds.
    orbit : dict or None
        The resolved ``[orbit]`` table (its Earth orientation, for Earth-fixed exports).
    center_name : str or None
        CCSDS ``CENTER_NAME`` of the central body (``EARTH``, ``SUN``); None without ``[orbit]``,
        or for a body that is neither.
    mu_m3_s2 : float or None
        The central body's gravitational parameter, m³/s² (None without ``[orbit]``).
    r_eci_m, v_eci_m_s : ndarray, shape (T, n, 3), or None
        Position, m, and velocity, m/s, inertial (ECI) axes, origin the central body; None for
        a run without ``[orbit]``.
    q_bi : ndarray, shape (T, n, 4), or None
        Attitude, scalar first, Hamilton, body to inertial (``v_i = q ⊗ v_b ⊗ q*``); None for a
        run without attitude quaternions (the linearised small-angle model).
    """

    scenario_name: str
    names: tuple
    t_s: np.ndarray
    epoch: np.datetime64
    epoch_note: str
    time_system: str
    ref_frame: str
    epoch_utc: np.datetime64
    orbit: dict | None
    center_name: str | None
    mu_m3_s2: float | None
    r_eci_m: np.ndarray | None
    v_eci_m_s: np.ndarray | None
    q_bi: np.ndarray | None


def open_dataset(source):
    """The run's dataset: ``source`` is a run folder (``coopsat run``; its ``result.nc``, read by
    :func:`coopsat.workflows.folders.read_result` as ``load_run`` reads it, without rebuilding
    the scenario: an export needs only the record) or anything with a ``dataset`` (a
    :class:`coopsat.Result`).

    Raises
    ------
    ExportError
        A folder without a readable ``result.nc`` and its scenario.
    """
    if hasattr(source, "dataset"):
        return source.dataset
    from coopsat.workflows.folders import read_result

    return read_result(source, ExportError)


def _instant(iso):
    """An ISO-8601 string (a zone, if any, taken to UTC) as ``numpy.datetime64[us]``."""
    when = datetime.fromisoformat(iso)
    when = when if when.tzinfo is None else when.astimezone(timezone.utc).replace(tzinfo=None)
    return np.datetime64(when, "us")


def _epoch(orbit, attrs):
    """(epoch, note, time system, inertial frame, UTC epoch) of t = 0 from the resolved ``[orbit]``
    table (None: attitude only) and the result's attributes.

    An attitude-only run has no date: its t = 0 is written as the default ``epoch_utc`` of
    ``[orbit]`` (docs/scenarios.md) on UTC, and the note says so.
    """
    if "epoch_tt" in attrs:
        frame = "GCRF" if attrs.get("inertial_frame") == "GCRF" else "EME2000"
        note = f"t = 0 is {attrs['epoch_tt']} TT (given as {attrs.get('epoch_given', '?')}); the clock is TT"
        return _instant(attrs["epoch_tt"]), note, "TT", frame, _instant(attrs["epoch_utc"])
    if orbit is None:
        from coopsat.scenarios.schema import Orbit

        iso, note = Orbit.model_fields["epoch_utc"].default, "no [orbit]: t = 0 written as the default epoch"
    else:
        iso, note = orbit["epoch_utc"], "t = 0 is [orbit] epoch_utc"
    return _instant(iso), f"{note} {iso} (UTC)", "UTC", "EME2000", _instant(iso)


def _values(ds, name):
    return None if name not in ds else np.asarray(ds[name].values, dtype=np.float64)


def read_states(source):
    """Read a run (folder or :class:`coopsat.Result`) into :class:`RunStates`.

    Raises
    ------
    ExportError
        Not a run folder, or a dataset without its resolved scenario (``scenario_toml``).
    """
    ds = open_dataset(source)
    if "scenario_toml" not in ds.attrs:
        raise ExportError(f"{source}: the result has no scenario_toml attribute (not written by coopsat run)")
    orbit = tomllib.loads(ds.attrs["scenario_toml"]).get("orbit")
    epoch, note, time_system, frame, epoch_utc = _epoch(orbit, ds.attrs)
    mu = None if orbit is None else float(orbit["mu_m3_s2"])
    return RunStates(
        scenario_name=str(ds.attrs.get("scenario_name", "run")),
        names=tuple(str(n) for n in ds["spacecraft"].values),
        t_s=np.asarray(ds["time"].values, dtype=np.float64),
        epoch=epoch,
        epoch_note=note,
        time_system=time_system,
        ref_frame=frame,
        epoch_utc=epoch_utc,
        orbit=orbit,
        center_name=None if mu is None else central_body_name(mu),
        mu_m3_s2=mu,
        r_eci_m=_values(ds, "r_eci"),
        v_eci_m_s=_values(ds, "v_eci"),
        q_bi=_values(ds, "q"),
    )


def epochs_iso(run, utc=False):
    """ISO-8601 date-time of every sample on the run's ``time_system`` (``utc``: on UTC, as
    ``epoch_utc + t``, which a leap second inside the run would put 1 s off after it), to the
    microsecond: shape (T,) of str."""
    offsets = np.round(run.t_s * 1e6).astype(np.int64).astype("timedelta64[us]")
    return np.datetime_as_string((run.epoch_utc if utc else run.epoch) + offsets, unit="us")


def require_positions(run, what):
    """Refuse a run without positions, or one about a body no standard names.

    Parameters
    ----------
    what : str
        The format, for the message (``"an OEM"``).
    """
    if run.r_eci_m is None:
        raise ExportError(f"{run.scenario_name}: {what} needs positions and this run has none "
                          "(attitude only: no [orbit]); export its attitude with --format aem")
    if run.center_name is None:
        raise ExportError(f"{run.scenario_name}: {what} needs a named central body and [orbit] mu_m3_s2 = "
                          f"{run.mu_m3_s2:g} m^3/s^2 is neither the Earth's nor the Sun's")


def require_attitude(run, what):
    """Refuse a run without attitude quaternions (the small-angle model records ``angle``)."""
    if run.q_bi is None:
        raise ExportError(f"{run.scenario_name}: {what} needs attitude quaternions and this run records none "
                          "(its attitude model is the linearised small-angle one)")
