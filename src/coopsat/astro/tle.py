"""Two-line element sets (TLEs) as initial states: checked parsing, SGP4, TEME to GCRF.

Design-time code (NumPy, pyerfa, sgp4): a TLE gives the state at the start of a run; it does not
run in the closed loop. sgp4 and erfa are imported inside the functions, so importing this
module costs nothing until a TLE is used.

The format (CelesTrak, "Frequently Asked Questions: Two-Line Element Set Format"): two lines of
69 ASCII characters, fixed columns, each line ending in a modulo-10 checksum. SGP4 is the
theory the elements are fitted to (Vallado, Crawford, Hujsak and Kelso, "Revisiting Spacetrack
Report #3", AIAA 2006-6753), run here by the ``sgp4`` package (Vallado's C++ code) with the
WGS-72 constants the elements are generated with; its output frame is TEME, the true equator
and mean equinox of date.
"""

import re

import numpy as np

TLE_LINE_LENGTH = 69
"""Characters in each TLE line, the checksum in the last."""

_DECIMAL = r" *[+-]?\d*\.\d+"
_UNSIGNED_DECIMAL = r" *\d+\.\d+"
_IMPLIED_POINT = r"[ +-]\d{5}[ +-]\d"  # " 12345-6" is 0.12345e-6

# (line, first column, last column (1-based, inclusive, as the format is written), name, pattern)
_FIELDS = (
    (1, 19, 20, "epoch year", r"\d\d"),
    (1, 21, 32, "epoch day", r" *\d+\.\d+"),
    (1, 34, 43, "first derivative of the mean motion", _DECIMAL),
    (1, 45, 52, "second derivative of the mean motion", _IMPLIED_POINT),
    (1, 54, 61, "BSTAR drag term", _IMPLIED_POINT),
    (2, 9, 16, "inclination", _UNSIGNED_DECIMAL),
    (2, 18, 25, "right ascension of the ascending node", _UNSIGNED_DECIMAL),
    (2, 27, 33, "eccentricity", r" *\d+"),  # decimal point implied before the first column
    (2, 35, 42, "argument of perigee", _UNSIGNED_DECIMAL),
    (2, 44, 51, "mean anomaly", _UNSIGNED_DECIMAL),
    (2, 53, 63, "mean motion", _UNSIGNED_DECIMAL),
)

# Columns that separate the fields and must be blank (1-based). The C++ parser inside sgp4 reads
# the lines with whitespace-delimited sscanf, so a field that runs into its neighbour would be
# split in the wrong place without complaint. sgp4's pure-Python parser checks the same columns,
# but for line 1's column 18, after the international designator.
_BLANK_COLUMNS = {1: (2, 9, 18, 33, 44, 53, 62, 64), 2: (2, 8, 17, 26, 34, 43, 52)}

# Catalogue number, columns 3–7: up to five digits, or Alpha-5 (a letter other than I and O,
# standing for 10–33, then four digits) for numbers from 100000.
_CATALOGUE = r" *\d+|[A-HJ-NP-Z]\d{4}"


def _checksum(line):
    """Modulo-10 sum of columns 1–68: each digit its value, each '-' one, anything else zero."""
    return sum(int(c) if c in "0123456789" else c == "-" for c in line[:68]) % 10


def _check_tle(lines):
    """Raise ValueError, one line naming the cause, if ``lines`` (two stripped strings) is not
    a well-formed TLE. The order runs from the grossest damage (a truncated line) to the finest
    (one field), so that the message names the first thing to fix."""
    for number, line in enumerate(lines, start=1):
        if len(line) != TLE_LINE_LENGTH:
            raise ValueError(f"TLE line {number} is {len(line)} characters long, not {TLE_LINE_LENGTH}")
        # A non-ASCII character is two or more bytes to the C++ parser: every later column shifts.
        odd = next((i for i, c in enumerate(line) if not (" " <= c <= "~")), None)
        if odd is not None:
            raise ValueError(
                f"TLE line {number} column {odd + 1} holds {line[odd]!r}, not a printable ASCII character"
            )
        if line[0] != str(number):
            raise ValueError(f"TLE line {number} starts with {line[0]!r}, not '{number}' (lines out of order?)")
    for number, line in enumerate(lines, start=1):
        stated = line[68]
        if stated not in "0123456789":
            raise ValueError(f"TLE line {number} checksum: column 69 holds {stated!r}, not a digit")
        if int(stated) != _checksum(line):
            raise ValueError(
                f"TLE line {number} checksum: column 69 says {stated}, the line sums to {_checksum(line)}"
            )
    catalogue = [line[2:7] for line in lines]
    if catalogue[0] != catalogue[1]:
        raise ValueError(f"TLE catalogue numbers differ: line 1 has {catalogue[0]!r}, line 2 has {catalogue[1]!r}")
    if not re.fullmatch(_CATALOGUE, catalogue[0], flags=re.ASCII):
        raise ValueError(f"TLE catalogue number (columns 3–7) does not parse: {catalogue[0]!r}")
    for number, line in enumerate(lines, start=1):
        for column in _BLANK_COLUMNS[number]:
            if line[column - 1] != " ":
                raise ValueError(
                    f"TLE line {number} column {column} holds {line[column - 1]!r}, "
                    "where a blank separates two fields"
                )
    for number, first, last, name, pattern in _FIELDS:
        text = lines[number - 1][first - 1 : last]
        # re.ASCII: without it \d also accepts non-ASCII digits such as "٣".
        if not re.fullmatch(pattern, text, flags=re.ASCII):
            raise ValueError(f"TLE line {number} {name} (columns {first}–{last}) does not parse: {text!r}")
    day = float(lines[0][20:32])
    if not 1.0 <= day < 367.0:
        raise ValueError(f"TLE line 1 epoch day (columns 21–32) is {day!r}, outside 1 ≤ day < 367")


