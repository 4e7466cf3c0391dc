"""Linear steady-state analysis of cooperative observation (SPEC §5): Lyapunov against Monte Carlo,
limiting cases, the deterministic transfer and the stability check."""

from collections import deque

import numpy as np
import pytest

from coopsat.design.observation import (
    FEEDFORWARDS,
    SOURCES,
    pd_gains_for_bandwidth,
    relative_error_covariance,
    relative_error_transfer,
)

# A fast loop (ωn T = 0.1) so that Monte Carlo converges in few samples; the model is the same.
I_MC, T_MC = 0.3, 0.1
K1_MC, K2_MC = pd_gains_for_bandwidth(I_MC, 1.0, 0.7)
SIG_MC = (1e-4, 1e-4, 1e-4)  # star (rad), gyro (rad/s), torque (N·m): every source counts

# The realistic example of the module notes.
I_EX = np.array([0.28, 0.33, 0.35])
K1_EX, K2_EX = pd_gains_for_bandwidth(I_EX, 0.1, 0.7)
SIG_EX = (4.85e-5, 1e-4, 1e-5)


def simulate(law, delay, chains=128, steps=3000, burn=300, seed=0):
    """Plain sample-by-sample simulation of reference, independent follower and cooperative
    follower (same noise for both followers), written from the law statements, not the model.

    Returns the second moments of θ_r, θ_f (cooperative), e (independent), e (cooperative), the
    intersample mean of e² (cooperative, exact integral of the quadratic over each period), and
    the relative standard error of each second moment from the spread over independent chains.
    """
    rng = np.random.default_rng(seed)
    s_n, s_g, s_d = SIG_MC
    h = 0.5 * K1_MC
    th_r, w_r, th_i, w_i, th_c, w_c = np.zeros((6, chains))
    zero = np.zeros(chains)
    history = deque([(zero, zero, zero)] * (delay + 1), maxlen=delay + 1)
    prev = (zero, zero)  # the reference's measurement one period ago ("estimated")
    sums = np.zeros((5, chains))
    T = T_MC
    for k in range(burn + steps):
        n_r, g_r, d_r, n_i, g_i, d_i = rng.standard_normal((6, chains)) * np.array([s_n, s_g, s_d] * 2)[:, None]
        mth_r, mw_r = th_r + n_r, w_r + g_r
        u_r = -h * mth_r - K2_MC * mw_r
        # Both followers see the same own noise: two what-ifs of one spacecraft.
        n_f, g_f, d_f = n_i, g_i, d_i
        u_i = -h * (th_i + n_f) - K2_MC * (w_i + g_f)
        # Reference's message of period k: measured error, measured rate, angular acceleration.
        if law == "commanded":
            msg = (mth_r, mw_r, u_r / I_MC)
        elif law == "actual":
            msg = (mth_r, mw_r, (u_r + d_r) / I_MC)
        elif law == "none":
            msg = (mth_r, mw_r, zero)
        else:  # "estimated": last period's measurement and gyro-differenced acceleration
            msg = (prev[0], prev[1], (mw_r - prev[1]) / T)
            prev = (mth_r, mw_r)
        history.append(msg)
        rth, rw, ra = history[0]  # sent D periods ago
        u_c = -h * ((th_c + n_f) - rth) - K2_MC * ((w_c + g_f) - rw) + I_MC * ra
        acc_r, acc_i, acc_c = (u_r + d_r) / I_MC, (u_i + d_f) / I_MC, (u_c + d_f) / I_MC
        if k >= burn:
            a, b, c = th_c - th_r, w_c - w_r, 0.5 * (acc_c - acc_r)
            inter = a * a + a * b * T + (b * b + 2 * a * c) * T**2 / 3 + b * c * T**3 / 2 + c * c * T**4 / 5
            sums += np.stack([th_r**2, th_c**2, (th_i - th_r) ** 2, a * a, inter])
        th_r, w_r = th_r + T * w_r + 0.5 * T * T * acc_r, w_r + T * acc_r
        th_i, w_i = th_i + T * w_i + 0.5 * T * T * acc_i, w_i + T * acc_i
        th_c, w_c = th_c + T * w_c + 0.5 * T * T * acc_c, w_c + T * acc_c
    per_chain = sums / steps
    moment = per_chain.mean(axis=1)
    rel_se = per_chain.std(axis=1, ddof=1) / np.sqrt(chains) / moment
    return moment, rel_se


