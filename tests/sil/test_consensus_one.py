"""The consensus law's per-spacecraft form (what software in the loop runs in each flight
software process) against its formation-wide step (what the compiled loop runs)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from coopsat.control.consensus import ConsensusLaw
from coopsat.network import topology
from coopsat.network.delivery import IdealNetwork
from coopsat.sim.flight_software import as_flight_software
from coopsat.sim.system import as_arrays
from per_spacecraft import OneByOne


def _law(track, short_way):
    return ConsensusLaw(*as_arrays((1.0, 2.0, 90.0, 80.0, np.array([0.6, 0.0, 0.8, 0.0]), np.array([0.0, 0.1, 0.0]))), track, short_way)


def _measurements(n, seed):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(4, n))
    return {"q": jnp.asarray(q / np.linalg.norm(q, axis=0)), "omega": jnp.asarray(rng.normal(size=(3, n)))}


@pytest.mark.parametrize("track", [False, True])
@pytest.mark.parametrize("graph, exact", [("ring", True), ("complete", False)])
def test_per_spacecraft_form_equals_the_formation_step(track, graph, exact):
    n = 6
    adjacency = topology.ring_adjacency(n) if graph == "ring" else topology.complete_adjacency(n)
    links = topology.links_for_schedule([adjacency * np.linspace(0.5, 1.5, n)[:, None]], layout="edges")
    network = IdealNetwork(*as_arrays((links.src, links.dst, links.weight, np.zeros(1, int))))
    law = _law(track, short_way=track)
    y = _measurements(n, seed=3)
    key = jax.random.PRNGKey(0)
    whole = law.step(0.7, y, network.deliver(0, law.outbox(y, ()), (), key)[0], (), key)
    one = as_flight_software(OneByOne(law), n)
    split = one.step(0.7, y, network.deliver(0, one.outbox(y, ()), (), key)[0], (), key)
    u_whole, u_split = np.asarray(whole[0]["torque_b"]), np.asarray(split[0]["torque_b"])
    if exact:  # two links per receiver: the same sum whatever its order
        np.testing.assert_array_equal(u_split, u_whole)
    else:
        np.testing.assert_allclose(u_split, u_whole, rtol=0, atol=1e-14 * np.abs(u_whole).max())
    np.testing.assert_array_equal(np.asarray(split[2]["torque_command"]), u_split)
    if track:
        np.testing.assert_array_equal(np.asarray(split[2]["q_ref"])[:, 0], np.asarray(whole[2]["q_ref"]))
