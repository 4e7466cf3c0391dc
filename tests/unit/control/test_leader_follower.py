"""Leader–follower consensus under multi-hop delay (SPEC §3): routes, the exact margin against
the closed loop, and the steady lag of law (3) behind a moving leader."""

import warnings

import numpy as np
import pytest

from coopsat.analysis.papers.leader_follower_2018 import steady_lag_rad
from coopsat.pipeline import prepare, simulate_built
from coopsat.plugins.leader_follower import follower_hops
from coopsat.scenarios.build import DesignWarning
from coopsat.scenarios.load import ScenarioError, load_scenario


def _built(name, *overrides):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DesignWarning)
        return prepare(load_scenario(name, list(overrides)))


def test_the_papers_ring_gives_its_hop_counts():
    built = _built("delay-classic-nodelay")
    (hops, weights), = follower_hops(built.scenario.controller, built.context)
    # Rows v1, v2; columns v0 (leader), v1, v2: m01 = 1, m21 = 2, m12 = 1, m02 = 2.
    np.testing.assert_array_equal(hops, [[1, 0, 2], [2, 1, 0]])
    np.testing.assert_array_equal(weights, [[1, 0, 1], [1, 1, 0]])


def _rate_error_growth(built):
    """Ratio of the largest follower rate error over the last fifth of the run to the first fifth."""
    ds, _ = simulate_built(built)
    err = np.abs(ds.omega.values[:, 1:] - ds.omega.values[:, :1]).max(axis=(1, 2))
    fifth = len(err) // 5
    return err[-fifth:].max() / err[:fifth].max()


@pytest.mark.slow
def test_the_exact_margin_separates_decay_from_growth_in_the_closed_loop():
    # Classical protocol, K = [1, 2]: exact constant-delay margin 0.178046 s. Run the engine
    # (1 ms control period, constant single-hop delay) at 0.95x and 1.05x of it.
    base = ["sim.dt_s=0.001", "controller.period_s=0.001", "sim.record_interval_s=0.1", "sim.t_final_s=120.0"]
    margin = _built("delay-classic-nodelay").checks["delay-margin"].detail.tau_s
    assert margin == pytest.approx(0.178046, abs=1e-6)
    below = _built("delay-classic-nodelay", *base, f"network.delivery.delay_s={round(0.95 * margin, 3)}")
    above = _built("delay-classic-nodelay", *base, f"network.delivery.delay_s={round(1.05 * margin, 3)}")
    assert _rate_error_growth(below) < 1e-2
    assert _rate_error_growth(above) > 1e2


def test_law3_settles_at_the_predicted_lag_behind_a_moving_leader():
    # A constant 0.5 s single-hop delay: law (3) with K = [1, 2] converges (its margin is
    # infinite) to a lag that only the leader's motion causes.
    built = _built("delay-law3-classic-gain", "network.delivery.random_delay.min_s=0.5", "sim.t_final_s=150.0")
    ds, _ = simulate_built(built)
    lag = steady_lag_rad(built, 0.5)  # (followers, axes)
    angle_err = ds.angle.values[-1, 1:] - ds.angle.values[-1, :1]
    np.testing.assert_allclose(angle_err, lag, atol=1e-6)
    assert np.abs(lag).max() > 0.01  # a real lag, not a converged zero
    np.testing.assert_allclose(ds.omega.values[-1, 1:], np.broadcast_to(ds.omega.values[-1, 0], (2, 3)), atol=1e-7)


def test_a_follower_that_cannot_hear_the_leader_is_refused():
    with pytest.raises(ScenarioError, match="network: v1, v2 cannot hear the leader v0"):
        _built("delay-classic-nodelay", "network.delivery.relay=false", 'network.edges=[["v1", "v2", 1.0], ["v2", "v1", 1.0]]')


def test_the_small_angle_model_is_required():
    with pytest.raises(ScenarioError, match='needs sim.attitude = "small-angle"'):
        _built("delay-classic-nodelay", "sim.attitude=rigid-body")
