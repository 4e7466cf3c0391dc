"""Two-line element sets: SGP4 against Vallado et al.'s published test case, every TLE of
sgp4's verification file read as sgp4 reads it, each malformed-line error, the epoch string,
and TEME → GCRF against astropy and against the long way round through the ITRF."""

import subprocess
import sys
from pathlib import Path

import erfa
import numpy as np
import pytest

from coopsat.astro.tle import parse_tle, teme_state, teme_to_gcrf, tle_epoch_utc

# Vallado, Crawford, Hujsak and Kelso 2006, "Revisiting Spacetrack Report #3" (AIAA 2006-6753),
# test case 00005 (58002B, Vanguard 1's upper stage).
SAT5 = (
    "1 00005U 58002B   00179.78495062  .00000023  00000-0  28098-4 0  4753",
    "2 00005  34.2682 348.7242 1859667 331.7664  19.3264 10.82419157413667",
)
# The ISS (ZARYA) example of Wikipedia's "Two-line element set" article.
ISS = (
    "1 25544U 98067A   08264.51782528 -.00002182  00000-0 -11606-4 0  2927",
    "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.72125391563537",
)

OMEGA_EARTH_RAD_S = 7.292115146706979e-5


def sgp4_data(name):
    """A file of sgp4's own verification data (shipped inside the package)."""
    import sgp4

    return Path(sgp4.__file__).parent / name


def checksum(line):
    """The format's modulo-10 checksum of columns 1–68 (digits, '-' = 1), written out again."""
    total = 0
    for c in line[:68]:
        if c.isascii() and c.isdigit():
            total += int(c)
        elif c == "-":
            total += 1
    return total % 10


def edit(line, column, text):
    """``line`` with ``text`` written from 1-based ``column`` on, and its checksum made good."""
    line = line[: column - 1] + text + line[column - 1 + len(text) :]
    return line[:68] + str(checksum(line))


def one_line_error(line1, line2):
    """The ValueError message of parse_tle, checked to be a single line."""
    with pytest.raises(ValueError) as info:
        parse_tle(line1, line2)
    message = str(info.value)
    assert "\n" not in message and message
    return message


# ----------------------------------------------------------------------------- SGP4 and the epoch


def test_vallado_2006_case_00005_at_epoch():
    # tsince = 0 of satellite 00005 in tcppver.out (Vallado et al. 2006's C++ output, shipped
    # with sgp4), read from the file rather than copied: r km to 8 decimals (0.01 mm), v km/s
    # to 9 (1e-6 m/s). The brief's values are those printed numbers.
    lines = sgp4_data("tcppver.out").read_text().splitlines()
    row = lines[lines.index("5 xx") + 1].split()
    assert float(row[0]) == 0.0
    published_r_m = np.array([float(x) for x in row[1:4]]) * 1e3
    published_v_m_s = np.array([float(x) for x in row[4:7]]) * 1e3
    np.testing.assert_array_equal(published_r_m, np.array([7022.46529266, -1400.08296755, 0.03995155]) * 1e3)
    np.testing.assert_array_equal(published_v_m_s, np.array([1.893841015, 6.405893759, 4.534807250]) * 1e3)
    sat = parse_tle(*SAT5)
    r, v = teme_state(sat, sat.jdsatepoch, sat.jdsatepochF)
    assert r.shape == (3,) and v.shape == (3,)
    assert np.max(np.abs(r - published_r_m)) <= 1e-3  # measured 4e-6 m
    assert np.max(np.abs(v - published_v_m_s)) <= 1e-6  # measured 4.9e-7 m/s, the print's rounding


def test_vallado_2006_case_00005_half_a_day_on():
    # The next row of tcppver.out, tsince = 360 min: the time argument is counted from the epoch.
    lines = sgp4_data("tcppver.out").read_text().splitlines()
    row = lines[lines.index("5 xx") + 2].split()
    assert float(row[0]) == 360.0
    sat = parse_tle(*SAT5)
    r, v = teme_state(sat, sat.jdsatepoch, sat.jdsatepochF + 0.25)
    assert np.max(np.abs(r - np.array([float(x) for x in row[1:4]]) * 1e3)) <= 1e-3
    assert np.max(np.abs(v - np.array([float(x) for x in row[4:7]]) * 1e3)) <= 1e-6


def verification_tles():
    """(line1, line2) of every TLE in sgp4's SGP4-VER.TLE (line 2 carries the test's start,
    stop and step times after column 69)."""
    lines = [line for line in sgp4_data("SGP4-VER.TLE").read_text().splitlines() if line[:2] in ("1 ", "2 ")]
    return [(a.rstrip(), b[:69]) for a, b in zip(lines[::2], lines[1::2])]


