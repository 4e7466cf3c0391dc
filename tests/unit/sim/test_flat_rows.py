"""A batch's flat RK4 rows (sim/layout._flat_rows, _flat_plant): the same values as the
batch-inner layout, the chief gathered per run."""

import jax.numpy as jnp
import numpy as np

from coopsat.dynamics.plant import PlantParams, _chief
from coopsat.sim.layout import _flat_plant, _flat_rows


def test_flat_rows_round_trip_and_pass_scalars():
    flat, unflat = _flat_rows((4, 3))
    a = jnp.arange(2 * 4 * 3.0).reshape(2, 4, 3)
    assert flat(a).shape == (2, 12)
    np.testing.assert_array_equal(unflat(flat(a)), a)
    assert flat(jnp.float64(2.0)).shape == () and unflat(jnp.float64(2.0)).shape == ()


def test_flat_plant_chief_gathers_each_runs_chief():
    b, n = 4, 3
    rng = np.random.default_rng(0)
    r = jnp.asarray(rng.normal(size=(3, b, n)))
    chief = jnp.asarray([[0], [2], [1], [2]])
    mu = jnp.asarray(rng.uniform(1, 2, size=(b, 1)))
    plant = PlantParams(jnp.ones((3, b, n)), jnp.ones((3, b, n)), mu, mu, mu, jnp.ones((b, n)), chief)
    flat, unflat = _flat_rows((b, n))
    fp = _flat_plant(plant, (b, n))
    inner = _chief(r, chief, 0)  # (3, B, 1)
    np.testing.assert_array_equal(unflat(_chief(flat(r), fp.chief, 0)), jnp.broadcast_to(inner, (3, b, n)))
    np.testing.assert_array_equal(unflat(fp.mu_m3_s2), jnp.broadcast_to(mu, (b, n)))
    assert fp.inertia_kgm2.shape == (3, b * n) and fp.mass_kg.shape == (b * n,)