def parse_tle(line1, line2):
    """A checked two-line element set, ready for SGP4.

    Parameters
    ----------
    line1, line2 : str
        The two lines; trailing whitespace (a newline) is ignored. A title line ("line 0") is
        not taken: the catalogue number identifies the object.

    Returns
    -------
    sgp4.api.Satrec
        Initialised with the WGS-72 constants, the ones the elements are fitted with (WGS-84
        ones move the state at the epoch by 14 m for the ISS, 20 m for Vallado's 00005).

    Raises
    ------
    ValueError
        One line naming the first problem found: a line not 69 printable ASCII characters, the
        lines' numbers not '1' and '2', a checksum that disagrees with column 69, different
        catalogue numbers on the two lines, a non-blank separator column, or a numeric field
        that does not read in its columns (epoch, mean-motion derivatives, BSTAR, inclination,
        node, eccentricity, argument of perigee, mean anomaly, mean motion).

    Notes
    -----
    The checks come first because the accelerated ``Satrec.twoline2rv`` checks nothing: a
    damaged line gives elements that are silently wrong. Whether the elements make an orbit
    (eccentricity below one, a perigee above the ground) SGP4 only says when it propagates:
    :func:`teme_state` raises then.
    """
    from sgp4.api import WGS72, Satrec

    lines = (line1.rstrip(), line2.rstrip())
    _check_tle(lines)
    return Satrec.twoline2rv(lines[0], lines[1], WGS72)


def tle_epoch_utc(satrec):
    """The TLE's epoch as an ISO-8601 UTC string with microseconds.

    Parameters
    ----------
    satrec : sgp4.api.Satrec

    Returns
    -------
    str
        ``"2008-09-20T12:25:40.104192"`` (no zone suffix: UTC, as
        :func:`coopsat.astro.timescales.run_epoch` reads it).

    Notes
    -----
    The epoch is the two-part Julian date ``jdsatepoch + jdsatepochF`` that SGP4 counts its
    time from, formatted by SOFA's ``d2dtf`` on the UTC scale, so that the string read back by
    ``erfa.dtf2d`` (as :func:`coopsat.astro.timescales.run_epoch` reads an epoch) is that very
    Julian date, and :func:`teme_state` at the run's start is SGP4 at zero minutes from the
    epoch. The TLE gives the day to 1e-8 d = 864 µs, a whole number of microseconds, so the
    string is exact (on a day of 86400 s). One case is a convention: SOFA counts a day that ends in a leap second
    as 86401 s, so there the day fraction reads up to 1 s later than as a fraction of 86400 s
    (day 366.5 of 2016 is 12:00:00.5); the format does not say which the catalogue means.
    """
    import erfa

    year, month, day, hmsf = erfa.d2dtf("UTC", 6, satrec.jdsatepoch, satrec.jdsatepochF)
    h, m, s, f = (int(v) for v in hmsf)
    return f"{int(year):04d}-{int(month):02d}-{int(day):02d}T{h:02d}:{m:02d}:{s:02d}.{f:06d}"