def test_every_verification_tle_reads_as_sgp4_reads_it():
    # 33 element sets (20413 twice) chosen by Vallado et al. for odd formatting and orbits
    # (blank designators, "00000+0" exponents, deep space, near-parabolic): the checks accept
    # every well-formed one and leave sgp4's reading of it untouched. 33333–33335 are, by the
    # file's own comments, edited copies whose checksums no longer match ("Checksum error as
    # expected").
    from sgp4.api import WGS72, Satrec

    tles = verification_tles()
    assert len(tles) == 33
    fields = ("inclo", "nodeo", "ecco", "argpo", "mo", "no_kozai", "bstar", "ndot", "nddot")
    fields += ("jdsatepoch", "jdsatepochF")
    for line1, line2 in tles:
        if line1[2:7] in ("33333", "33334", "33335"):
            assert "checksum" in one_line_error(line1, line2)
            continue
        ours, theirs = parse_tle(line1, line2), Satrec.twoline2rv(line1, line2, WGS72)
        assert [getattr(ours, f) for f in fields] == [getattr(theirs, f) for f in fields], line1


def test_iss_example_parses_with_valid_checksums_and_epoch():
    for line in ISS:
        assert int(line[68]) == checksum(line)
    sat = parse_tle(*ISS)
    assert sat.satnum_str == "25544"
    # Day 264.51782528 of 2008 (a leap year: 1 January is day 1, so day 264 is 20 September)
    # is 0.51782528 × 86400 s = 44740.104192 s after midnight.
    assert tle_epoch_utc(sat) == "2008-09-20T12:25:40.104192"
    r, v = teme_state(sat, sat.jdsatepoch, sat.jdsatepochF)
    assert 6.6e6 < np.linalg.norm(r) < 6.8e6  # about 350 km up
    assert 7.6e3 < np.linalg.norm(v) < 7.8e3


def test_epoch_string_reads_back_to_sgp4s_epoch():
    # erfa.dtf2d (what coopsat.astro.timescales.run_epoch applies to an epoch_utc) gives back
    # the Julian date SGP4 counts from, so a run that starts at the TLE's epoch starts SGP4 at 0.
    # 2016-12-31 ends in a leap second: there SOFA's day is 86401 s and day 366.5 is 12:00:00.5.
    leap_day = (edit(ISS[0], 19, "16366.50000000"), ISS[1])
    for lines, iso in ((SAT5, "2000-06-27T18:50:19.733568"), (ISS, "2008-09-20T12:25:40.104192"),
                       (leap_day, "2016-12-31T12:00:00.500000")):
        sat = parse_tle(*lines)
        assert tle_epoch_utc(sat) == iso
        date, time = iso.split("T")
        h, m, s = time.split(":")
        jd1, jd2 = erfa.dtf2d("UTC", *(int(x) for x in date.split("-")), int(h), int(m), float(s))
        assert (jd1 - sat.jdsatepoch) + (jd2 - sat.jdsatepochF) == pytest.approx(0.0, abs=1e-11)  # 1 µs


def test_module_import_leaves_sgp4_and_erfa_unloaded():
    probe = "import sys, coopsat.astro.tle; print(sorted({'sgp4', 'erfa'} & set(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120, check=True)
    assert out.stdout.strip() == "[]"


# ----------------------------------------------------------------------------- malformed TLEs


def test_trailing_whitespace_and_newlines_are_ignored():
    sat = parse_tle(ISS[0] + "\n", ISS[1] + "   \r\n")
    assert tle_epoch_utc(sat) == "2008-09-20T12:25:40.104192"


def test_short_line_is_refused_with_its_length():
    assert one_line_error(ISS[0], ISS[1][:-1]) == "TLE line 2 is 68 characters long, not 69"
    assert one_line_error(ISS[0] + " 0", ISS[1]) == "TLE line 1 is 71 characters long, not 69"


def test_non_ascii_character_is_refused():
    line1 = ISS[0][:14] + "Ä" + ISS[0][15:]
    assert "line 1 column 15" in one_line_error(line1, ISS[1])


def test_lines_out_of_order_are_refused():
    assert one_line_error(ISS[1], ISS[0]) == "TLE line 1 starts with '2', not '1' (lines out of order?)"


def test_checksum_mismatch_names_both_digits():
    line2 = ISS[1][:15] + "2" + ISS[1][16:]  # inclination 51.6412: the sum drops by 4, 7 → 3
    assert one_line_error(ISS[0], line2) == "TLE line 2 checksum: column 69 says 7, the line sums to 3"
    line1 = ISS[0][:68] + "x"
    assert one_line_error(line1, ISS[1]) == "TLE line 1 checksum: column 69 holds 'x', not a digit"


