"""The Earth's orientation in the inertial frame over a run: computed before it, applied inside it.

Two models, by name (:data:`EARTH_ORIENTATION_MODELS`, ``[orbit] earth_orientation``):

- ``"iau2006"`` (the default): the IERS 2010 conventions' CIO-based transformation,
  ``r_itrf = W · R3(ERA) · Q · r_gcrf``, with ``Q`` the celestial-to-intermediate matrix of the
  IAU 2006 precession and IAU 2000A nutation (``erfa.c2i06a``, frame bias included), ``ERA`` the
  Earth rotation angle of UT1 (``erfa.era00``), and ``W`` polar motion (``erfa.pom00`` with the
  IERS pole and the TIO locator ``s'``). UT1 − UTC and the pole come from the IERS Bulletin A
  (:func:`coopsat.astro.timescales.earth_orientation_parameters`). The inertial frame is the
  GCRF, the Earth-fixed frame the ITRF. This is the chain astropy's GCRS ↔ ITRS follows.
- ``"gmst82"``: the papers' Earth (SPEC §0): a turn about the inertial z axis by the IAU-82
  Greenwich mean sidereal angle, ``θ = GMST(UT1 = UTC at the epoch) + ω_E t``, no precession,
  nutation or polar motion. Kept to reproduce a paper as published and to measure what the
  real Earth changes (docs/time-and-frames.md); the inertial frame is then only "J2000-like".

Both become one :class:`EarthOrientation` table, sampled every ``step_s`` seconds of the run's
TT clock from t = 0 to past its end; inside the compiled loop :func:`itrf_from_gcrf_matrix`
interpolates it linearly (the angle and the two slowly turning matrices) and composes the
rotation. Interpolation error, measured against SOFA at every second of a day with the
default 3600 s step: tests/unit/astro/test_earth_orientation.py (below 1 mm at the surface).
"""

from typing import NamedTuple

import jax.numpy as jnp
import numpy as np

from coopsat.astro.earth import OMEGA_EARTH_RAD_S, gmst_rad

STEP_S = 3600.0
"""Default spacing of the table, s of TT. Nutation's fastest large term (0.2″, 13.7 days) bends
between samples by 1e-5″ at this step; the angle is linear in UT1, whose rate changes by
milliseconds a day."""


class EarthOrientation(NamedTuple):
    """The Earth's orientation sampled over a run (a JAX pytree: arrays only).

    Attributes
    ----------
    step_s : scalar
        Sample spacing, s of the run's clock (sample k at ``t = k step_s``).
    angle_rad : (K,)
        The rotation angle about the intermediate pole (ERA, or GMST for ``gmst82``), rad,
        unwrapped (continuous), so that it interpolates linearly.
    q_c2i : (K, 3, 3)
        Celestial (GCRF) to intermediate (CIRS) matrix ``Q``; the identity for ``gmst82``.
    w_pole : (K, 3, 3)
        Polar motion ``W`` (TIRS to ITRF); the identity for ``gmst82``.
    """

    step_s: object
    angle_rad: object
    q_c2i: object
    w_pole: object


class Oriented(NamedTuple):
    """An :class:`EarthOrientation` with what it was built from (design time).

    Attributes
    ----------
    table : EarthOrientation
        NumPy arrays (the builder's ``as_arrays`` makes them JAX's).
    model : str
    inertial_frame : str
        ``"GCRF"`` or ``"J2000-like"``.
    eop_source : str
        Where UT1 − UTC and the pole came from.
    """

    table: EarthOrientation
    model: str
    inertial_frame: str
    eop_source: str


def _sample_times(span_s, step_s):
    """(K,) sample times covering [0, span_s] with one sample to spare, s."""
    count = int(np.ceil(max(span_s, 0.0) / step_s)) + 2
    return np.arange(count) * step_s


