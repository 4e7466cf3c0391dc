"""Deep-space flight software (SPEC §4): the relay rebuild, the relative-position sensor, and
that a spacecraft's computer never reads a measurement it could not have."""

import jax
import jax.numpy as jnp
import numpy as np

from coopsat.control.formation import LinearFormationSoftware, fill_blocked
from coopsat.network.delivery import Inbox
from coopsat.sensors.parts import RelativePosition, relative_positions
from coopsat.sim.flight_software import as_flight_software

N, D = 4, 2


def _rows(r):
    """(4, n, n) readings with every line of sight open."""
    return np.concatenate([np.asarray(relative_positions(jnp.asarray(r))), np.ones((1, N, N))])


def test_relative_positions_are_target_minus_observer():
    r = np.random.default_rng(0).normal(size=(3, N))
    rho = np.asarray(relative_positions(jnp.asarray(r)))
    for i in range(N):
        for j in range(N):
            np.testing.assert_array_equal(rho[:, j, i], r[:, j] - r[:, i])


def test_relay_rebuilds_a_blocked_line_exactly():
    r = np.random.default_rng(1).normal(size=(3, N)) * 100.0
    rows = _rows(r)
    own = rows[:, :, 0].copy()
    own[:3, 2], own[3, 2] = 0.0, 0.0  # 0 cannot see 2
    others = rows[:, :, 1:]  # rows of 1, 2, 3 (k sees j)
    filled, relayed = fill_blocked(jnp.asarray(own), jnp.asarray(others), jnp.asarray([1, 2, 3]), jnp.ones(3))
    np.testing.assert_allclose(np.asarray(filled)[:3, 2], r[:, 2] - r[:, 0], rtol=1e-12)
    assert float(filled[3, 2]) == 1.0
    np.testing.assert_array_equal(np.asarray(relayed), [0, 0, 1, 0])


def test_no_relay_without_a_live_link():
    r = np.random.default_rng(2).normal(size=(3, N))
    rows = _rows(r)
    own = rows[:, :, 0].copy()
    own[:, 2] = 0.0
    filled, relayed = fill_blocked(jnp.asarray(own), jnp.asarray(rows[:, :, 1:]), jnp.asarray([1, 2, 3]), jnp.zeros(3))
    assert float(filled[3, 2]) == 0.0 and float(jnp.sum(relayed)) == 0.0


def test_sensor_blocks_both_directions_in_its_window_and_keeps_self_exact():
    part = RelativePosition(
        jnp.full(3, 0.5), jnp.asarray([[0, 2]], dtype=jnp.int32), jnp.asarray([[10.0, 20.0]]), jnp.asarray(10.0),
        names=("a", "b", "c", "d"),
    )
    r = np.random.default_rng(3).normal(size=(3, N))
    truth = np.concatenate([np.asarray(relative_positions(jnp.asarray(r))), np.ones((1, N, N))])
    key = jax.random.PRNGKey(0)
    before, t1 = part.measure(jnp.asarray(truth), None, jnp.asarray(0.0), key)
    inside, _ = part.measure(jnp.asarray(truth), None, jnp.asarray(10.0), key)
    after, _ = part.measure(jnp.asarray(truth), None, jnp.asarray(20.0), key)
    assert float(t1) == 10.0
    assert float(before[3, 2, 0]) == 1.0 and float(after[3, 0, 2]) == 1.0
    assert float(inside[3, 2, 0]) == 0.0 and float(inside[3, 0, 2]) == 0.0
    np.testing.assert_array_equal(np.asarray(inside[:3, 2, 0]), 0.0)
    assert float(np.asarray(inside[3]).sum()) == N * N - 2
    for i in range(N):  # a spacecraft sees itself exactly
        np.testing.assert_array_equal(np.asarray(before[:3, i, i]), 0.0)
    noise = np.asarray(before[:3]) - truth[:3]
    assert np.all(np.abs(noise[:, ~np.eye(N, dtype=bool)]) > 0)


def _software(source, rng):
    ny, nz, nu = (N - 1) * D, 2 * (N - 1) * D + 2 * D, N * D
    basis = np.hstack([-np.ones((N - 1, 1)), np.eye(N - 1)])  # hub coordinates, hub 0
    arrays = dict(
        phi=rng.normal(size=(nz, nz)) * 0.1, gamma_y=rng.normal(size=(nz, ny)), gamma_u=rng.normal(size=(nz, nu)),
        c_u=rng.normal(size=(nu, nz)), u_ff=rng.normal(size=nu), c_y=rng.normal(size=(ny, nz)),
        y_map=np.kron(basis, np.eye(D)), z0_map=rng.normal(size=(nz, ny)), force_min_n=0.0, force_max_n=1e6,
        source=np.asarray(source),
    )
    return LinearFormationSoftware(**{k: jnp.asarray(v) for k, v in arrays.items()}, axes=(0, 1))


