"""Relative-position consensus in orbit (``lvlh-consensus``): the law against a plain-NumPy
reimplementation, its per-spacecraft form, its start time, and its design check.

The reference below builds each receiver's LVLH axes from their definition (ẑ = −r̂,
ŷ = −ĥ, x̂ = ŷ × ẑ, frame rate h/|r|²) and sums over the links one by one, so it shares no
code with :mod:`coopsat.control.lvlh_consensus` or :mod:`coopsat.geometry.frames`.
"""

import math

import jax.numpy as jnp
import numpy as np
import pytest

from coopsat.control.lvlh_consensus import LvlhConsensus, slot_frame_turns
from coopsat.network.delivery import Inbox
from coopsat.plugins.lvlh_consensus import laplacian_modes

MU = 3.986004418e14
A_M = 6878137.0


def lvlh_axes(r, v):
    """Rows x̂, ŷ, ẑ of the LVLH frame at (r, v), and its rate (ECI), from the definition."""
    z = -r / np.linalg.norm(r)
    h = np.cross(r, v)
    y = -h / np.linalg.norm(h)
    return np.array([np.cross(y, z), y, z]), h / (r @ r)


def circular_orbit(phase_rad, inc_rad=math.radians(97.4)):
    """Position and velocity on a circle of radius A_M, at an argument of latitude."""
    speed = math.sqrt(MU / A_M)
    u = np.array([math.cos(phase_rad), math.sin(phase_rad), 0.0])
    w = np.array([-math.sin(phase_rad), math.cos(phase_rad), 0.0])
    turn = np.array([[1.0, 0.0, 0.0], [0.0, math.cos(inc_rad), -math.sin(inc_rad)], [0.0, math.sin(inc_rad), math.cos(inc_rad)]])
    return A_M * turn @ u, speed * turn @ w


def train(n, gap_m=10.0):
    """n spacecraft on one circle, gap_m apart behind the first; their slots in its LVLH frame."""
    theta = -gap_m * np.arange(n) / A_M
    states = [circular_orbit(th) for th in theta]
    r, v = np.array([s[0] for s in states]), np.array([s[1] for s in states])
    slots = np.stack([A_M * np.sin(theta), np.zeros(n), A_M * (1.0 - np.cos(theta))], axis=1)
    return r, v, slots


def ring_links(n, rng):
    """An undirected ring as an edge list sorted by receiver, with random weights."""
    pairs = sorted({(i, (i + d) % n) for i in range(n) for d in (-1, 1)})
    dst = np.array([p[0] for p in pairs])
    src = np.array([p[1] for p in pairs])
    return dst, src, rng.uniform(0.5, 2.0, size=len(pairs))


def reference_force(r, v, slots, dst, src, w, k_p, k_d, turns):
    """f_i = k_p Σ a_ij (ρ_ij − R_i (δ_j − δ_i)) + k_d Σ a_ij ρ̇_ij, ECI, link by link."""
    f = np.zeros_like(r)
    for i, j, a in zip(dst, src, w):
        c, omega = lvlh_axes(r[i], v[i])
        dr = r[j] - r[i]
        rho = c @ dr
        rho_dot = c @ (v[j] - v[i] - np.cross(omega, dr))
        f_lvlh = k_p * a * (rho - turns[i] @ (slots[j] - slots[i])) + k_d * a * rho_dot
        f[i] += c.T @ f_lvlh
    return f


def part(slots, turns, k_p=2e-4, k_d=5e-3, start_s=0.0):
    return LvlhConsensus(jnp.asarray(k_p), jnp.asarray(k_d), jnp.asarray(slots.T), jnp.asarray(np.moveaxis(turns, 0, -1)),
                         jnp.asarray(start_s))


def inbox(r, v, slots, dst, src, w):
    out = {"r_eci": r.T, "v_eci": v.T, "slot": slots.T}
    gather = lambda idx: {k: jnp.asarray(a[:, idx]) for k, a in out.items()}  # noqa: E731
    return Inbox(msg=gather(src), weight=jnp.asarray(w), dst=jnp.asarray(dst), own=gather(dst))


