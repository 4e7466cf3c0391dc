"""A box-bounded global-best particle swarm optimiser that runs inside the compiled loop.

SPEC §2 re-allocates the cartwheel's free phase ψ on board with PSO, the cost being the total
impulse the deputies need. The closed loop is one jitted ``lax.scan``, so the optimiser must be
pure JAX with a fixed amount of work: a fixed swarm size and iteration count, randomness only
from an explicit ``jax.random`` key. :func:`grid_minimize` is the exhaustive check used to
validate it on one or two variables.
"""


import jax
import jax.numpy as jnp


def _as_box(lo, hi):
    """Bounds as two float arrays of shape (d,)."""
    lo = jnp.atleast_1d(jnp.asarray(lo, dtype=float))
    hi = jnp.atleast_1d(jnp.asarray(hi, dtype=float))
    return jnp.broadcast_arrays(lo, hi)


def _nan_to_inf(f):
    """A NaN cost never compares below anything, so it would pin a personal best forever: treat
    it as infinitely bad instead (a near-singular transfer, say, evaluated in the loop)."""
    return jnp.where(jnp.isnan(f), jnp.inf, f)


def pso_minimize(
    cost, lo, hi, key, particles=16, iterations=40, inertia=0.7298, cognitive=1.49618, social=1.49618
):
    """Minimise ``cost`` over the box ``[lo, hi]`` with a global-best particle swarm.

    Parameters
    ----------
    cost : callable
        ``(P, d) -> (P,)``: the cost of each particle's position; pure and traceable. It may
        close over traced data (the loop's state), so the optimiser can be ``vmap``-ped over it.
    lo, hi : float or array_like (d,)
        Box bounds, ``lo < hi``; the problem's dimension d is their length (scalars: d = 1).
    key : jax.Array
        PRNG key; the result is a deterministic function of it.
    particles : int
        Swarm size P (static).
    iterations : int
        Number of velocity-and-position updates after the initial swarm (static).
    inertia, cognitive, social : float
        Inertia weight w and the acceleration coefficients c1 (towards each particle's own
        best) and c2 (towards the swarm's best).

    Returns
    -------
    x_best : jax.Array (d,)
        Best position found, including the initial swarm.
    f_best : jax.Array ()
        Its cost (``inf`` if every evaluation was ``nan`` or ``inf``).

    Notes
    -----
    Kennedy & Eberhart (1995) with the inertia weight of Shi & Eberhart (1998), updated
    synchronously: ``v ← w v + c1 r1 (p − x) + c2 r2 (g − x)``, ``x ← x + v`` with
    ``r1, r2 ~ U(0, 1)`` drawn per particle and dimension. The defaults ``w = 0.7298``,
    ``c1 = c2 = 1.49618`` are the inertia form of Clerc & Kennedy's (2002) constriction
    (χ = 0.7298, φ = 4.1), which converges without velocity clamping; the velocity is still
    clipped to the box width per dimension so no step can jump clean across the box, and the
    position is clipped to the box. Positions start uniform in the box and velocities at zero
    (Engelbrecht, "Particle swarm optimization: velocity initialization", IEEE CEC 2012:
    random initial velocities send more particles out of the search space, and zero ones
    search as well or better).

    Work is fixed: ``particles · (iterations + 1)`` cost evaluations, in ``iterations + 1``
    batched calls, under ``lax.fori_loop``.
    """
    lo, hi = _as_box(lo, hi)
    width = hi - lo
    shape = (particles, lo.shape[-1])
    key_init, key_loop = jax.random.split(key)
    x = lo + width * jax.random.uniform(key_init, shape)
    f = _nan_to_inf(cost(x))

    def step(i, swarm):
        x, v, p, f_p = swarm
        g = p[jnp.argmin(f_p)]
        r1, r2 = jax.random.uniform(jax.random.fold_in(key_loop, i), (2,) + shape)
        v = jnp.clip(inertia * v + cognitive * r1 * (p - x) + social * r2 * (g - x), -width, width)
        x = jnp.clip(x + v, lo, hi)
        f = _nan_to_inf(cost(x))
        better = f < f_p
        return x, v, jnp.where(better[:, None], x, p), jnp.where(better, f, f_p)

    _, _, p, f_p = jax.lax.fori_loop(0, iterations, step, (x, jnp.zeros(shape), x, f))
    best = jnp.argmin(f_p)
    return p[best], f_p[best]


def grid_minimize(cost, lo, hi, points):
    """Minimise ``cost`` over a uniform grid on the box ``[lo, hi]``, both ends included.

    Parameters
    ----------
    cost : callable
        ``(G, d) -> (G,)``, as for :func:`pso_minimize`.
    lo, hi : float or array_like (d,)
        Box bounds.
    points : int
        Grid points per dimension (static); ``points**d`` evaluations in one call, so meant
        for d = 1 or 2.

    Returns
    -------
    x_best : jax.Array (d,)
        Best grid point (the first, in C order, on a tie).
    f_best : jax.Array ()
    """
    lo, hi = _as_box(lo, hi)
    axes = [jnp.linspace(lo[k], hi[k], points) for k in range(lo.shape[-1])]
    x = jnp.stack(jnp.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(axes))
    f = _nan_to_inf(cost(x))
    best = jnp.argmin(f)
    return x[best], f[best]
