"""Time scales of a run: its clock is TT; epochs in UTC, TAI or TT; UT1 and polar motion from
the IERS (design time, NumPy).

A run's time ``t`` counts SI seconds of Terrestrial Time (TT) from its epoch: TT is uniform, so
a run that crosses a leap second has no jump in its clock, and the ephemerides take it as
they are defined. The scenario may give the epoch in UTC (``[orbit] epoch_utc``, the default),
TAI or TT. Turning UTC into TT needs the leap seconds: from 1972 they are read from the IERS
table that astropy-iers-data ships (``Leap_Second.dat``, kept current by that package's
releases), with its expiry date checked; from 1960 to 1972, when UTC ran at a rate offset
from TAI, from SOFA's formula (``erfa.dat``). Before 1960 there is no UTC.

The Earth's rotation angle needs UT1, and the Earth-fixed frame polar motion: both come from
the IERS Bulletin A file (``finals2000A``, measured values with Bulletin B's where final, and a
year of predictions) that astropy-iers-data ships. Nothing is downloaded.

Two-part Julian dates ``(jd1, jd2)`` are used as SOFA does: their sum is the date, split so
that no precision is lost (``jd1`` a whole or half day).
"""

import functools
import math
import warnings
from datetime import datetime, timezone
from typing import NamedTuple

import numpy as np

from coopsat.core.errors import InputError

SECONDS_PER_DAY = 86400.0
TT_MINUS_TAI_S = 32.184
"""TT − TAI, s (by definition)."""

MJD_ZERO = 2400000.5
"""Julian date of MJD 0."""

MJD_1972 = 41317.0
"""1972-01-01: from here TAI − UTC is a whole number of seconds, changed only by leap seconds."""

EPOCH_SCALES = ("utc", "tai", "tt")
"""Scales in which a scenario may give its epoch (``[orbit] epoch_utc``, ``epoch_tai``, ``epoch_tt``)."""


class TimeScaleError(InputError):
    """An epoch that cannot be placed on TT (before UTC began, beyond the leap-second table)."""


class RunEpoch(NamedTuple):
    """The instant t = 0 of a run, on every scale it needs.

    Attributes
    ----------
    tt : tuple of float
        Two-part Julian date, TT.
    utc_iso : str or None
        The same instant in UTC, ISO 8601 with microseconds (None for a TT or TAI epoch beyond
        the leap-second table).
    tt_iso : str
        In TT, ISO 8601 with microseconds.
    given : str
        The scale the scenario gave it in (``"utc"``, ``"tai"``, ``"tt"``).
    """

    tt: tuple
    utc_iso: str
    tt_iso: str
    given: str

    @property
    def jd_tt(self):
        """Julian date, TT, one float (resolution 40 µs: for ephemerides, not for clocks)."""
        return self.tt[0] + self.tt[1]


@functools.cache
def _leap_second_table():
    """(mjd (L,), tai_utc_s (L,), expires ``datetime.date``) from astropy-iers-data's
    ``Leap_Second.dat``."""
    from astropy.utils.iers import LeapSeconds
    from astropy_iers_data import IERS_LEAP_SECOND_FILE

    table = LeapSeconds.open(IERS_LEAP_SECOND_FILE)
    expires = table.expires.to_datetime().date()
    return np.asarray(table["mjd"], dtype=float), np.asarray(table["tai_utc"], dtype=float), expires


def leap_second_expiry():
    """The last date (``datetime.date``) on which the bundled leap-second table is valid."""
    return _leap_second_table()[2]


