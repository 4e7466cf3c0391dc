"""Laws (3) and (4): written-out cases, layouts, and link representations agree."""

import numpy as np
import pytest

from coopsat.control.consensus import consensus_sync_torque, consensus_track_torque, reference_attitude
from coopsat.geometry.quaternion import quat_from_axis_angle, quat_multiply
from coopsat.network.topology import complete_adjacency, links_from_adjacency, ring_adjacency


def _random_state(n, seed=0):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True), rng.normal(size=(n, 3))


def _law_by_hand(q, w, a, alpha, beta):
    """Eq. (3) with the error quaternion's vector part written out (q_j* ⊗ q_i)."""
    u = np.zeros((len(q), 3))
    for i in range(len(q)):
        for j in range(len(q)):
            if a[i, j]:
                qi, qj = q[i], q[j]
                vec = qj[0] * qi[1:] - qi[0] * qj[1:] - np.cross(qj[1:], qi[1:])
                u[i] -= a[i, j] * (alpha * vec + beta * (w[i] - w[j]))
    return u


@pytest.mark.parametrize("layout", ["edges", "padded"])
@pytest.mark.parametrize("axis", [-1, 0])
def test_sync_law_matches_hand_computation(layout, axis):
    q, w = _random_state(5)
    a = ring_adjacency(5) * np.array([1, 1, 0.5, 1, 0.5])[:, None]  # some asymmetric weights
    links = links_from_adjacency(a, layout=layout)
    if axis == 0:
        qc, wc = q.T, w.T
        u = consensus_sync_torque(qc, wc, qc[:, links.src], wc[:, links.src], links.dst, links.weight, 1.3, 2.1, axis=0).T
    else:
        u = consensus_sync_torque(q, w, q[links.src], w[links.src], links.dst, links.weight, 1.3, 2.1)
    np.testing.assert_allclose(np.asarray(u), _law_by_hand(q, w, a, 1.3, 2.1), atol=1e-14)


def test_sync_law_vanishes_at_consensus_and_on_a_common_spin():
    q = np.tile(quat_from_axis_angle(np.array([0.0, 0.6, 0.8]), 1.1), (4, 1))
    w = np.tile([0.0, 2.0, 0.0], (4, 1))
    links = links_from_adjacency(complete_adjacency(4), layout="edges")
    u = consensus_sync_torque(q, w, q[links.src], w[links.src], links.dst, links.weight, 1.0, 2.0)
    np.testing.assert_allclose(np.asarray(u), 0.0, atol=1e-15)


def test_short_way_flips_only_the_long_way_round():
    q_i = np.array([[1.0, 0.0, 0.0, 0.0]])
    q_j = np.asarray(quat_from_axis_angle(np.array([0.0, 0.0, 1.0]), 3.0))[None]  # 172° away
    q = np.concatenate([q_i, -q_j])  # the neighbour stored on the other hemisphere
    w = np.zeros((2, 3))
    links = links_from_adjacency(complete_adjacency(2), layout="edges")
    args = (q, w, q[links.src], w[links.src], links.dst, links.weight, 1.0, 0.0)
    literal = np.asarray(consensus_sync_torque(*args))
    short = np.asarray(consensus_sync_torque(*args, short_way=True))
    # The short way pushes satellite 0 towards the neighbour along +z: torque ∝ +sin(86°).
    assert short[0, 2] == pytest.approx(np.sin(1.5), rel=1e-12)
    assert literal[0, 2] == pytest.approx(-np.sin(1.5), rel=1e-12)


def test_tracking_law_adds_the_reference_terms():
    q, w = _random_state(3, seed=4)
    links = links_from_adjacency(complete_adjacency(3), layout="edges")
    q_ref = np.asarray(reference_attitude(np.array([1.0, 0, 0, 0]), np.array([0.0, 0.1, 0.0]), 7.0))
    w_ref = np.array([0.0, 0.1, 0.0])
    sync = consensus_sync_torque(q, w, q[links.src], w[links.src], links.dst, links.weight, 1.0, 2.0)
    track = consensus_track_torque(q, w, q[links.src], w[links.src], links.dst, links.weight, 1.0, 2.0, 90.0, 80.0, q_ref, w_ref)
    e = np.array([q_ref[0] * qi[1:] - qi[0] * q_ref[1:] - np.cross(q_ref[1:], qi[1:]) for qi in q])
    np.testing.assert_allclose(np.asarray(track - sync), -90.0 * e - 80.0 * (w - w_ref), atol=1e-12)


def test_reference_attitude_rotates_about_the_reference_rate():
    q0 = np.asarray(quat_from_axis_angle(np.array([1.0, 0.0, 0.0]), 0.3))
    q = np.asarray(reference_attitude(q0, np.array([0.0, 0.1, 0.0]), 10.0))
    expected = np.asarray(quat_multiply(q0, quat_from_axis_angle(np.array([0.0, 1.0, 0.0]), 1.0)))
    np.testing.assert_allclose(q, expected, atol=1e-15)