@pytest.mark.parametrize(
    "law, delay",
    [("commanded", 0), ("commanded", 3), ("actual", 0), ("actual", 1), ("estimated", 0), ("none", 2)],
)
def test_lyapunov_matches_monte_carlo(law, delay):
    """Std within 3 %. Justification: 128 independent chains × 3000 samples (384k samples; e
    decorrelates in ~1/(ζ ωn T) ≈ 14 samples). The chains' spread gives the standard error of each
    second moment; we require it below 1.5 % (i.e. ≤ 0.75 % on the std, half of it), so 3 % on the
    std is at least 4 standard errors: a failure means a model error, not bad luck."""
    st = relative_error_covariance(I_MC, K1_MC, K2_MC, T_MC, *SIG_MC, delay, cooperative_feedforward=law)
    moment, rel_se = simulate(law, delay)
    assert np.all(rel_se < 0.015), rel_se
    mc_std = np.sqrt(moment)
    model = [
        st.std_reference_rad,
        st.std_follower_cooperative_rad,
        st.std_relative_independent_rad,
        st.std_relative_cooperative_rad,
        st.std_relative_cooperative_intersample_rad,
    ]
    np.testing.assert_allclose(mc_std, model, rtol=0.03)


def test_contributions_sum_and_intersample_close_for_slow_loop():
    st = relative_error_covariance(I_EX, K1_EX, K2_EX, 0.1, *SIG_EX, 1, cooperative_feedforward="actual")
    for total, parts in (
        (st.std_relative_independent_rad, st.contributions_independent),
        (st.std_relative_cooperative_rad, st.contributions_cooperative),
        (st.std_relative_cooperative_intersample_rad, st.contributions_cooperative_intersample),
    ):
        assert set(parts) == set(SOURCES)
        np.testing.assert_allclose(sum(parts.values()), total**2, rtol=1e-12)
    # ωn T = 0.01: the error hardly moves within a period.
    np.testing.assert_allclose(st.std_relative_cooperative_intersample_rad, st.std_relative_cooperative_rad, rtol=1e-3)
    assert st.std_reference_rad.shape == (3,) and st.contributions_cooperative["d_r"].shape == (3,)
    np.testing.assert_array_less(st.closed_loop_spectral_radius, 1.0)


def test_scalar_inputs_give_floats():
    st = relative_error_covariance(I_MC, K1_MC, K2_MC, T_MC, *SIG_MC)
    assert isinstance(st.std_relative_cooperative_rad, float)
    assert isinstance(st.contributions_independent["n_f"], float)


def test_zero_noise_gives_zero():
    st = relative_error_covariance(I_EX, K1_EX, K2_EX, 0.1, 0.0, 0.0, 0.0, 2, cooperative_feedforward="estimated")
    for name in ("std_reference_rad", "std_follower_independent_rad", "std_follower_cooperative_rad", "std_relative_independent_rad", "std_relative_cooperative_rad", "mean_relative_cooperative_rad"):
        np.testing.assert_array_equal(getattr(st, name), 0.0)
    for parts in (st.contributions_independent, st.contributions_cooperative_intersample):
        assert all(np.all(v == 0.0) for v in parts.values())


@pytest.mark.parametrize("delay", [0, 1, 4])
def test_law23_with_commanded_feedforward_is_law8(delay):
    """The follower receives v = K m_r + u_r, and u_r = −K m_r: v ≡ 0 for any D, so law 23 with
    the reference's commanded acceleration as feed-forward is law 8, noise included."""
    st = relative_error_covariance(I_EX, K1_EX, K2_EX, 0.1, *SIG_EX, delay)
    np.testing.assert_allclose(st.std_follower_cooperative_rad, st.std_follower_independent_rad, rtol=1e-9)
    for s in SOURCES:
        np.testing.assert_allclose(st.contributions_cooperative[s], st.contributions_independent[s], rtol=1e-9, atol=1e-30)


def test_reference_disturbance_only_delay_zero():
    """Only d_r, D = 0. The claim "e stays exactly 0 with cooperation" is false for law 23 as
    specified: the follower does not move at all (θ_f ≡ 0: its PD term on θ_f − θ_r and the
    feed-forward u_r = −K θ_r cancel), so e = −θ_r exactly, as without cooperation. It holds only
    when the feed-forward is the reference's *actual* acceleration (u_r + d_r)/I: then the follower
    applies d_r itself, θ_f ≡ θ_r and e ≡ 0."""
    sig = dict(sigma_star_rad=0.0, sigma_gyro_rad_s=0.0, sigma_torque_nm=1e-5, follower_sigmas=(0.0, 0.0, 0.0))
    st = relative_error_covariance(I_EX, K1_EX, K2_EX, 0.1, **sig)
    np.testing.assert_allclose(st.std_relative_cooperative_rad, st.std_reference_rad, rtol=1e-9)
    np.testing.assert_allclose(st.std_relative_independent_rad, st.std_reference_rad, rtol=1e-9)
    np.testing.assert_allclose(st.std_follower_cooperative_rad, 0.0, atol=1e-12 * np.max(st.std_reference_rad))

    ideal = relative_error_covariance(I_EX, K1_EX, K2_EX, 0.1, **sig, cooperative_feedforward="actual")
    np.testing.assert_allclose(ideal.std_relative_cooperative_rad, 0.0, atol=1e-6 * np.max(st.std_reference_rad))
    np.testing.assert_allclose(ideal.std_follower_cooperative_rad, ideal.std_reference_rad, rtol=1e-9)


