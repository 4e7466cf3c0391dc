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

from coopsat.analysis.papers import paper_modules

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
        ``(samples, t_s, built) -> scalar``; minimised in place of the metric. ``samples``
        are :func:`coopsat.sim.engine.run_samples`'s (JAX arrays), ``t_s`` the sample times.
    constraint : callable or None
        ``(samples, t_s, built, bound) -> scalar``, ≤ 0 where ``metric ≤ bound`` (dimensionless).
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
        out.update(getattr(module, "SURROGATES", {}))
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