def tai_minus_utc_s(jd_utc):
    """TAI − UTC, s, at a UTC Julian date (one float).

    Raises
    ------
    TimeScaleError
        Before 1960 (there was no UTC) or after the leap-second table expires.
    """
    import erfa

    mjd = jd_utc - MJD_ZERO
    mjds, offsets, expires = _leap_second_table()
    day = _calendar(jd_utc)
    if mjd >= MJD_1972:
        if day > expires:
            raise TimeScaleError(
                f"UTC date {day.isoformat()} is beyond the leap-second table (valid to {expires.isoformat()}, "
                "astropy-iers-data): give the epoch in TT or TAI (epoch_tt, epoch_tai), or update astropy-iers-data"
            )
        return float(offsets[np.searchsorted(mjds, mjd, side="right") - 1])
    if day.year < 1960:
        raise TimeScaleError(f"UTC date {day.isoformat()} is before UTC began (1960): give the epoch in TT (epoch_tt)")
    # 1960–1971: TAI − UTC grew at a stated rate between steps (SOFA's table, fixed for good).
    return float(erfa.dat(day.year, day.month, day.day, (mjd - math.floor(mjd))))


def _calendar(jd):
    """The UTC calendar date containing a Julian date (``datetime.date``)."""
    mjd = jd - MJD_ZERO
    return datetime.fromtimestamp((mjd - 40587.0) * SECONDS_PER_DAY, tz=timezone.utc).date()


def _iso(jd1, jd2, scale):
    """ISO 8601 with microseconds of a two-part Julian date (``erfa.d2dtf``, which formats a UTC
    leap second as second 60)."""
    import erfa

    y, mo, d, hmsf = erfa.d2dtf(scale.upper(), 6, jd1, jd2)
    h, mi, s, f = (int(v) for v in hmsf)
    return f"{int(y):04d}-{int(mo):02d}-{int(d):02d}T{h:02d}:{mi:02d}:{s:02d}.{f:06d}"


def _parse(iso, field):
    """(year, month, day, hour, minute, seconds) of an ISO-8601 string without a zone (or UTC)."""
    try:
        when = datetime.fromisoformat(iso)
    except ValueError:
        raise TimeScaleError(f"{field}: '{iso}' is not an ISO 8601 date-time (e.g. 2018-06-21T04:00:00)") from None
    if when.tzinfo is not None:
        if when.utcoffset().total_seconds() != 0.0 or field != "epoch_utc":
            raise TimeScaleError(f"{field}: '{iso}' carries a time zone; give the instant without one")
    return when.year, when.month, when.day, when.hour, when.minute, when.second + when.microsecond * 1e-6


def run_epoch(iso, scale="utc"):
    """A run's epoch from the scenario's ISO-8601 string and the scale it is given in.

    Parameters
    ----------
    iso : str
        ``"2018-06-21T04:00:00"`` (fractions of a second allowed).
    scale : str
        ``"utc"``, ``"tai"`` or ``"tt"``.

    Returns
    -------
    RunEpoch

    Raises
    ------
    TimeScaleError
        A malformed string, a UTC date before 1960 or beyond the leap-second table.

    Notes
    -----
    ``TT = TAI + 32.184 s``, ``TAI = UTC + (TAI − UTC)``: SOFA's ``dtf2d``, ``utctai`` and
    ``taitt`` (which know a leap-second day's 86401 s), after checking that SOFA's leap
    seconds are the bundled IERS table's at that date (:func:`tai_minus_utc_s`).
    """
    import erfa

    field = f"epoch_{scale}"
    y, mo, d, h, mi, s = _parse(iso, field)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", erfa.ErfaWarning)  # "dubious year": the table's own check below
        if scale == "utc":
            utc = erfa.dtf2d("UTC", y, mo, d, h, mi, s)
            _check_leap_seconds(*utc)
            tt = erfa.taitt(*erfa.utctai(*utc))
        else:
            jd1, jd2 = erfa.dtf2d("", y, mo, d, h, mi, s)
            tt = (jd1, jd2 + TT_MINUS_TAI_S / SECONDS_PER_DAY) if scale == "tai" else (jd1, jd2)
        tt = (float(tt[0]), float(tt[1]))
        try:
            utc_iso = _iso(*utc_from_tt(*tt), "utc")
        except TimeScaleError:  # a TT or TAI epoch beyond the leap-second table has no known UTC
            utc_iso = None
        return RunEpoch(tt=tt, utc_iso=utc_iso, tt_iso=_iso(*tt, "tt"), given=scale)