def test_minus_sign_counts_one_in_the_checksum():
    # ISS line 1 has two minus signs: written as '+' they leave the sum two short.
    line1 = ISS[0].replace("-.", "+.", 1)
    assert one_line_error(line1, ISS[1]) == "TLE line 1 checksum: column 69 says 7, the line sums to 6"


def test_different_catalogue_numbers_are_refused():
    line2 = edit(ISS[1], 3, "25545")
    assert one_line_error(ISS[0], line2) == "TLE catalogue numbers differ: line 1 has '25544', line 2 has '25545'"


def test_unreadable_catalogue_number_is_refused():
    message = one_line_error(edit(ISS[0], 3, "2554x"), edit(ISS[1], 3, "2554x"))
    assert message == "TLE catalogue number (columns 3–7) does not parse: '2554x'"


def test_alpha5_catalogue_number_is_accepted():
    sat = parse_tle(edit(ISS[0], 3, "A5544"), edit(ISS[1], 3, "A5544"))
    assert sat.satnum == 105544


def test_filled_separator_column_is_refused():
    # Column 44 of line 1 separates the mean motion's two derivatives.
    message = one_line_error(edit(ISS[0], 44, "0"), ISS[1])
    assert message == "TLE line 1 column 44 holds '0', where a blank separates two fields"


# (line, first column, last column, field name in the message)
FIELDS = [
    (1, 19, 20, "epoch year"),
    (1, 21, 32, "epoch day"),
    (1, 34, 43, "first derivative of the mean motion"),
    (1, 45, 52, "second derivative of the mean motion"),
    (1, 54, 61, "BSTAR drag term"),
    (2, 9, 16, "inclination"),
    (2, 18, 25, "right ascension of the ascending node"),
    (2, 27, 33, "eccentricity"),
    (2, 35, 42, "argument of perigee"),
    (2, 44, 51, "mean anomaly"),
    (2, 53, 63, "mean motion"),
]


@pytest.mark.parametrize("number, first, last, name", FIELDS, ids=[f[3] for f in FIELDS])
def test_unreadable_field_is_refused_by_name(number, first, last, name):
    # A letter in the field's last column (a digit in every field), checksum made good, so that
    # only the field is wrong.
    lines = list(ISS)
    lines[number - 1] = edit(lines[number - 1], last, "x")
    text = lines[number - 1][first - 1 : last]
    assert one_line_error(*lines) == f"TLE line {number} {name} (columns {first}–{last}) does not parse: {text!r}"


def test_field_with_a_second_decimal_point_is_refused():
    line2 = edit(ISS[1], 9, " 51.64.6")
    assert "inclination (columns 9–16) does not parse" in one_line_error(ISS[0], line2)


def test_epoch_day_out_of_the_year_is_refused():
    line1 = edit(ISS[0], 19, "08400.51782528")
    message = one_line_error(line1, ISS[1])
    assert message == "TLE line 1 epoch day (columns 21–32) is 400.51782528, outside 1 ≤ day < 367"


def test_sgp4_error_is_raised_with_sgp4s_message():
    # 00005's elements at 17 rev/day: a = 6390 km, perigee a (1 − 0.186) = 5200 km, inside the
    # Earth at the epoch (mean anomaly 19°, near perigee). The set reads; SGP4 refuses to run it.
    from sgp4.api import SGP4_ERRORS

    sat = parse_tle(SAT5[0], edit(SAT5[1], 53, "17.00000000"))
    with pytest.raises(ValueError) as info:
        teme_state(sat, sat.jdsatepoch, sat.jdsatepochF)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith("SGP4 error 6 for catalogue number 00005 at 0.000 min from the TLE epoch")
    assert message.endswith(SGP4_ERRORS[6])


# ----------------------------------------------------------------------------- TEME → GCRF

# Dates inside the IERS-B table bundled with astropy (no download), across three decades.
IERS_B_DATES = ["1985-04-12T03:04:05", "1995-03-14T07:21:09.5", "2008-09-20T12:25:40.104192", "2020-11-03T22:48:00"]
STATES = {
    # 00005's TEME state at its epoch (low, eccentric orbit)
    "leo": (
        np.array([7022.46529266, -1400.08296755, 0.03995155]) * 1e3,
        np.array([1.893841015, 6.405893759, 4.534807250]) * 1e3,
    ),
    # geostationary distance, slightly inclined: the largest lever arm for an angle error
    "geo": (np.array([25298.4e3, 33731.2e3, 150.0e3]), np.array([-2459.76, 1844.82, 10.0])),
}


def astropy_epochs(iso):
    """astropy Time of the instant with the bundled IERS-B table for UT1 and the pole."""
    from astropy.time import Time
    from astropy.utils import iers

    table = iers.IERS_B.open()
    with iers.conf.set_temp("auto_download", False), iers.earth_orientation_table.set(table):
        t = Time(iso, scale="utc")
        xp, yp = (q.to_value("rad") for q in table.pm_xy(t))
        return t, (t.tt.jd1, t.tt.jd2), (t.ut1.jd1, t.ut1.jd2), (xp, yp), table


