"""The leader–follower law's per-spacecraft form (what software in the loop runs in each flight
software process) against its formation-wide step (what the compiled loop runs), both
protocols, on random messages over an edge list and over a padded in-neighbour table."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from coopsat.control.leader_follower import LeaderFollower
from coopsat.network.delivery import Inbox
from coopsat.sim.flight_software import as_flight_software
from coopsat.sim.system import as_arrays
from per_spacecraft import OneByOne


def _inbox(rng, dst, n):
    """Random messages, receivers' own past outboxes and weights (some zero) on links ``dst``."""
    shape = dst.shape
    weight = rng.uniform(0.2, 1.5, shape) * (rng.uniform(size=shape) > 0.2)
    msg = {k: jnp.asarray(rng.normal(size=(3, *shape))) for k in ("angle", "omega")}
    own = {k: jnp.asarray(rng.normal(size=(3, *shape))) for k in ("angle", "omega")}
    return Inbox(msg, jnp.asarray(weight), jnp.asarray(dst), own)


def _links(layout, n, rng):
    if layout == "edges":  # receivers sorted, 1 to 3 links each (the leader none)
        return np.repeat(np.arange(n), [0] + list(rng.integers(1, 4, n - 1)))
    return np.tile(np.arange(n), (2, 1))  # padded table, two rows: column i is receiver i


@pytest.mark.parametrize("protocol", ["law3", "classical"])
@pytest.mark.parametrize("layout", ["edges", "padded"])
def test_per_spacecraft_form_equals_the_formation_step(protocol, layout):
    n = 5
    rng = np.random.default_rng(7)
    follower = np.ones(n)
    follower[0] = 0.0
    law = LeaderFollower(*as_arrays((np.array([0.454606, 1.35789]), follower)), protocol=protocol)
    assert law.reads_own == (protocol == "classical")
    key = jax.random.PRNGKey(0)
    for trial in range(5):
        y = {k: jnp.asarray(rng.normal(size=(3, n))) for k in ("angle", "omega")}
        inbox = _inbox(rng, _links(layout, n, rng), n)
        whole = law.step(0.7, y, inbox, (), key)
        one = as_flight_software(OneByOne(law), n)
        split = one.step(0.7, y, inbox, (), key)
        u_whole, u_split = np.asarray(whole[0]["torque_b"]), np.asarray(split[0]["torque_b"])
        assert u_split.shape == (3, n)
        # the same terms summed in another order (segment sum or a table row): to rounding
        np.testing.assert_allclose(u_split, u_whole, rtol=0, atol=1e-14 * np.abs(u_whole).max())
        np.testing.assert_array_equal(u_split[:, 0], 0.0)  # the leader commands nothing
        np.testing.assert_array_equal(np.asarray(split[2]["torque_command"]), u_split)
        out_whole, out_split = law.outbox(y, ()), one.outbox(y, ())
        for k in ("angle", "omega"):
            np.testing.assert_array_equal(np.asarray(out_split[k]), np.asarray(out_whole[k]))


def test_two_links_are_bit_for_bit():
    """At most two links of nonzero weight into each follower (delay-designed's graph): adding
    the zeroed links is exact, so the per-spacecraft form is the formation step's bits."""
    n, rng = 3, np.random.default_rng(1)
    law = LeaderFollower(*as_arrays((np.array([1.0, 2.0]), np.array([0.0, 1.0, 1.0]))), protocol="law3")
    dst = np.array([1, 1, 2, 2])
    y = {k: jnp.asarray(rng.normal(size=(3, n))) for k in ("angle", "omega")}
    inbox = _inbox(rng, dst, n)._replace(weight=jnp.asarray(rng.uniform(0.5, 1.0, 4)))
    key = jax.random.PRNGKey(0)
    whole = law.step(0.0, y, inbox, (), key)[0]["torque_b"]
    split = as_flight_software(OneByOne(law), n).step(0.0, y, inbox, (), key)[0]["torque_b"]
    np.testing.assert_array_equal(np.asarray(split), np.asarray(whole))
