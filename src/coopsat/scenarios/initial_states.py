"""Each spacecraft's initial position and velocity, by the form the scenario gives it in.

Two registries, by the ``[[spacecraft]]`` field that holds the state:

- :data:`ABSOLUTE`: ``r_eci_m``/``v_eci_m_s`` (inertial Cartesian), ``elements`` (classical
  elements), ``tle`` (a two-line element set through SGP4 at the run's epoch, TEME turned into
  the GCRF), ``oem`` (a CCSDS OEM file, interpolated to the run's epoch);
- :data:`RELATIVE`: ``relative`` (LVLH position and velocity about another spacecraft) and
  ``roe`` (quasi-nonsingular relative orbital elements about another spacecraft).

Each entry is ``fn(table, orbit, clock) -> (r_m (3,), v_m_s (3,))`` (a relative one also takes
the reference's state), where ``clock()`` gives the run's
:class:`~coopsat.plugins.earth_environment.RunClock` (built only for the forms that need a
date). A bad value raises :class:`ValueError` naming the cause in one line; the builder puts
the field's place in front.
"""

import math
from pathlib import Path

import numpy as np

from coopsat.astro.constants import MU_EARTH_M3_S2, central_body_name


def _cartesian(sc, orbit, clock):
    return np.asarray(sc.r_eci_m, dtype=float), np.asarray(sc.v_eci_m_s, dtype=float)


def _elements(el, orbit, clock):
    from coopsat.astro.kepler import elements_to_rv

    return elements_to_rv(
        el.a_m, el.e, math.radians(el.i_deg), math.radians(el.raan_deg), math.radians(el.argp_deg),
        math.radians(el.mean_anomaly_deg), orbit.mu_m3_s2,
    )


def _require_earth(orbit, what):
    if abs(orbit.mu_m3_s2 / MU_EARTH_M3_S2 - 1.0) > 0.01:
        raise ValueError(f"{what} is an Earth orbit and [orbit] mu_m3_s2 = {orbit.mu_m3_s2:.6g} is not the Earth's")


def _tle(table, orbit, clock):
    """SGP4 at the run's epoch (its UTC), TEME → GCRF with the epoch's UT1 (IERS)."""
    from coopsat.astro.timescales import earth_orientation_parameters, utc_from_tt
    from coopsat.astro.tle import parse_tle, teme_state, teme_to_gcrf

    _require_earth(orbit, "a TLE")
    satrec = parse_tle(table.line1, table.line2)
    tt = clock().epoch.tt
    utc = utc_from_tt(*tt)
    eop = earth_orientation_parameters(*utc)
    r_teme, v_teme = teme_state(satrec, *utc)
    return teme_to_gcrf(r_teme, v_teme, *tt, utc[0], utc[1] + eop.ut1_utc_s[0] / 86400.0)


OEM_FRAMES = {"GCRF": "GCRF", "ICRF": "GCRF", "EME2000": "EME2000"}
"""OEM ``REF_FRAME`` values read as an initial state, and the frame each is (the ICRF's axes are
the GCRF's)."""

OEM_TIME_SYSTEMS = ("UTC", "TT", "TAI")


def _frame_bias(frame, inertial_frame):
    """Matrix from the file's inertial axes to the run's: the IAU 2006 frame bias between
    EME2000 and the GCRF (23 mas, 0.7 m at the Earth's surface, 1 m per 10 000 km) where they
    differ, else the identity."""
    import erfa

    if frame == inertial_frame or inertial_frame not in ("GCRF", "EME2000"):
        return np.eye(3)
    bias = erfa.bp06(2451545.0, 0.0)[0]  # GCRF → EME2000, constant
    return bias.T if frame == "EME2000" else bias


