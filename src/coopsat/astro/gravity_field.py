"""The Earth's gravity field in spherical harmonics: EGM2008 to degree and order 70.

The coefficients are EGM2008's, fully normalised and tide-free (``data/egm2008_70.txt`` states
their source and licence). :func:`harmonic_accel_ecef` evaluates the field's non-central part,
degrees 2…N, in the Earth-fixed frame with Pines' singularity-free formulation: the derived
Legendre functions ``Ā_nm(u)`` of ``u = z/r`` carry no ``cos^m φ`` factor, which lives instead in
``(s + i t)^m`` with ``s = x/r``, ``t = y/r``, so nothing divides by ``cos φ`` at the poles. It is
written with ``jax.numpy`` and traces under ``jit``; the loops over degree and order unroll
at trace time (static ``N``), and every operation acts on all spacecraft at once.
"""

from functools import lru_cache
from importlib import resources
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np


MAX_DEGREE = 70
"""Highest degree (and order) shipped in ``data/egm2008_70.txt``."""

EGM2008_GM_M3_S2 = 3.986004415e14
"""EGM2008's gravitational parameter, m³/s² (the coefficients are scaled by it)."""

EGM2008_RADIUS_M = 6378136.3
"""EGM2008's reference radius, m."""


class FieldCoefficients(NamedTuple):
    """Fully normalised coefficients to degree N (arrays (N+1, N+1), ``[n, m]``, zero above the
    diagonal and beyond the order kept), with the model's GM (m³/s²) and reference radius (m)."""

    c: np.ndarray
    s: np.ndarray
    gm_m3_s2: float
    radius_m: float


@lru_cache(maxsize=1)
def _egm2008_table():
    text = resources.files("coopsat.astro").joinpath("data/egm2008_70.txt").read_text()
    rows = np.loadtxt(text.splitlines(), comments="#")
    c = np.zeros((MAX_DEGREE + 1, MAX_DEGREE + 1))
    s = np.zeros_like(c)
    n, m = rows[:, 0].astype(int), rows[:, 1].astype(int)
    c[n, m], s[n, m] = rows[:, 2], rows[:, 3]
    return c, s


def egm2008(degree, order=None):
    """EGM2008 coefficients to ``degree`` and ``order`` (design time, NumPy).

    Parameters
    ----------
    degree : int
        2 … :data:`MAX_DEGREE`.
    order : int, optional
        0 … ``degree`` (default ``degree``): orders above it are dropped (``order = 0``: the
        zonal terms only).

    Returns
    -------
    FieldCoefficients

    Raises
    ------
    ValueError
        A degree outside 2 … 70 or an order outside 0 … degree, naming the field.
    """
    order = degree if order is None else order
    if not 2 <= degree <= MAX_DEGREE:
        raise ValueError(f"degree {degree} is outside the model's 2 … {MAX_DEGREE} (EGM2008 as shipped)")
    if not 0 <= order <= degree:
        raise ValueError(f"order {order} is outside 0 … degree ({degree})")
    c, s = _egm2008_table()
    keep = np.arange(degree + 1)[None, :] <= order
    return FieldCoefficients(
        np.where(keep, c[: degree + 1, : degree + 1], 0.0), np.where(keep, s[: degree + 1, : degree + 1], 0.0),
        EGM2008_GM_M3_S2, EGM2008_RADIUS_M,
    )


def _recursion_factors(degree):
    """Factors of the normalised derived-Legendre recursions, arrays (N+1, N+1) ``[n, m]``.

    ``Ā_nm = a_nm u Ā_{n-1,m} − b_nm Ā_{n-2,m}`` (m < n), ``Ā_nn = c_n Ā_{n-1,n-1}`` and
    ``dĀ_nm/du = d_nm Ā_{n,m+1}``; see :func:`harmonic_accel_ecef`.
    """
    n = np.arange(degree + 1, dtype=float)[:, None]
    m = np.arange(degree + 1, dtype=float)[None, :]
    below = m < n
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.where(below, np.sqrt((2 * n - 1) * (2 * n + 1) / ((n - m) * (n + m))), 0.0)
        b = np.where(m < n - 1, np.sqrt((2 * n + 1) * (n + m - 1) * (n - m - 1) / ((n - m) * (n + m) * (2 * n - 3))), 0.0)
        d = np.where(below, np.sqrt(np.where(m == 0, 0.5, 1.0) * (n - m) * (n + m + 1)), 0.0)
    degrees = np.arange(degree + 1, dtype=float)
    c = np.sqrt((2 * degrees + 1) / np.maximum(2 * degrees, 1.0))
    c[0], c[1] = 0.0, np.sqrt(3.0)  # Ā_11 = √3 Ā_00: the order-0 normalisation lacks the factor 2 of the others
    return np.nan_to_num(a), np.nan_to_num(b), c, d