def _complete_inbox(outbox, weight=None):
    src = np.array([j for i in range(N) for j in range(N) if j != i])
    dst = np.array([i for i in range(N) for j in range(N) if j != i])
    msg = jax.tree_util.tree_map(lambda a: jnp.take(a, jnp.asarray(src), axis=-1), outbox)
    w = jnp.ones(len(src)) if weight is None else weight
    return Inbox(msg, w, jnp.asarray(dst), {}), src, dst


def _commands(sw, rho, state, inbox_fn):
    fs = as_flight_software(sw, N)
    y = {"rho": rho, "omega": jnp.zeros((3, N))}
    outbox = fs.outbox(y, state)
    inbox = inbox_fn(outbox)
    cmd, _, _ = fs.step(0.0, y, inbox, state, jax.random.PRNGKey(0))
    return cmd["force_eci"]


def test_decentralized_command_depends_only_on_own_row_when_nothing_is_blocked():
    rng = np.random.default_rng(4)
    sw = _software(np.arange(N), rng)
    # First period: the estimate starts from the measurement, so the command depends on it.
    state = {"z": jnp.zeros((sw.phi.shape[0], N)), "started": jnp.zeros(N)}
    rho = jnp.asarray(_rows(rng.normal(size=(3, N)) * 100.0))
    jac = jax.jacobian(lambda rr: _commands(sw, rr, state, lambda o: _complete_inbox(o)[0]))(rho)  # (3, n, 4, n, n)
    for i in range(N):
        for k in range(N):
            block = np.asarray(jac[:, i, :, :, k])
            if k == i:
                assert np.abs(block).max() > 0  # its own measurements matter
            else:
                np.testing.assert_array_equal(block, 0.0)  # another's row never reaches it


def test_messages_not_addressed_to_a_spacecraft_never_reach_it():
    rng = np.random.default_rng(5)
    sw = _software(np.zeros(N, dtype=int), rng)  # centralized: everyone uses the hub's row
    state = {"z": jnp.zeros((sw.phi.shape[0], N)), "started": jnp.zeros(N)}
    rho = jnp.asarray(_rows(rng.normal(size=(3, N)) * 100.0))

    def with_msg(delta):
        def inbox_fn(outbox):
            inbox, src, dst = _complete_inbox(outbox)
            # move target 1's vector in every message on links that end at spacecraft 2 (a common
            # shift of a whole row would not show: the coordinates are translation-invariant)
            bump = jnp.zeros((4, N, 1)).at[:3, 1].set(delta)
            mask = jnp.asarray(dst == 2, dtype=float)
            return inbox._replace(msg={**inbox.msg, "rho": inbox.msg["rho"] + bump * mask})
        return _commands(sw, rho, state, inbox_fn)

    base, moved = np.asarray(with_msg(0.0)), np.asarray(with_msg(1.0))
    changed = np.abs(moved - base).max(axis=0) > 0
    np.testing.assert_array_equal(changed, [False, False, True, False])


def test_centralized_spacecraft_use_the_hubs_row_and_agree():
    rng = np.random.default_rng(6)
    sw = _software(np.zeros(N, dtype=int), rng)
    z = rng.normal(size=(sw.phi.shape[0], 1))
    state = {"z": jnp.asarray(np.repeat(z, N, axis=1)), "started": jnp.ones(N)}
    r = rng.normal(size=(3, N)) * 100.0
    rows = _rows(r)
    rows[:3] += rng.normal(size=(3, N, N)) * 1e-3  # each spacecraft's own noisy view
    cmd = np.asarray(_commands(sw, jnp.asarray(rows), state, lambda o: _complete_inbox(o)[0]))
    # Every spacecraft computed the hub's formation command: rebuild it from the hub's row.
    vec = rows[:2, :, 0].T.reshape(-1)
    y = np.asarray(sw.y_map) @ vec
    u = np.asarray(sw.c_u) @ z[:, 0] + np.asarray(sw.u_ff)
    np.testing.assert_allclose(cmd[:2], u.reshape(N, D).T, rtol=1e-10)
    assert y.shape == ((N - 1) * D,)