def test_sensor_noise_only_ratios():
    """Only sensor noise (σ_d = 0). The follower tracks the reference's *measured* error, so n_r and
    g_r stay in e whatever the law. Found ratios (cooperative/independent std of e): exactly 1 for
    "commanded" (law 23 ≡ law 8) and "actual" (the received term is d_r, noise-free); for
    "none" 1.063 (D = 0) and 1.064 (D = 1) — the reference's noise reaches e through T(1 + S)
    instead of T; for "estimated" 1.12 (the differenced gyro noise), 1.0 with star noise alone."""
    ratio = {}
    for law in FEEDFORWARDS:
        for delay in (0, 1):
            st = relative_error_covariance(I_EX, K1_EX, K2_EX, 0.1, 4.85e-5, 1e-4, 0.0, delay, cooperative_feedforward=law)
            ratio[law, delay] = st.std_relative_cooperative_rad / st.std_relative_independent_rad
    for delay in (0, 1):
        np.testing.assert_allclose(ratio["commanded", delay], 1.0, rtol=1e-9)
        np.testing.assert_allclose(ratio["actual", delay], 1.0, rtol=1e-9)
        # Loose: cooperation never removes sensor noise and "none"/"estimated" add some of it.
        assert np.all((ratio["none", delay] > 1.0) & (ratio["none", delay] < 1.2))
        assert np.all((ratio["estimated", delay] > 1.0) & (ratio["estimated", delay] < 1.3))
    np.testing.assert_allclose(ratio["none", 0], 1.0627, rtol=1e-3)


@pytest.mark.parametrize("law", FEEDFORWARDS)
def test_gyro_bias_offset(law):
    """Steady state: θ̇ = 0 and (k1/2) θ + k2 b = 0 on each spacecraft, so e = −2 k2 (b_f − b_r)/k1
    for every law (the cooperative follower's extra terms carry b_r and cancel it the same way)."""
    b_r, b_f = 2e-6, -1e-6
    st = relative_error_covariance(I_EX, K1_EX, K2_EX, 0.1, *SIG_EX, 2, cooperative_feedforward=law, gyro_bias_reference_rad_s=b_r, gyro_bias_follower_rad_s=b_f)
    np.testing.assert_allclose(st.mean_reference_rad, -2 * K2_EX * b_r / K1_EX, rtol=1e-9)
    np.testing.assert_allclose(st.mean_relative_independent_rad, -2 * K2_EX * (b_f - b_r) / K1_EX, rtol=1e-9)
    np.testing.assert_allclose(st.mean_relative_cooperative_rad, -2 * K2_EX * (b_f - b_r) / K1_EX, rtol=1e-9)


def test_relative_error_transfer():
    w = np.array([1e-3, 1e-2, 0.05, 0.3, 3.0])
    I, k1, k2 = I_EX[1], K1_EX[1], K2_EX[1]
    for delay in (0, 2):
        ind, coop = relative_error_transfer(I, k1, k2, 0.1, w, delay)
        np.testing.assert_allclose(ind, 1.0, rtol=1e-9)
        np.testing.assert_allclose(coop, 1.0, rtol=1e-9)  # law 23 ≡ law 8
        _, act = relative_error_transfer(I, k1, k2, 0.1, w, delay, cooperative_feedforward="actual")
        np.testing.assert_allclose(act, 2 * np.abs(np.sin(w * delay * 0.1 / 2)), rtol=1e-6, atol=1e-12)
        _, est = relative_error_transfer(I, k1, k2, 0.1, w, delay, cooperative_feedforward="estimated")
        np.testing.assert_allclose(est, 2 * np.abs(np.sin(w * (delay + 1) * 0.1 / 2)), rtol=1e-6)
    # No feed-forward, D = 0: the loop's sensitivity, ≈ (ω/ωn)² well below ωn = 0.1 rad/s.
    _, none = relative_error_transfer(I, k1, k2, 0.1, 0.01, 0, cooperative_feedforward="none")
    assert none == pytest.approx(0.01, rel=0.01)
    assert isinstance(none, float)


def test_unstable_gains_raise_one_line():
    # 1 − T k2/I < −1: the sampled rate loop alone is unstable.
    with pytest.raises(ValueError, match=r"^k1, k2 and period_s give an unstable sampled loop \(spectral radius") as info:
        relative_error_covariance(I_EX, K1_EX, 10.0, 0.1, *SIG_EX)
    assert "\n" not in str(info.value)
    with pytest.raises(ValueError, match="unstable sampled loop"):
        relative_error_transfer(0.3, 0.6, 10.0, 0.1, 0.01)


def test_bad_arguments():
    with pytest.raises(ValueError, match="cooperative_feedforward"):
        relative_error_covariance(0.3, 0.6, 0.42, 0.1, 0, 0, 0, cooperative_feedforward="magic")
    with pytest.raises(ValueError, match="delay_periods"):
        relative_error_covariance(0.3, 0.6, 0.42, 0.1, 0, 0, 0, delay_periods=-1)
    with pytest.raises(ValueError, match="omega"):
        relative_error_transfer(0.3, 0.6, 0.42, 0.1, 40.0)