@pytest.mark.parametrize("state", STATES, ids=list(STATES))
@pytest.mark.parametrize("iso", IERS_B_DATES)
def test_teme_to_gcrf_matches_astropy(iso, state):
    # astropy's TEME → ITRS → CIRS → GCRS for a geocentric object: rotations only (GCRS with
    # the default obsgeoloc = 0, CIRS at the geocentre), velocity by finite differences of the
    # whole chain. Both sides take UT1 and the pole from the same IERS-B table. Measured
    # differences: position 0.08–0.34 mm in LEO, 0.5–2.0 mm at GEO (astropy's TEME → ITRS
    # leaves out the TIO locator s', 47 µas a century from J2000); velocity 5–6e-5 m/s in LEO,
    # 3.0–3.4e-4 m/s at GEO (the precession-nutation rate of TEME, which astropy's finite
    # difference includes and teme_to_gcrf leaves out).
    import astropy.units as u
    from astropy.coordinates import GCRS, TEME, CartesianDifferential, CartesianRepresentation
    from astropy.utils import iers

    r_teme, v_teme = STATES[state]
    t, tt, ut1, _, table = astropy_epochs(iso)
    r, v = teme_to_gcrf(r_teme, v_teme, *tt, *ut1)
    with iers.conf.set_temp("auto_download", False), iers.earth_orientation_table.set(table):
        rep = CartesianRepresentation(r_teme * u.m, differentials=CartesianDifferential(v_teme * u.m / u.s))
        gcrs = TEME(rep, obstime=t).transform_to(GCRS(obstime=t))
        r_ref, v_ref = gcrs.cartesian.xyz.to_value(u.m), gcrs.velocity.d_xyz.to_value(u.m / u.s)
    assert r.shape == (3,) and v.shape == (3,)
    assert np.linalg.norm(r - r_ref) <= 1e-2
    assert np.linalg.norm(v - v_ref) <= 1e-3


@pytest.mark.parametrize("iso", IERS_B_DATES)
def test_teme_to_gcrf_equals_the_way_through_the_itrf(iso):
    # Vallado's route written out: TEME → PEF by GMST82 (velocity less ω × r), PEF → ITRF by
    # polar motion W with the real pole, ITRF → GCRF by the IERS 2010 matrix with ω × r added
    # back, ω along the intermediate pole (taking it along the ITRF z axis instead, tilted by
    # the pole's 0.2″–0.5″, would move v by 4e-4 m/s in LEO, 6e-3 m/s at GEO). W and ω cancel:
    # the short form agrees to rounding (measured 8e-9 m, 2e-12 m/s), where W, were it applied
    # one way only, would move r by 0.2–80 m at these dates.
    _, tt, ut1, (xp, yp), _ = astropy_epochs(iso)
    c2i = erfa.c2i06a(*tt)
    w = erfa.pom00(xp, yp, erfa.sp00(*tt))
    c2t = erfa.c2tcio(c2i, erfa.era00(*ut1), w)
    omega_tirs = np.array([0.0, 0.0, OMEGA_EARTH_RAD_S])
    omega_gcrf = c2i.T @ omega_tirs
    for r_teme, v_teme in STATES.values():
        pef = erfa.rz(erfa.gmst82(*ut1), np.eye(3))
        r_pef = pef @ r_teme
        v_pef = pef @ v_teme - np.cross(omega_tirs, r_pef)
        r_long = c2t.T @ (w @ r_pef)
        v_long = c2t.T @ (w @ v_pef) + np.cross(omega_gcrf, r_long)
        r, v = teme_to_gcrf(r_teme, v_teme, *tt, *ut1)
        assert np.linalg.norm(r - r_long) <= 1e-7
        assert np.linalg.norm(v - v_long) <= 1e-10
        assert xp != 0.0 and yp != 0.0


def test_teme_to_gcrf_is_a_rotation():
    _, tt, ut1, _, _ = astropy_epochs("2008-09-20T12:25:40.104192")
    for r_teme, v_teme in STATES.values():
        r, v = teme_to_gcrf(r_teme, v_teme, *tt, *ut1)
        assert np.linalg.norm(r) == pytest.approx(np.linalg.norm(r_teme), rel=1e-15)
        assert np.linalg.norm(v) == pytest.approx(np.linalg.norm(v_teme), rel=1e-15)
        scale = np.linalg.norm(r_teme) * np.linalg.norm(v_teme)
        assert r @ v == pytest.approx(r_teme @ v_teme, abs=1e-14 * scale)