def _check_leap_seconds(utc1, utc2):
    """SOFA's own leap seconds (pyerfa's copy, used by ``utctai``) agree with the bundled IERS
    table at this UTC date, which the table covers; else a TimeScaleError."""
    import erfa

    day = _calendar(utc1 + utc2)
    table_s = tai_minus_utc_s(utc1 + utc2)
    sofa_s = float(erfa.dat(day.year, day.month, day.day, 0.0))
    if day >= _calendar(MJD_1972 + MJD_ZERO) and sofa_s != table_s:
        raise TimeScaleError(
            f"UTC date {day.isoformat()}: pyerfa's leap seconds (TAI − UTC = {sofa_s:g} s) lag the IERS table's "
            f"({table_s:g} s): update pyerfa"
        )


def utc_from_tt(tt1, tt2, strict=True):
    """UTC two-part Julian date of a TT one (SOFA's ``tttai`` and ``taiutc``), checked against
    the bundled leap-second table.

    With ``strict=False`` a date beyond the table keeps its last offset (TAI − UTC as at its
    expiry) instead of raising: the best guess of UTC for looking up UT1, which is then outside
    the IERS table too and said so."""
    import erfa

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", erfa.ErfaWarning)  # "dubious year": checked here instead
        utc = erfa.taiutc(*erfa.tttai(tt1, tt2))
    try:
        _check_leap_seconds(*utc)
    except TimeScaleError:
        if strict:
            raise
        offset_s = TT_MINUS_TAI_S + _leap_second_table()[1][-1]
        return float(tt1), float(tt2) - offset_s / SECONDS_PER_DAY
    return float(utc[0]), float(utc[1])


class EarthOrientationParameters(NamedTuple):
    """UT1 − UTC and polar motion at given UTC dates, with where they came from.

    Attributes
    ----------
    ut1_utc_s : ndarray (K,)
    xp_rad, yp_rad : ndarray (K,)
        Pole coordinates (CIP in ITRS).
    source : str
        The table, and whether any date fell outside it (then 0 is used).
    """

    ut1_utc_s: np.ndarray
    xp_rad: np.ndarray
    yp_rad: np.ndarray
    source: str


@functools.cache
def _iers_a():
    from astropy.utils.iers import IERS_A
    from astropy_iers_data import IERS_A_FILE

    return IERS_A.open(IERS_A_FILE)


def earth_orientation_parameters(utc1, utc2):
    """UT1 − UTC and the pole's position at UTC dates, from the bundled IERS Bulletin A.

    Parameters
    ----------
    utc1, utc2 : array_like (K,)
        Two-part UTC Julian dates.

    Returns
    -------
    EarthOrientationParameters
        Outside the table (before 1973, or past its predictions) the values are 0 and
        ``source`` says so; the caller decides whether that is acceptable.
    """
    from importlib.metadata import version

    table = _iers_a()
    utc1, utc2 = np.atleast_1d(utc1).astype(float), np.atleast_1d(utc2).astype(float)
    dut1, status = table.ut1_utc(utc1, utc2, return_status=True)
    xp, yp, _ = table.pm_xy(utc1, utc2, return_status=True)
    status = np.atleast_1d(status)
    outside = status < 0
    arcsec = np.pi / (180.0 * 3600.0)
    ut1_utc = np.where(outside, 0.0, np.asarray(dut1.to_value("s")))
    xp_rad = np.where(outside, 0.0, np.asarray(xp.to_value("arcsec")) * arcsec)
    yp_rad = np.where(outside, 0.0, np.asarray(yp.to_value("arcsec")) * arcsec)
    kinds = ["measured" if s <= 1 else "predicted" for s in status[~outside]]
    source = f"IERS finals2000A (astropy-iers-data {version('astropy-iers-data')}): " + (
        ", ".join(sorted(set(kinds))) if kinds else ""
    )
    if outside.any():
        source += f"{', ' if kinds else ''}{int(outside.sum())} of {status.size} dates outside the table (UT1 = UTC, no polar motion there)"
    return EarthOrientationParameters(ut1_utc, xp_rad, yp_rad, source)