def teme_state(satrec, jd_utc1, jd_utc2):
    """SGP4 position and velocity at a UTC instant, TEME frame.

    Parameters
    ----------
    satrec : sgp4.api.Satrec
        From :func:`parse_tle`.
    jd_utc1, jd_utc2 : float
        Two-part Julian date, UTC (SOFA's convention, as
        :func:`coopsat.astro.timescales.utc_from_tt` gives it).

    Returns
    -------
    r_teme_m : ndarray, shape (3,)
        Position, m, TEME (true equator, mean equinox of date).
    v_teme_m_s : ndarray, shape (3,)
        Velocity, m/s, TEME axes (the derivative of the position in those axes).

    Raises
    ------
    ValueError
        SGP4 reports an error (the elements make no orbit, or the satellite has decayed by
        then), as one line with SGP4's own message.

    Notes
    -----
    SGP4 runs on minutes since the epoch, ``(jd − jd_epoch) × 1440``: it knows no leap
    seconds, so an interval that contains one is counted a second short, like the theory the
    elements were fitted with.
    """
    from sgp4.api import SGP4_ERRORS

    code, r_km, v_km_s = satrec.sgp4(jd_utc1, jd_utc2)
    if code != 0:
        minutes = ((jd_utc1 - satrec.jdsatepoch) + (jd_utc2 - satrec.jdsatepochF)) * 1440.0
        raise ValueError(
            f"SGP4 error {code} for catalogue number {satrec.satnum_str.strip()} at {minutes:.3f} min from the "
            f"TLE epoch: {SGP4_ERRORS.get(code, 'unknown error')}"
        )
    return np.asarray(r_km) * 1e3, np.asarray(v_km_s) * 1e3


def teme_to_gcrf(r_teme_m, v_teme_m_s, tt1, tt2, ut11, ut12):
    """TEME position and velocity to the GCRF (IAU 2006/2000A, CIO based).

    Parameters
    ----------
    r_teme_m : array_like, shape (3,)
        Position, m, TEME.
    v_teme_m_s : array_like, shape (3,)
        Velocity, m/s, TEME axes.
    tt1, tt2 : float
        Two-part Julian date of the instant, TT (for precession-nutation).
    ut11, ut12 : float
        The same instant as a two-part Julian date, UT1 (for the sidereal angles).

    Returns
    -------
    r_gcrf_m : ndarray, shape (3,)
    v_gcrf_m_s : ndarray, shape (3,)

    Notes
    -----
    Vallado et al. 2006 (AIAA 2006-6753, its TEME conversion) and Vallado, *Fundamentals of
    Astrodynamics and Applications*, 4th ed., §3.7, reach an inertial frame through the Earth:
    ``r_pef = R3(GMST82) r_teme``, ``v_pef = R3(GMST82) v_teme − ω × r_pef``,
    ``r_itrf = W r_pef`` (polar motion), then the ITRF to the GCRF, here by the IERS 2010 chain
    ``r_itrf = W R3(ERA) Q r_gcrf`` (``Q`` from ``erfa.c2i06a``). Its terrestrial intermediate
    frame is the pseudo-Earth-fixed frame (both have the true pole as z and the Greenwich
    meridian as x; they differ by the 1976 and 2006 precession models, below 1 mas). Written
    out, the chain cancels against itself: ``W`` meets ``Wᵀ``, and the ``−ω × r`` taken off
    with GMST is added back with ERA, about the same pole at the same rate. What is left is a
    fixed turn about the pole by the difference of the two sidereal angles (the accumulated
    precession in right ascension, ``GMST82 − ERA``), then ``Qᵀ``::

        r_gcrf = Qᵀ R3(GMST82 − ERA) r_teme,    v_gcrf = Qᵀ R3(GMST82 − ERA) v_teme.

    So neither polar motion nor the Earth's rotation rate enters, and UT1 − UTC (≤ 0.9 s)
    turns the result by 0.9 s × 7e-12 rad/s (the rate of ``GMST82 − ERA``), 6e-12 rad,
    0.05 mm at 7000 km: UT1 is asked for to keep both angles on their own scale. Left out:
    the turning of TEME itself against the GCRF (precession and nutation, about 7e-12 rad/s),
    which would add 5e-5 m/s to the velocity in low Earth orbit and 3e-4 m/s at geostationary
    distance, far below SGP4's own error (a kilometre, a metre per second). astropy's
    TEME → GCRS takes the same angles (but leaves the TIO locator ``s'`` out of its
    TEME → ITRS, 2 mm at geostationary distance in 2020) and finds the velocity by finite
    differences, that turning included: tests/unit/astro/test_tle.py measures both.
    """
    import erfa

    teme_to_cirs = erfa.rz(erfa.gmst82(ut11, ut12) - erfa.era00(ut11, ut12), np.eye(3))
    gcrf_from_teme = erfa.c2i06a(tt1, tt2).T @ teme_to_cirs
    r = gcrf_from_teme @ np.asarray(r_teme_m, dtype=float)
    return r, gcrf_from_teme @ np.asarray(v_teme_m_s, dtype=float)
