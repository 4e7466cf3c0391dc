"""The delayed network: hand-computed arrival times, hops, losses, rerouting, random τ(t).

Each test builds the network part from a real scenario, then drives its ``deliver`` with a
synthetic outbox whose only field is the period number stamped by every transmitter, so the
stamp a receiver gets says exactly how late the message is.
"""

import warnings

import jax
import numpy as np
import pytest

from coopsat.workflows.pipeline import prepare, simulate_built
from coopsat.scenarios.build import DesignWarning
from coopsat.scenarios.load import ScenarioError, load_scenario

BASE = ["sim.t_final_s=1.0", "sim.dt_s=0.01", "controller.period_s=0.01", "actuators.kind=ideal-torque"]


def _network(tmp_path, delivery, network='kind = "edges"\nedges = [["sat1", "sat2", 1.0], ["sat2", "sat3", 1.0]]\ndirected = true', extra=""):
    """The built network part of a three-spacecraft scenario (period 0.01 s), and the names."""
    text = f"""
extends = "consensus-sync-a-stable"
[sim]
t_final_s = 1.0
[controller]
kind = "consensus-track"
period_s = 0.01
alpha = 1.0
beta = 2.0
k_p = 1.0
k_d = 1.0
omega_ref_rad_s = [0.0, 0.0, 0.0]
[network]
{network}
[network.delivery]
{delivery}
{extra}
"""
    path = tmp_path / "net.toml"
    path.write_text(text)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DesignWarning)
        built = prepare(load_scenario(path))
    return built.system.network, built


def _drive(net, n, frames, seed=0, switch=None):
    """Received stamps and weights per period: lists of arrays shaped like the links."""
    stamp = lambda f: {"stamp": np.full((1, n), float(f))}  # noqa: E731
    state = net.init(stamp(0))
    deliver = jax.jit(net.deliver)
    got, weights = [], []
    for f in range(frames):
        inbox, state, _ = deliver(f * net.period_ticks, stamp(f), state, jax.random.PRNGKey(1000 * seed + f))
        got.append(np.asarray(inbox.msg["stamp"][0]))
        weights.append(np.asarray(inbox.weight))
    return got, weights


def _pair(net, receiver, transmitter):
    """Index of the link (receiver hears transmitter) in the part's link arrays."""
    src, dst = np.asarray(net.src), np.asarray(net.dst)
    hit = np.argwhere((src == transmitter) & (dst == receiver) & (np.asarray(net.weight).max(axis=0) > 0))
    assert len(hit) == 1
    return tuple(hit[0])


def test_a_message_arrives_exactly_d_periods_late(tmp_path):
    net, built = _network(tmp_path, 'kind = "delayed"\ndelay_s = 0.07')
    got, _ = _drive(net, 5, 20)
    e = _pair(net, 1, 0)
    # Before t = 0 the history is the first outbox (stamp 0); afterwards stamp = f − 7.
    assert [g[e] for g in got] == [max(0, f - 7) for f in range(20)]


def test_two_hops_arrive_with_the_sum_of_two_different_delays(tmp_path):
    delivery = 'kind = "delayed"\nrelay = true\nlink_delays = [["sat1", "sat2", 0.02], ["sat2", "sat3", 0.05]]'
    net, _ = _network(tmp_path, delivery)
    got, _ = _drive(net, 5, 20)
    assert [g[_pair(net, 1, 0)] for g in got][10:] == [f - 2 for f in range(10, 20)]
    assert [g[_pair(net, 2, 1)] for g in got][10:] == [f - 5 for f in range(10, 20)]
    assert [g[_pair(net, 2, 0)] for g in got][10:] == [f - 7 for f in range(10, 20)]  # 2 hops: 2 + 5


def test_a_failure_reroutes_over_the_longer_path_with_the_longer_delay(tmp_path):
    # Directed ring sat1→sat2→sat3→sat4→sat5→sat1 plus a shortcut sat1→sat3 that fails at 0.1 s.
    edges = '[["sat1","sat2",1.0],["sat2","sat3",1.0],["sat3","sat4",1.0],["sat4","sat5",1.0],["sat5","sat1",1.0]'
    network = (
        f'kind = "edges"\ndirected = true\nedges = {edges}, ["sat1","sat3",1.0]]\n'
        f'[[network.switches]]\nt_s = 0.1\nkind = "edges"\ndirected = true\nedges = {edges}]'
    )
    net, _ = _network(tmp_path, 'kind = "delayed"\ndelay_s = 0.01\nrelay = true', network=network)
    got, _ = _drive(net, 5, 25)
    e = _pair(net, 2, 0)
    # One hop (1 period) before the failure, two hops (2 periods) after it.
    assert [g[e] for g in got][5:10] == [f - 1 for f in range(5, 10)]
    assert [g[e] for g in got][12:] == [f - 2 for f in range(12, 25)]


