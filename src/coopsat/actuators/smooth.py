"""Smooth stand-ins for actuator nonlinearities, for gradients only (``coopsat tune``).

A saturation or dead zone has zero derivative where it clips or cuts, so a gradient through
the closed loop cannot see that a larger gain would saturate less, or that a command inside
the dead zone could grow to fire. The tuner optimises on these smooth surrogates and then
re-runs the exact loop; both figures are reported (docs/tuning.md).
"""


import jax
import jax.numpy as jnp


def soft_clip(x, limit, width):
    """``clip(x, −limit, limit)`` with corners rounded over ``width``; any shape.

    Notes
    -----
    ``x − w·softplus((x − L)/w) + w·softplus((−x − L)/w)``: equal to the clip to within
    ``w·ln 2`` at the corners and exponentially close away from them; its slope goes
    smoothly from 1 to 0 over a few ``width`` around ``±limit``. ``limit = inf`` gives ``x``.
    """
    finite = jnp.isfinite(limit)
    # Safe stand-ins on the unused side of the where: a NaN there would reach the gradient.
    lim = jnp.where(finite, limit, 0.0)
    w = jnp.where(finite, width, 1.0)
    sp = jax.nn.softplus
    return jnp.where(finite, x - w * sp((x - lim) / w) + w * sp((-x - lim) / w), x)


def soft_deadzone(x, threshold, width):
    """``x`` where ``|x| ≥ threshold``, 0 below, with the step smoothed over ``width``.

    Notes
    -----
    ``x·σ((|x| − threshold)/width)`` (σ the logistic function): the exact dead zone's
    output to within ``x·e^{−(|x|−threshold)/width}`` away from the threshold, with a slope
    everywhere, so a gradient sees a command grow towards firing. ``threshold = 0`` (no
    dead zone) gives ``x`` exactly.
    """
    safe = jnp.where(threshold > 0.0, width, 1.0)
    return jnp.where(threshold > 0.0, x * jax.nn.sigmoid((jnp.abs(x) - threshold) / safe), x)