def iau2006_table(epoch, span_s, step_s=STEP_S):
    """The IAU 2006/2000A orientation over ``[0, span_s]`` of a run.

    Parameters
    ----------
    epoch : coopsat.astro.timescales.RunEpoch
    span_s : float
        Run length, s.
    step_s : float

    Returns
    -------
    Oriented
    """
    import erfa

    from coopsat.astro.timescales import SECONDS_PER_DAY, earth_orientation_parameters, utc_from_tt

    t = _sample_times(span_s, step_s)
    tt1 = np.full(t.shape, epoch.tt[0])
    tt2 = epoch.tt[1] + t / SECONDS_PER_DAY
    utc = np.array([utc_from_tt(a, b, strict=False) for a, b in zip(tt1, tt2)])  # K is small: hours of a run
    eop = earth_orientation_parameters(utc[:, 0], utc[:, 1])
    ut1_2 = utc[:, 1] + eop.ut1_utc_s / SECONDS_PER_DAY
    angle = np.unwrap(erfa.era00(utc[:, 0], ut1_2))
    q = erfa.c2i06a(tt1, tt2)
    w = erfa.pom00(eop.xp_rad, eop.yp_rad, erfa.sp00(tt1, tt2))
    table = EarthOrientation(np.float64(step_s), angle, q, w)
    return Oriented(table, "iau2006", INERTIAL_FRAMES["iau2006"], eop.source)


def gmst82_table(epoch, span_s, step_s=STEP_S):
    """The papers' Earth: ``R3(GMST(epoch) + ω_E t)``, UT1 taken as UTC (SPEC §0).

    Parameters and returns as :func:`iau2006_table`.
    """
    from coopsat.astro.earth import julian_date_utc

    gmst0_rad = gmst_rad(julian_date_utc(epoch.utc_iso or epoch.tt_iso))
    return Oriented(z_rotation(gmst0_rad, span_s, step_s), "gmst82", INERTIAL_FRAMES["gmst82"],
                    "none (UT1 = UTC, no polar motion: SPEC §0)")


EARTH_ORIENTATION_MODELS = {"iau2006": iau2006_table, "gmst82": gmst82_table}
"""Builders of the Earth's orientation, by ``[orbit] earth_orientation``."""

INERTIAL_FRAMES = {"iau2006": "GCRF", "gmst82": "J2000-like"}
"""The inertial frame a run flies in, by Earth orientation model (what ``result.nc`` and the
exports call it; EME2000 in a CCSDS message for the J2000-like one)."""


def z_rotation(angle0_rad, span_s, step_s=STEP_S):
    """A bare turn about z, ``θ = angle0 + ω_E t`` (tests and hand-built parts), NumPy arrays."""
    t = _sample_times(span_s, step_s)
    eye = np.broadcast_to(np.eye(3), (t.size, 3, 3)).copy()
    return EarthOrientation(np.float64(step_s), angle0_rad + OMEGA_EARTH_RAD_S * t, eye, eye.copy())


def _r3(angle_rad, xp):
    """``R3(θ)`` (frame rotation about z), shape (..., 3, 3)."""
    c, s = xp.cos(angle_rad), xp.sin(angle_rad)
    zero, one = xp.zeros_like(c), xp.ones_like(c)
    return xp.stack([xp.stack([c, s, zero], -1), xp.stack([-s, c, zero], -1), xp.stack([zero, zero, one], -1)], -2)


def _interpolate(table, t_s, xp):
    """(angle (...), Q (..., 3, 3), W (..., 3, 3)) at run times ``t_s`` (shape (...)), linear
    between samples; times past the table hold its last interval's slope."""
    table = EarthOrientation(*(xp.asarray(v) for v in table))  # a NumPy table indexes by traced k too
    t = xp.asarray(t_s, dtype=float)
    pos = t / table.step_s
    k = xp.clip(xp.floor(pos).astype(xp.int32), 0, table.angle_rad.shape[0] - 2)
    f = pos - k
    fm = f[..., None, None]
    angle = table.angle_rad[k] + f * (table.angle_rad[k + 1] - table.angle_rad[k])
    q = table.q_c2i[k] + fm * (table.q_c2i[k + 1] - table.q_c2i[k])
    w = table.w_pole[k] + fm * (table.w_pole[k + 1] - table.w_pole[k])
    return angle, q, w