def test_a_dropout_holds_the_last_message(tmp_path):
    net, _ = _network(tmp_path, 'kind = "delayed"\ndelay_s = 0.01\ndropout_probability = 0.5')
    got, weights = _drive(net, 5, 400)
    e = _pair(net, 1, 0)
    stamps = np.array([g[e] for g in got])
    fresh = stamps[1:] == np.arange(1, 400) - 1
    held = stamps[1:] == stamps[:-1]
    assert np.all(fresh | held)  # every period: the new message, or the last one held
    assert 0.4 < 1 - fresh.mean() < 0.6  # about half are lost (400 draws: 5 sigma ≈ 0.125)
    assert all(w[e] == 1.0 for w in weights)


def test_a_dropout_can_drop_the_term_instead(tmp_path):
    net, _ = _network(tmp_path, 'kind = "delayed"\ndropout_probability = 0.3\non_loss = "drop"')
    got, weights = _drive(net, 5, 1000)
    e = _pair(net, 1, 0)
    w = np.array([x[e] for x in weights])
    assert set(np.unique(w)) == {0.0, 1.0}
    assert abs((w == 0).mean() - 0.3) < 5 * np.sqrt(0.3 * 0.7 / 1000)
    assert all(g[e] == f for f, g in enumerate(got))  # no delay: what arrives is current


def test_random_delay_is_bounded_piecewise_constant_and_summed_per_hop(tmp_path):
    delivery = (
        'kind = "delayed"\nrelay = true\n'
        "[network.delivery.random_delay]\nmin_s = 0.01\nmax_s = 0.04\nhold_min_s = 0.03\nhold_max_s = 0.06"
    )
    net, _ = _network(tmp_path, delivery)
    got, _ = _drive(net, 5, 300)
    one = np.array([f - g[_pair(net, 1, 0)] for f, g in enumerate(got)])[10:]
    two = np.array([f - g[_pair(net, 2, 0)] for f, g in enumerate(got)])[10:]
    assert one.min() >= 1 and one.max() <= 4 and len(np.unique(one)) > 1
    np.testing.assert_array_equal(two, 2 * one)  # two hops: 2·τ
    changes = np.flatnonzero(np.diff(one)) + 1
    assert np.diff(changes).min() >= 3  # held at least hold_min between draws


def test_the_same_seed_replays_and_another_seed_does_not(tmp_path):
    delivery = (
        'kind = "delayed"\ndropout_probability = 0.2\n'
        "[network.delivery.random_delay]\nmax_s = 0.05\nhold_min_s = 0.01\nhold_max_s = 0.05"
    )
    _, built = _network(tmp_path, delivery)
    a, _ = simulate_built(built)
    b, _ = simulate_built(built)
    for name in a.data_vars:
        np.testing.assert_array_equal(a[name].values, b[name].values)
    _, other = _network(tmp_path, delivery, extra="")
    other_scenario = load_scenario(tmp_path / "net.toml", ["seed=7"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DesignWarning)
        c, _ = simulate_built(prepare(other_scenario))
    assert not np.array_equal(a["network_tau_periods"].values, c["network_tau_periods"].values)


@pytest.mark.parametrize(
    "delivery, match",
    [
        ('kind = "delayed"\ndelay_s = 0.015', r"network\.delivery\.delay_s \(0\.015 s\) must be a whole number of control periods"),
        ('kind = "delayed"\nlink_delays = [["sat1", "sat3", 0.01]]', r"link_delays\[0\]: there is no link sat1 -> sat3"),
    ],
)
def test_bad_delays_name_the_field(tmp_path, delivery, match):
    with pytest.raises(ScenarioError, match=match) as info:
        _network(tmp_path, delivery)
    assert "\n" not in str(info.value)


def test_a_random_delay_below_its_own_minimum_is_refused(tmp_path):
    delivery = 'kind = "delayed"\n[network.delivery.random_delay]\nmin_s = 0.05\nmax_s = 0.02\nhold_min_s = 0.01\nhold_max_s = 0.01'
    with pytest.raises(ScenarioError, match=r"network\.delivery\.random_delay: .*above the bound max_s"):
        _network(tmp_path, delivery)


def test_a_route_lost_after_a_failure_is_refused(tmp_path):
    network = (
        'kind = "edges"\ndirected = true\nedges = [["sat1","sat2",1.0],["sat2","sat3",1.0],["sat3","sat1",1.0]]\n'
        '[[network.switches]]\nt_s = 0.5\nkind = "edges"\ndirected = true\nedges = [["sat1","sat2",1.0],["sat2","sat3",1.0]]'
    )
    with pytest.raises(ScenarioError, match=r"network\.switches\[0\]: no route from sat2 to sat1 is left"):
        _network(tmp_path, 'kind = "delayed"\nrelay = true', network=network)


def test_unknown_network_kind_lists_the_installed_ones(tmp_path):
    with pytest.raises(ScenarioError, match=r"network\.delivery: .*'ideal', 'delayed'"):
        _network(tmp_path, 'kind = "wormhole"')
