"""Tools for linear time-invariant systems ``ẋ = A x + B u``, ``y = C x``.

Kalman controllability and observability ranks (on normalised matrices, so that units differing
by orders of magnitude do not drown one block in another), the stabilisability and
detectability test that every LMI design runs first (:func:`check_pair`; its one-line error
names the failing pair and its modes), Bryson's weights, and the feed-forward of a non-zero
set point (deep-space paper, eq. 17). The formation of SPEC §4 is built on them
(:mod:`coopsat.design.formation_model`, :mod:`coopsat.design.formation_synthesis`).
"""

import math

import numpy as np

from coopsat.core.errors import DesignError


class FormationDesignError(DesignError):
    """A formation design step failed; the message (one line) says which and why."""


def finite_matrix(name, value):
    """``value`` as a finite 2-D float array (a scalar or vector promoted); ValueError naming ``name``."""
    m = np.atleast_2d(np.asarray(value, dtype=float))
    if m.ndim != 2 or not np.all(np.isfinite(m)):
        raise ValueError(f"{name} must be a finite 2-D array, got shape {np.shape(value)}")
    return m


def kalman_observability(a, c, rtol=1e-9):
    """Rank of the observability matrix and an orthonormal basis of the unobservable subspace.

    Parameters
    ----------
    a : array_like, shape (n, n)
    c : array_like, shape (p, n)
    rtol : float
        Singular values at or below ``rtol`` times the largest count as zero.

    Returns
    -------
    rank : int
    unobservable : ndarray, shape (n, n − rank)
        Orthonormal columns spanning the kernel of [C; CA; …; CA^{n−1}].

    Notes
    -----
    The kernel does not change under A → A/‖A‖ (a time scale) or under scaling the rows of C
    (output units), so both are normalised before the SVD; that keeps the powers of A from
    drowning one block in another when the units differ by orders of magnitude.
    """
    a, c = finite_matrix("a", a), finite_matrix("c", c)
    n = a.shape[0]
    if a.shape != (n, n) or c.shape[1] != n:
        raise ValueError(f"shapes do not match: a {a.shape}, c {c.shape}")
    row_norms = np.linalg.norm(c, axis=1)
    rows = c[row_norms > 0.0] / row_norms[row_norms > 0.0, None]
    if rows.shape[0] == 0:
        return 0, np.eye(n)
    norm_a = np.linalg.norm(a, 2)
    a_s = a / norm_a if norm_a > 0.0 else a
    blocks = [rows]
    for _ in range(n - 1):
        blocks.append(blocks[-1] @ a_s)
    _, sv, vt = np.linalg.svd(np.vstack(blocks))
    rank = int(np.sum(sv > rtol * sv[0]))
    return rank, vt[rank:].T


def kalman_controllability(a, b, rtol=1e-9):
    """Rank of the controllability matrix and an orthonormal basis of its orthogonal complement.

    Parameters
    ----------
    a : array_like, shape (n, n)
    b : array_like, shape (n, m)
    rtol : float
        As :func:`kalman_observability`.

    Returns
    -------
    rank : int
    uncontrollable : ndarray, shape (n, n − rank)
        Orthonormal columns spanning the orthogonal complement of range [B, AB, …]; the
        uncontrollable dynamics are ``uncontrollableᵀ a uncontrollable``.
    """
    a, b = finite_matrix("a", a), finite_matrix("b", b)
    return kalman_observability(a.T, b.T, rtol)


def _unstable_modes(a, basis):
    """Eigenvalues of the dynamics on ``basis`` (an invariant subspace or its quotient) that are
    not in the open left half-plane, tiny ones shown as 0."""
    if basis.shape[1] == 0:
        return np.zeros(0, dtype=complex)
    scale = max(np.linalg.norm(a, 2), np.finfo(float).tiny)
    eig = np.linalg.eigvals(basis.T @ a @ basis)
    # A nilpotent block of size k has eigenvalues ~ε^{1/k}‖A‖ in floating point: √ε is zero.
    tol = math.sqrt(np.finfo(float).eps) * scale
    eig = np.where(np.abs(eig) < tol, 0.0, eig)
    return eig[eig.real >= -tol]


def _format_eigs(eig):
    def one(z):
        return f"{z.real:.3g}" if z.imag == 0.0 else f"{z.real:.3g}{z.imag:+.3g}j"

    return ", ".join(one(complex(z)) for z in eig)