def itrf_from_gcrf_matrix(table, t_s, xp=jnp):
    """The matrix ``W R3(θ) Q`` taking inertial components to Earth-fixed ones at ``t_s``.

    Parameters
    ----------
    table : EarthOrientation
    t_s : array_like, shape (...)
        Run time, s (a scalar, or one time per spacecraft in a pulsed tick).
    xp : module
        ``jax.numpy`` (in the loop) or ``numpy`` (design time and exports: float64 whatever
        JAX's x64 setting, with a NumPy table).

    Returns
    -------
    array, shape (..., 3, 3)
    """
    angle, q, w = _interpolate(table, t_s, xp)
    return w @ _r3(angle, xp) @ q


def rotate(matrix, vec, axis=-1):
    """``matrix · vec``, shape of ``vec``, with ``vec``'s components along ``axis``; the
    matrix's leading shape (..., 3, 3) broadcasts against ``vec``'s other axes."""
    v = jnp.moveaxis(jnp.asarray(vec), axis, -1)
    return jnp.moveaxis((matrix @ v[..., None])[..., 0], -1, axis)


def gcrf_to_itrf(vec_gcrf, t_s, table, axis=-1):
    """Inertial components of a vector to Earth-fixed ones.

    Parameters
    ----------
    vec_gcrf : array_like, shape (..., 3) (component ``axis``)
        Position or direction (a velocity relative to the rotating Earth is not turned this
        way: see :func:`earth_fixed_point_gcrf`).
    t_s : array_like
        Run time, s: a scalar, or shape ``(n,)`` against ``(3, n)`` with ``axis=0``.
    table : EarthOrientation
    axis : int
        Component axis.

    Returns
    -------
    jax.Array, the shape of ``vec_gcrf``.
    """
    return rotate(itrf_from_gcrf_matrix(table, t_s), vec_gcrf, axis)


def itrf_to_gcrf(vec_itrf, t_s, table, axis=-1):
    """Earth-fixed components to inertial ones (inverse of :func:`gcrf_to_itrf`; parameters as there)."""
    return rotate(jnp.swapaxes(itrf_from_gcrf_matrix(table, t_s), -1, -2), vec_itrf, axis)


def rotation_rate_gcrf(t_s, table):
    """The Earth's angular velocity in inertial components, rad/s, shape ``t_s.shape + (3,)``:
    ``ω_E`` along the intermediate pole ``Qᵀ ẑ`` (polar motion, 1e-6 rad, is left out)."""
    return OMEGA_EARTH_RAD_S * _interpolate(table, t_s, jnp)[1][..., 2, :]


def earth_fixed_point_gcrf(r_itrf_m, t_s, table, axis=-1):
    """Inertial position, velocity and acceleration of a point fixed to the Earth.

    Parameters
    ----------
    r_itrf_m : array_like, shape (..., 3) (component ``axis``)
        The point, ITRF, m.
    t_s, table, axis
        As :func:`gcrf_to_itrf`.

    Returns
    -------
    r_gcrf_m, v_gcrf_m_s, a_gcrf_m_s2 : jax.Array
        ``Mᵀ r``, ``ω × r`` and ``ω × (ω × r)`` with ``ω`` of :func:`rotation_rate_gcrf`
        (its direction moves by 1e-9 rad a day, so its derivative is left out).
    """
    r = itrf_to_gcrf(r_itrf_m, t_s, table, axis)
    w = rotation_rate_gcrf(t_s, table)
    r_last = jnp.moveaxis(r, axis, -1)
    v = jnp.cross(w, r_last)
    return r, jnp.moveaxis(v, -1, axis), jnp.moveaxis(jnp.cross(w, v), -1, axis)