def test_slot_frames_turn_by_the_arc_about_the_orbit_normal():
    r, v, slots = train(5, gap_m=1000.0)
    turns = slot_frame_turns(r[0], v[0], slots)
    np.testing.assert_allclose(turns[0], np.eye(3), atol=1e-15)
    for k in range(1, 5):
        th = -1000.0 * k / A_M  # the slot's arc behind the first: its frame turned by θ about y
        c, s = math.cos(th), math.sin(th)
        expected = np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])
        # Rotation about ±y by θ, the sign fixed by the axes' definition; both rotation senses
        # cannot pass, so the test fixes it.
        assert np.allclose(turns[k], expected, atol=1e-12) or np.allclose(turns[k], expected.T, atol=1e-12)
        # and it agrees with the frames built from the definition at the slots' true states
        c_k, _ = lvlh_axes(r[k], v[k])
        c_0, _ = lvlh_axes(r[0], v[0])
        np.testing.assert_allclose(turns[k], c_k @ c_0.T, atol=1e-12)


def test_a_train_in_its_slots_commands_nothing():
    r, v, slots = train(8)
    turns = slot_frame_turns(r[0], v[0], slots)
    dst, src, w = ring_links(8, np.random.default_rng(0))
    commands, _, record = part(slots, turns).step(0.0, {"r_eci": r.T, "v_eci": v.T}, inbox(r, v, slots, dst, src, w), (), None)
    # The ring's closing link spans 70 m; rounding in r (7e6 m) is 1e-9 m.
    assert np.abs(record["spacing_error_lvlh"]).max() < 1e-7
    assert np.abs(commands["force_eci"]).max() < 1e-10


def test_the_law_equals_a_link_by_link_reference():
    rng = np.random.default_rng(1)
    n = 6
    r, v, slots = train(n)
    turns = slot_frame_turns(r[0], v[0], slots)
    r = r + rng.normal(scale=3.0, size=r.shape)  # off their slots by metres
    v = v + rng.normal(scale=0.01, size=v.shape)
    dst, src, w = ring_links(n, rng)
    k_p, k_d = 2e-4, 5e-3
    commands, _, _ = part(slots, turns, k_p, k_d).step(0.0, {"r_eci": r.T, "v_eci": v.T}, inbox(r, v, slots, dst, src, w), (), None)
    expected = reference_force(r, v, slots, dst, src, w, k_p, k_d, turns)
    assert np.abs(expected).max() > 1e-4  # the reference pushes: the comparison can fail
    np.testing.assert_allclose(np.asarray(commands["force_eci"]).T, expected, rtol=1e-9, atol=1e-15)


def test_one_spacecraft_computes_its_own_column():
    rng = np.random.default_rng(2)
    n = 5
    r, v, slots = train(n)
    turns = slot_frame_turns(r[0], v[0], slots)
    r = r + rng.normal(scale=2.0, size=r.shape)
    dst, src, w = ring_links(n, rng)
    law = part(slots, turns)
    box = inbox(r, v, slots, dst, src, w)
    whole = np.asarray(law.step(0.0, {"r_eci": r.T, "v_eci": v.T}, box, (), None)[0]["force_eci"])
    for i in range(n):
        mine = dst == i
        zero = lambda m: jnp.where(jnp.asarray(mine), m, 0.0)  # noqa: E731  what the engine hands spacecraft i
        box_i = Inbox(
            msg={k: zero(a) for k, a in box.msg.items()}, weight=zero(box.weight), dst=box.dst,
            own={k: zero(a) for k, a in box.own.items()},
        )
        one = law.step_one(i, 0.0, {"r_eci": jnp.asarray(r[i]), "v_eci": jnp.asarray(v[i])}, box_i, (), None)[0]["force_eci"]
        assert np.all(np.isfinite(one))  # zeroed links do not make NaN
        np.testing.assert_allclose(np.asarray(one), whole[:, i], rtol=1e-12, atol=1e-18)


