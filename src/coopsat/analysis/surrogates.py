"""Differentiable stand-ins for run metrics, for ``coopsat tune``.

A metric such as a settling time is a threshold crossing: piecewise constant in the gains, so
its gradient is zero or undefined. For each metric a paper module can tune on, it gives a
:class:`Surrogate` (in its ``SURROGATES``): a smooth function of the run's samples (JAX) that
goes down when the metric goes down (``objective``), and a smooth function that is ≤ 0 when
``metric ≤ bound`` holds, or nearly (``constraint``). The tuner optimises the surrogates and
then re-runs the exact loop, so the figures it reports are the metric's, never the
surrogate's (docs/tuning.md).
"""

from dataclasses import dataclass

import numpy as np

from coopsat.analysis.papers import member, paper_modules

SMOOTH_MAX_TEMPERATURE = 0.02
"""Temperature of :func:`smooth_max` in units of the tolerance: the log-sum-exp exceeds the
true maximum by at most ``0.02·log(N)`` tolerances (N samples), so a constraint built on it
is slightly conservative (the exact loop settles a little before the bound)."""


@dataclass(frozen=True)
class Surrogate:
    """A metric's smooth stand-ins.

    Attributes
    ----------
    objective : callable or None
        ``(samples, t_s, built, system) -> scalar``; minimised in place of the metric.
        ``samples`` are :func:`coopsat.sim.engine.run_samples`'s (JAX arrays), ``t_s`` the
        sample times, ``system`` the tuned System (traced: a design metric such as a
        closed-loop spectral radius is a function of its parts).
    constraint : callable or None
        ``(samples, t_s, built, system, bound) -> scalar``, ≤ 0 where ``metric ≤ bound``
        (dimensionless).
    what : str
        One line: what the surrogate is (printed by the tuner and written in its report).
    exact_in_metric_units : bool
        The objective is the metric itself, evaluated on the smoothed loop (so the gap between
        the two is a number in the metric's units).
    """

    objective: object
    constraint: object
    what: str
    exact_in_metric_units: bool = False


def surrogates(built):
    """Every surrogate the paper modules of a built run offer, by metric name."""
    out = {}
    for module in paper_modules(built):
        out.update(member(module, "SURROGATES"))
    return out


def smooth_max(x, temperature):
    """``τ·log Σ exp(x/τ)``: a smooth upper bound of ``max(x)`` (exceeds it by ≤ τ·log N)."""
    import jax.scipy.special as jss

    return temperature * jss.logsumexp(x / temperature)


def settled_by(t_s, error, bound_s):
    """Constraint ``settling time ≤ bound_s`` on a normalised error (1 = the tolerance).

    Parameters
    ----------
    t_s : (T,)
        Sample times, s.
    error : (T,) JAX array
        The error divided by its tolerance.
    bound_s : float
        The settling time asked for, s.

    Returns
    -------
    scalar
        ``smooth_max(error over t ≥ bound_s) − 1`` (≤ 0: every late sample inside tolerance,
        with a margin of ``τ·log N``); ``+1`` when no sample lies at or after ``bound_s``.
    """
    import jax.numpy as jnp

    late = np.asarray(t_s) >= bound_s
    if not late.any():
        return jnp.asarray(1.0)
    return smooth_max(error[np.flatnonzero(late)], SMOOTH_MAX_TEMPERATURE) - 1.0


def time_weighted_error(t_s, error):
    """``∫ t·e(t) dt / ∫ t dt`` (trapezoid over the samples): the ITAE criterion, normalised
    so that a constant error gives itself. Small when the error dies early."""
    import jax.numpy as jnp

    t = jnp.asarray(t_s)
    w = t * error
    num = jnp.sum(0.5 * (w[1:] + w[:-1]) * jnp.diff(t))
    return num / (0.5 * (t[-1] ** 2 - t[0] ** 2))


GELFAND_SQUARINGS = 14
"""Squarings in :func:`spectral_radius_bound`: ``‖M^k‖^{1/k}`` with ``k = 2^14``."""


def spectral_radius_bound(m):
    """Gelfand's ``‖M^k‖_F^{1/k}`` with ``k = 2^14``: a smooth upper bound of the spectral radius.

    Unlike the largest ``|eig|``, it has a gradient where eigenvalues repeat (every coordinate
    of a formation has the same poles), which is where the eigenvalue's derivative is not
    defined. It exceeds ρ by a factor ``(C k^p)^{1/k}`` (C the conditioning of the
    eigenvectors, p the largest Jordan block less one): about 0.1 % for the formation's
    36 × 36 loop. Squared with a renormalisation at every step, so it neither overflows nor
    underflows.
    """
    import jax.numpy as jnp

    log_rho = 0.0
    a = m
    for j in range(GELFAND_SQUARINGS + 1):
        s = jnp.sqrt(jnp.sum(a**2))
        # A power that vanishes (a nilpotent M, ρ = 0): log 0 = −∞ gives 0, not 0/0 = NaN.
        nonzero = s > 0.0
        s = jnp.where(nonzero, s, 1.0)
        log_rho = log_rho + jnp.where(nonzero, jnp.log(s), -jnp.inf) / 2.0**j
        b = a / s
        a = b @ b
    return jnp.exp(log_rho)