def harmonic_accel_ecef(r_ecef_m, c, s, gm_m3_s2, radius_m, axis=-1):
    """Acceleration of the field's degrees 2…N, m/s², Earth-fixed axes.

    Parameters
    ----------
    r_ecef_m : array_like, shape (..., 3) (component ``axis``)
        Position in the Earth-fixed frame, m.
    c, s : array_like, (N+1, N+1)
        Fully normalised coefficients ``[n, m]`` (:func:`egm2008`); degrees 0 and 1 are
        ignored (the central term is the plant's two-body gravity).
    gm_m3_s2, radius_m : float
        The model's GM and reference radius.
    axis : int
        Component axis (0: the loop's component-major (3, n)).

    Returns
    -------
    jax.Array, the shape of ``r_ecef_m``

    Notes
    -----
    Pines (1973), normalised as in Montenbruck & Gill, *Satellite Orbits*, §3.2 (eq. 3.13 for
    the potential). With ``q = R/r`` the potential is
    ``U = GM/r Σ_n Σ_m Ã_nm (C̄_nm Re w^m + S̄_nm Im w^m)``, ``w = s + i t``, where
    ``Ã_nm = q^n Ā_nm(u)`` obeys the recursions of ``Ā`` with each step in n scaled by q. Taking
    ``r, s, t, u`` as independent variables ``f(r, s, t, u)``, the gradient is
    ``∇U = (f_r − (s f_s + t f_t + u f_u)/r) r̂ + (f_s, f_t, f_u)/r``, with
    ``∂Re w^m/∂s = m Re w^{m−1}``, ``∂Im w^m/∂s = m Im w^{m−1}``, ``∂Re w^m/∂t = −m Im w^{m−1}``,
    ``∂Im w^m/∂t = m Re w^{m−1}`` and ``dĀ_nm/du = d_nm Ā_{n,m+1}`` with
    ``d_nm = √((2 − δ_m0)/2 · (n − m)(n + m + 1))`` (the ratio of the normalisations of
    ``d^m P_n/du^m`` and ``d^{m+1} P_n/du^{m+1}``).

    The sums run over the degrees first: for each order m, six per-order sums of ``Ã_nm``
    weighted by the coefficients (:func:`_per_order_weights`), which the powers of w then
    combine once. Degree n is a row of its n + 1 orders only (the triangle, not the square),
    unrolled at trace time: measured in the loop at N = 1000 spacecraft, degree 20, 4.3 ms a
    tick against 16.5 ms for a ``fori_loop`` over square rows summed degree by degree, for a
    compile of 10.7 s against 6.3 s (degree 70: 48 against 181 ms, 57 against 27 s).
    """
    degree = jnp.shape(c)[0] - 1
    a_f, b_f, c_f, _ = _recursion_factors(degree)
    x, y, z = jnp.moveaxis(jnp.asarray(r_ecef_m), axis, 0)
    r = jnp.sqrt(x * x + y * y + z * z)
    sx, ty, u, q = x / r, y / r, z / r, radius_m / r
    col = (Ellipsis,) + (None,) * r.ndim  # a vector over orders against the spacecraft axes
    weights = _per_order_weights(jnp.asarray(c), jnp.asarray(s))
    qu, qq = q * u, q * q
    # Rows 0 and 1 of Ã (Ã_00 = 1; Ã_10 = √3 u q, Ã_11 = √3 q) start the recursion over 2 … N.
    prev2 = jnp.ones((1,) + r.shape, dtype=r.dtype)
    prev = jnp.stack([np.sqrt(3.0) * qu, np.sqrt(3.0) * q])
    sums = jnp.zeros((6, degree + 1) + r.shape, dtype=r.dtype)
    for n in range(2, degree + 1):
        below = prev2 if n == 2 else jnp.concatenate([prev2, jnp.zeros_like(prev2[:1])])  # Ã_{n−2,m}, 0 at m = n − 1
        lower = a_f[n, :n][col] * qu * prev - b_f[n, :n][col] * qq * below  # Ã_nm, m < n
        row = jnp.concatenate([lower, (c_f[n] * q * prev[-1])[None]])  # Ã_nn = c_n q Ã_{n−1,n−1}
        sums = sums.at[:, : n + 1].add(weights[:, n, : n + 1][col] * row[None])
        prev2, prev = prev, row
    # w^m = (s + i t)^m, m = 0 … N, and w^{m−1} (zero at m = 0, where the factor m kills it).
    re, im = [jnp.ones_like(r)], [jnp.zeros_like(r)]
    for _ in range(degree):
        re, im = re + [sx * re[-1] - ty * im[-1]], im + [sx * im[-1] + ty * re[-1]]
    re, im = jnp.stack(re), jnp.stack(im)
    re_1 = jnp.concatenate([jnp.zeros_like(re[:1]), re[:-1]])
    im_1 = jnp.concatenate([jnp.zeros_like(im[:1]), im[:-1]])
    rad_c, rad_s, ord_c, ord_s, du_c, du_s = sums
    radial = jnp.sum(rad_c * re + rad_s * im, axis=0)
    g_s = jnp.sum(ord_c * re_1 + ord_s * im_1, axis=0)
    g_t = jnp.sum(ord_s * re_1 - ord_c * im_1, axis=0)
    g_u = jnp.sum(du_c * re_1 + du_s * im_1, axis=0)
    scale = gm_m3_s2 / (r * r)
    along_r = -radial - (sx * g_s + ty * g_t + u * g_u)
    return jnp.stack([scale * (along_r * sx + g_s), scale * (along_r * ty + g_t), scale * (along_r * u + g_u)], axis=axis)


