"""The in-loop JAX particle swarm against a fine grid and against pymoo's PSO."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from coopsat.control.pso import grid_minimize, pso_minimize

GRID = 20001
SWARM = dict(particles=32, iterations=150)

_rng = np.random.default_rng(0)
_A, _B, _C = _rng.uniform(0.5, 2.0, 5), _rng.uniform(-3.0, 3.0, 5), _rng.uniform(-1.0, 1.0, 5)


def rastrigin(x):
    """Shifted 1-D Rastrigin: ten local minima in the box, the global one (0) at 1.2345678."""
    z = x[..., 0] - 1.2345678
    return 10.0 + z**2 - 10.0 * jnp.cos(2 * np.pi * z)


def kinked(x):
    """``Σ_k |a_k sin(ψ + b_k) + c_k|``: smooth pieces joined at kinks, like an L1 impulse."""
    return jnp.sum(jnp.abs(_A * jnp.sin(x + _B) + _C), axis=-1)


# (cost, lo, hi, scale of its values)
PROBLEMS = {
    "rastrigin": (rastrigin, -5.12, 5.12, 10.0),
    "kinked": (kinked, -np.pi, np.pi, float(_A.sum())),
}


def _pymoo_pso(cost, lo, hi, seed):
    from pymoo.algorithms.soo.nonconvex.pso import PSO
    from pymoo.core.problem import Problem
    from pymoo.optimize import minimize

    class Wrapped(Problem):
        def __init__(self):
            super().__init__(n_var=1, n_obj=1, xl=lo, xu=hi)

        def _evaluate(self, x, out, *args, **kwargs):
            out["F"] = np.asarray(cost(jnp.asarray(x)))

    res = minimize(Wrapped(), PSO(pop_size=32), ("n_gen", 200), seed=seed, verbose=False)
    return np.atleast_1d(res.X), float(np.squeeze(res.F))


def test_grid_includes_both_ends_and_works_in_two_dimensions():
    x, f = grid_minimize(lambda x: x[:, 0], -2.0, 3.0, 11)
    assert float(x[0]) == -2.0 and float(f) == -2.0
    x, f = grid_minimize(lambda x: -x[:, 0], -2.0, 3.0, 11)
    assert float(x[0]) == 3.0
    x, f = grid_minimize(lambda x: (x[:, 0] - 0.5) ** 2 + (x[:, 1] + 0.25) ** 2, [-1.0, -1.0], [1.0, 1.0], 9)
    np.testing.assert_array_equal(np.asarray(x), [0.5, -0.25])


@pytest.mark.parametrize("name", PROBLEMS)
def test_pso_reaches_the_fine_grid_minimum_for_every_key(name):
    cost, lo, hi, scale = PROBLEMS[name]
    x_grid, f_grid = grid_minimize(cost, lo, hi, GRID)
    keys = jax.random.split(jax.random.key(7), 16)
    x, f = jax.vmap(lambda k: pso_minimize(cost, lo, hi, k, **SWARM))(keys)
    assert x.shape == (16, 1) and f.shape == (16,)
    assert np.all(np.asarray(f) <= float(f_grid) + 1e-9 * scale)
    # Same basin as the grid's best (within one grid spacing).
    assert np.abs(np.asarray(x[:, 0]) - float(x_grid[0])).max() <= (hi - lo) / (GRID - 1)
    # The reported cost is the cost of the reported point.
    np.testing.assert_allclose(np.asarray(cost(x)), np.asarray(f), rtol=1e-15)


@pytest.mark.parametrize("name", PROBLEMS)
@pytest.mark.parametrize("seed", [1, 2])
def test_pso_agrees_with_pymoo(name, seed):
    cost, lo, hi, scale = PROBLEMS[name]
    x_ref, f_ref = _pymoo_pso(cost, lo, hi, seed)
    x, f = pso_minimize(cost, lo, hi, jax.random.key(seed), **SWARM)
    assert abs(float(f) - f_ref) <= 1e-8 * scale
    np.testing.assert_allclose(np.asarray(x), x_ref, rtol=0, atol=1e-6)


def test_same_key_same_bits_different_keys_different_swarms_both_correct():
    cost, lo, hi, scale = PROBLEMS["kinked"]
    _, f_grid = grid_minimize(cost, lo, hi, GRID)
    a = pso_minimize(cost, lo, hi, jax.random.key(3), **SWARM)
    b = pso_minimize(cost, lo, hi, jax.random.key(3), **SWARM)
    c = pso_minimize(cost, lo, hi, jax.random.key(4), **SWARM)
    for u, v in zip(a, b):
        np.testing.assert_array_equal(np.asarray(u), np.asarray(v))
    assert float(a[0][0]) != float(c[0][0])  # different swarms (a different last bit suffices)
    for r in (a, c):
        assert float(r[1]) <= float(f_grid) + 1e-9 * scale
    # No iterations: the best of the initial swarm, which also differs with the key.
    s3 = pso_minimize(cost, lo, hi, jax.random.key(3), particles=8, iterations=0)
    s4 = pso_minimize(cost, lo, hi, jax.random.key(4), particles=8, iterations=0)
    assert float(s3[0][0]) != float(s4[0][0])


def test_jit_and_vmap_over_keys_and_over_closed_over_data():
    keys = jax.random.split(jax.random.key(11), 4)
    shifts = jnp.array([-0.3, 0.1, 0.45, 0.9])

    def solve(key, shift):
        def cost(x):
            return jnp.abs(x[:, 0] - shift) + 0.1 * (x[:, 0] - shift) ** 2

        return pso_minimize(cost, -1.0, 1.0, key, **SWARM)

    x, f = jax.jit(jax.vmap(solve))(keys, shifts)
    np.testing.assert_allclose(np.asarray(x[:, 0]), np.asarray(shifts), rtol=0, atol=1e-9)
    assert np.asarray(f).max() <= 1e-9
    one = jax.jit(solve)(keys[2], shifts[2])
    np.testing.assert_allclose(np.asarray(one[0]), np.asarray(x[2]), rtol=0, atol=1e-15)


def test_two_dimensional_bowl_is_solved_to_1e_8():
    centre, weight = jnp.array([0.3, -0.7]), jnp.array([1.0, 10.0])
    x, f = pso_minimize(
        lambda x: jnp.sum(weight * (x - centre) ** 2, axis=-1),
        -jnp.ones(2),
        jnp.ones(2),
        jax.random.key(0),
        particles=16,
        iterations=200,
    )
    assert x.shape == (2,)
    np.testing.assert_allclose(np.asarray(x), np.asarray(centre), rtol=0, atol=1e-8)
    assert float(f) < 1e-15


def test_bounds_hold_and_nan_costs_are_never_chosen():
    # Minimum on the boundary: the clipped swarm reaches it exactly and never leaves the box.
    x, f = pso_minimize(lambda x: x[:, 0], 0.25, 2.0, jax.random.key(5))
    assert float(x[0]) == 0.25
    # A cost undefined on part of the box (a singular transfer, say) is treated as infinite.
    def partly_undefined(x):
        return jnp.where(x[:, 0] < 0.0, jnp.nan, (x[:, 0] - 0.5) ** 2)

    x, f = pso_minimize(partly_undefined, -1.0, 1.0, jax.random.key(5))
    assert np.isfinite(float(f)) and abs(float(x[0]) - 0.5) < 1e-4