def check_pair(a, b, c=None, what="system", names=("A", "B", "C"), rtol=1e-9):
    """Raise unless (a, b) is stabilisable and (a, c) detectable.

    Parameters
    ----------
    a : array_like, shape (n, n)
    b : array_like, shape (n, m), or None
        Checked for stabilisability when given.
    c : array_like, shape (p, n), optional
        Checked for detectability when given.
    what : str
        The design step, first in the message ("state feedback", "observer").
    names : (str, str, str)
        Symbols of a, b, c in the message.
    rtol : float
        Rank tolerance, see :func:`kalman_observability`.

    Raises
    ------
    FormationDesignError
        One line, e.g. "state feedback: (A_o, B_o) is not controllable (rank 10 of 12) and
        not stabilisable: uncontrollable modes at 0, 0".

    Notes
    -----
    Stabilisability and detectability are what the LMIs of eq. (11) need; a double
    integrator's uncontrollable or unobservable modes sit at 0, so for this formation they
    coincide with controllability and observability.
    """
    if b is None and c is None:
        raise ValueError("check_pair needs b or c")
    a = finite_matrix("a", a)
    n = a.shape[0]
    if b is not None:
        rank, basis = kalman_controllability(a, b, rtol)
        bad = _unstable_modes(a, basis)
        if bad.size:
            raise FormationDesignError(
                f"{what}: ({names[0]}, {names[1]}) is not controllable (rank {rank} of {n}) and not "
                f"stabilisable: uncontrollable modes at {_format_eigs(bad)}"
            )
    if c is not None:
        rank, basis = kalman_observability(a, c, rtol)
        bad = _unstable_modes(a, basis)
        if bad.size:
            raise FormationDesignError(
                f"{what}: ({names[0]}, {names[2]}) is not observable (rank {rank} of {n}) and not "
                f"detectable: unobservable modes at {_format_eigs(bad)}"
            )


def nonzero_setpoint_feedforward(a, b, c, k):
    """Feed-forward N of the non-zero set-point law ``u = −k x + N y_d`` (eq. 17).

    Parameters
    ----------
    a : array_like, shape (n, n)
    b : array_like, shape (n, m)
    c : array_like, shape (p, n)
    k : array_like, shape (m, n)
        ``u = −k x``, A − BK Hurwitz.

    Returns
    -------
    ndarray, shape (m, p)
        ``pinv(C (BK − A)⁻¹ B)``.

    Notes
    -----
    Eq. (17) inverts C(BK − A)⁻¹B, the DC gain from a constant input offset to y. Here there
    are more inputs than independent outputs (and the pair outputs are redundant), so the
    inverse does not exist: the pseudo-inverse gives the minimum-norm feed-forward, which
    reaches every y_d in the range of C exactly. In the observable coordinates B_o annihilates
    the common-mode force, so that force lies in the kernel of the DC gain and the minimum-norm
    feed-forward contains none.
    """
    a, b, c, k = (finite_matrix(name, v) for name, v in (("a", a), ("b", b), ("c", c), ("k", k)))
    dc = c @ np.linalg.solve(b @ k - a, b)
    return np.linalg.pinv(dc)


def bryson_weights(x_max, u_max, n_x=None, n_u=None):
    """Bryson's rule: diagonal weights 1/x_max², 1/u_max².

    Parameters
    ----------
    x_max : float or array_like, shape (n_x,)
        Largest acceptable value of each state (its unit).
    u_max : float or array_like, shape (n_u,)
        Largest acceptable value of each input (its unit).
    n_x, n_u : int, optional
        Lengths to broadcast scalars (or shorter broadcastable arrays) to.

    Returns
    -------
    q : ndarray, shape (n_x, n_x)
    r : ndarray, shape (n_u, n_u)
    """

    def weights(name, value, size):
        v = np.atleast_1d(np.asarray(value, dtype=float))
        if size is not None:
            v = np.broadcast_to(v, (size,))
        if v.ndim != 1 or not np.all(np.isfinite(v)) or np.any(v <= 0.0):
            raise ValueError(f"{name} must be finite and > 0, got {value!r}")
        return np.diag(1.0 / v**2)

    return weights("x_max", x_max, n_x), weights("u_max", u_max, n_u)