def _per_order_weights(c, s):
    """Weights ``[k, n, m]`` (6, N+1, N+1) of ``Ã_nm`` in the six per-order sums over n.

    Parameters
    ----------
    c, s : (N+1, N+1)
        Fully normalised coefficients ``[n, m]`` (traced: a campaign may disperse them).

    Returns
    -------
    jax.Array
        ``(n+1) C̄_nm``, ``(n+1) S̄_nm`` (the radial derivative, against ``Re w^m``, ``Im w^m``);
        ``m C̄_nm``, ``m S̄_nm`` (the s and t derivatives, against ``w^{m−1}``); and
        ``d_{n,m−1} C̄_{n,m−1}``, ``d_{n,m−1} S̄_{n,m−1}`` at m (the u derivative,
        ``Σ_m d_nm Ã_{n,m+1} (C̄_nm Re w^m + S̄_nm Im w^m)`` shifted by one order, against
        ``w^{m−1}``).
    """
    degree = c.shape[0] - 1
    _, _, _, d_f = _recursion_factors(degree)
    n = np.arange(degree + 1, dtype=float)[:, None]
    m = np.arange(degree + 1, dtype=float)[None, :]
    shifted = lambda coef: jnp.zeros_like(coef).at[:, 1:].set(d_f[:, :-1] * coef[:, :-1])  # noqa: E731
    return jnp.stack([(n + 1) * c, (n + 1) * s, m * c, m * s, shifted(c), shifted(s)])


def harmonic_potential(r_ecef_m, c, s, gm_m3_s2, radius_m, axis=-1):
    """Potential of the field's degrees 2…N, m²/s² (positive convention, ``a = ∇U``).

    Same parameters as :func:`harmonic_accel_ecef`; returns the shape without the component
    axis. Written from the classical sum over ``P̄_nm(sin φ) (C̄ cos mλ + S̄ sin mλ)`` so that a
    test can check the acceleration against its independent gradient and the energy it
    conserves.
    """
    c = jnp.asarray(c)
    s_coef = jnp.asarray(s)
    degree = c.shape[0] - 1
    a_f, b_f, c_f, _ = (jnp.asarray(v) for v in _recursion_factors(degree))
    x, y, z = jnp.moveaxis(jnp.asarray(r_ecef_m), axis, 0)
    r = jnp.sqrt(x * x + y * y + z * z)
    u = z / r
    cos_lat = jnp.sqrt(x * x + y * y) / r
    lon = jnp.arctan2(y, x)
    total = jnp.zeros_like(r)
    previous, current = None, None
    for n in range(0, degree + 1):
        row = []
        for m in range(n + 1):
            if m == n:
                row.append(jnp.ones_like(r) if n == 0 else c_f[n] * cos_lat * current[n - 1])
            else:
                p2 = previous[m] if (previous is not None and m < n - 1) else 0.0
                row.append(a_f[n, m] * u * current[m] - b_f[n, m] * p2)
        previous, current = current, row
        if n >= 2:
            shell = sum(row[m] * (c[n, m] * jnp.cos(m * lon) + s_coef[n, m] * jnp.sin(m * lon)) for m in range(n + 1))
            total = total + (radius_m / r) ** n * shell
    return gm_m3_s2 / r * total