def test_nothing_before_the_start_time():
    rng = np.random.default_rng(3)
    r, v, slots = train(4)
    turns = slot_frame_turns(r[0], v[0], slots)
    r = r + rng.normal(scale=5.0, size=r.shape)
    dst, src, w = ring_links(4, rng)
    law = part(slots, turns, start_s=100.0)
    box = inbox(r, v, slots, dst, src, w)
    before = law.step(95.0, {"r_eci": r.T, "v_eci": v.T}, box, (), None)[0]["force_eci"]
    after = law.step(100.0, {"r_eci": r.T, "v_eci": v.T}, box, (), None)[0]["force_eci"]
    assert np.all(np.asarray(before) == 0.0)
    assert np.abs(np.asarray(after)).max() > 1e-4


def test_laplacian_modes_of_a_complete_graph_are_n_over_m():
    n, m = 7, 4.0
    mu = laplacian_modes(np.ones((n, n)) - np.eye(n), np.full(n, m))
    assert abs(mu[0]) < 1e-12
    np.testing.assert_allclose(mu[1:].real, n / m, rtol=1e-12)


def test_a_ring_of_a_hundred_rings_and_a_split_graph_warns():
    """The design check on the swarm: a ring's slowest mode is barely damped (and said so); two
    groups that do not hear each other fail the check."""
    import coopsat

    swarm = coopsat.Scenario.load("leo-swarm-100")
    ring = swarm.set("network.kind", "ring").set("controller.k_p", 5e-3).set("controller.k_d", 0.1)
    check = coopsat.validate(ring).checks["lvlh-consensus"]
    # λ_2 = 2 (1 − cos 2π/100), μ = λ_2 / 4 kg: ζ = k_d μ / (2 √(k_p μ))
    mu = 2.0 * (1.0 - math.cos(2.0 * math.pi / 100)) / 4.0
    assert check.metrics["lvlh_consensus_slowest_damping"] == pytest.approx(0.1 * mu / (2.0 * math.sqrt(5e-3 * mu)), rel=1e-9)
    assert check.metrics["lvlh_consensus_slowest_damping"] < 0.05 and check.ok
    complete = coopsat.validate(swarm).checks["lvlh-consensus"]
    assert complete.ok and complete.metrics["lvlh_consensus_slowest_damping"] == pytest.approx(0.75, rel=1e-9)
    halves = [[f"sat{i}", f"sat{i + 1}", 1.0] for i in range(1, 100) if i != 50]  # a chain cut in two
    split = coopsat.validate(swarm.update({"network": {"kind": "edges", "edges": halves}})).checks["lvlh-consensus"]
    assert not split.ok and "2 groups" in split.note


@pytest.mark.parametrize(("path", "value", "words"), [
    ("controller.slot_lvlh_m", [[0.0, 0.0, 0.0]], ["controller.slot_lvlh_m", "1 slots for 100 spacecraft"]),
    ("network.kind", "none", ["lvlh-consensus", "[network]"]),
])
def test_bad_input_is_one_line(path, value, words):
    import coopsat

    with pytest.raises(coopsat.ScenarioError) as err:
        coopsat.validate(coopsat.Scenario.load("leo-swarm-100").set(path, value))
    assert all(w in str(err.value) for w in words) and "\n" not in str(err.value)


def test_a_run_that_ends_before_the_law_starts_has_no_slot_error_metrics():
    """leo-pair-differential-drag's law starts at 6 h: a 60 s run judges nothing (null), and
    spends nothing."""
    import coopsat

    result = coopsat.run(coopsat.Scenario.load("leo-pair-differential-drag").set("sim.t_final_s", 60.0))
    assert result.metrics["slot_error_along_track_max_m"] is None
    assert result.metrics["delta_v_m_s_deputy"] == 0.0 and result.metrics["delta_v_per_day_max_m_s"] == 0.0