def _oem(table, orbit, clock):
    """The state at the run's epoch from the file's segment (its own sample when one falls on the
    epoch, to the microsecond; else the ``oem`` package's interpolation, as the file asks)."""
    import oem
    from astropy.time import Time

    try:
        message = oem.OrbitEphemerisMessage.open(Path(table.file))
    except FileNotFoundError:
        raise ValueError(f"file: {table.file} does not exist") from None
    except Exception as err:  # the reader's own errors name no common base class
        raise ValueError(f"file: {table.file} is not a readable OEM ({str(err).splitlines()[0] if str(err) else type(err).__name__})") from None
    segments = [s for s in message if table.object is None or s.metadata["OBJECT_NAME"] == table.object]
    names = sorted({s.metadata["OBJECT_NAME"] for s in message})
    if not segments:
        raise ValueError(f"object: no segment of {table.file} is for '{table.object}' (it holds {', '.join(names)})")
    if table.object is None and len(names) > 1:
        raise ValueError(f"object: {table.file} holds {', '.join(names)}; say which (object = ...)")
    clk = clock()
    when = Time(*clk.epoch.tt, format="jd", scale="tt")
    segment = next((s for s in segments if when in s), None)
    if segment is None:
        spans = "; ".join(f"{s.span[0].tt.isot} … {s.span[1].tt.isot} TT" for s in segments)
        raise ValueError(f"file: {table.file} does not cover the run's epoch {clk.epoch.tt_iso} TT ({spans})")
    meta = segment.metadata
    frame, system, centre = meta["REF_FRAME"], meta["TIME_SYSTEM"], meta["CENTER_NAME"]
    if frame not in OEM_FRAMES:
        raise ValueError(f"file: REF_FRAME = {frame} in {table.file} is not an inertial frame read here ({', '.join(OEM_FRAMES)})")
    if system not in OEM_TIME_SYSTEMS:
        raise ValueError(f"file: TIME_SYSTEM = {system} in {table.file} is not one read here ({', '.join(OEM_TIME_SYSTEMS)})")
    if centre != central_body_name(orbit.mu_m3_s2):
        raise ValueError(f"file: CENTER_NAME = {centre} in {table.file} is not the run's central body")
    exact = next((s for s in segment.states if abs((s.epoch - when).to_value("s")) < 1e-6), None)
    state = exact if exact is not None else segment(when)
    bias = _frame_bias(OEM_FRAMES[frame], clk.oriented.inertial_frame)
    return bias @ (np.asarray(state.position, dtype=float) * 1e3), bias @ (np.asarray(state.velocity, dtype=float) * 1e3)


ABSOLUTE = {"r_eci_m": _cartesian, "elements": _elements, "tle": _tle, "oem": _oem}
"""A spacecraft's own state, by the field that gives it (``r_eci_m`` reads the spacecraft table
itself, the others their sub-table)."""


def _lvlh(table, orbit, clock, r_ref, v_ref):
    from coopsat.geometry.frames import lvlh_to_eci

    r, v = lvlh_to_eci(r_ref, v_ref, np.asarray(table.rho_lvlh_m), np.asarray(table.rho_dot_lvlh_m_s))
    return np.asarray(r), np.asarray(v)


def _roe(table, orbit, clock, r_ref, v_ref):
    from coopsat.astro.kepler import rv_to_elements
    from coopsat.astro.roe import rv_from_roe

    a_m = rv_to_elements(r_ref, v_ref, orbit.mu_m3_s2).a_m
    return rv_from_roe(r_ref, v_ref, np.asarray(table.a_droe_m) / a_m, orbit.mu_m3_s2)


RELATIVE = {"relative": _lvlh, "roe": _roe}
"""A state given about another spacecraft, by field."""


def _by_field(field, fn, *args):
    """``fn(*args)``; its one-line ValueError is given the field's name in front."""
    try:
        return fn(*args)
    except ValueError as err:
        raise ValueError(f"{field}: {err}") from None


def absolute_state(sc, orbit, clock):
    """(r, v) of a spacecraft whose own state is given (:data:`ABSOLUTE`); a ValueError names
    the field first (``"tle: …"``)."""
    field = next(f for f in ABSOLUTE if getattr(sc, f) is not None)
    return _by_field(field, ABSOLUTE[field], sc if field == "r_eci_m" else getattr(sc, field), orbit, clock)


def relative_state(sc, orbit, clock, r_ref, v_ref):
    """(r, v) of a spacecraft given about another (:data:`RELATIVE`); errors as :func:`absolute_state`."""
    field = next(f for f in RELATIVE if getattr(sc, f) is not None)
    return _by_field(field, RELATIVE[field], getattr(sc, field), orbit, clock, r_ref, v_ref)
