"""Reaction wheels: minimum-norm allocation, torque and speed limits (SPEC §5)."""

import jax.numpy as jnp
import numpy as np

from coopsat.actuators.wheels import THREE_AXIS_PLUS_SKEW_B, wheel_momentum_b, wheel_motor_torque

G = THREE_AXIS_PLUS_SKEW_B
G_PINV = np.linalg.pinv(G)
I_WHEEL = 1.1318e-4  # kg·m²
RPM = 2 * np.pi / 60
H_MAX = I_WHEEL * np.array([[1000.0], [1000.0], [1000.0], [1732.0]]) * RPM  # (4, 1), N·m·s
TAU_MAX = 2e-3  # N·m


def test_spin_axes_of_spec_section_5():
    assert G.shape == (3, 4)
    np.testing.assert_allclose(np.linalg.norm(G, axis=0), 1.0, rtol=1e-15)
    np.testing.assert_allclose(G[:, 3], np.ones(3) / np.sqrt(3), rtol=1e-15)


def test_unclipped_reproduces_the_commanded_body_torque():
    rng = np.random.default_rng(5)
    u = rng.uniform(-5e-4, 5e-4, size=(3, 6))
    tau, h_dot = (np.asarray(a) for a in wheel_motor_torque(u, np.zeros((4, 6)), G, G_PINV, TAU_MAX, H_MAX))
    assert tau.shape == (4, 6) and h_dot.shape == (3, 6)
    np.testing.assert_allclose(-G @ tau, u, rtol=0.0, atol=1e-18)
    np.testing.assert_allclose(h_dot, G @ tau, rtol=1e-15)
    np.testing.assert_allclose(-h_dot, u, rtol=0.0, atol=1e-18)


def test_minimum_norm_equals_lstsq():
    rng = np.random.default_rng(6)
    u = rng.uniform(-5e-4, 5e-4, size=(3, 5))
    tau, _ = wheel_motor_torque(u, np.zeros((4, 5)), G, G_PINV, np.inf, np.inf)
    tau_lstsq = np.linalg.lstsq(G, -u, rcond=None)[0]
    np.testing.assert_allclose(tau, tau_lstsq, rtol=1e-12, atol=1e-20)
    # Any other solution of −G τ = u adds a null-space component and is longer.
    null = np.linalg.svd(G)[2][-1]
    np.testing.assert_allclose(G @ null, 0.0, atol=1e-15)
    longer = np.asarray(tau) + 1e-4 * null[:, None]
    assert np.all(np.linalg.norm(longer, axis=0) > np.linalg.norm(tau, axis=0))


def test_torque_limit_clips_each_wheel():
    u = np.array([[-6e-3], [1e-4], [0.0]])  # wants about +5 mN·m on wheel 1
    tau, h_dot = (np.asarray(a) for a in wheel_motor_torque(u, np.zeros((4, 1)), G, G_PINV, TAU_MAX, H_MAX))
    unclipped = -G_PINV @ u
    assert unclipped[0, 0] > TAU_MAX
    np.testing.assert_allclose(tau, np.clip(unclipped, -TAU_MAX, TAU_MAX), rtol=1e-15)
    assert tau[0, 0] == TAU_MAX
    np.testing.assert_allclose(h_dot, G @ tau, rtol=1e-15)
    # Per-wheel limits broadcast as (m, 1).
    tau_w, _ = wheel_motor_torque(u, np.zeros((4, 1)), G, G_PINV, np.array([[1e-3], [1.0], [1.0], [1.0]]), H_MAX)
    assert float(tau_w[0, 0]) == 1e-3


def test_speed_limit_blocks_only_the_direction_that_would_exceed_it():
    u_speed_up = -G[:, [0]] * 1e-4  # body torque −g₁: wheel 1 must spin up along +g₁ ...
    u_slow_down = -u_speed_up
    at_plus_limit = np.zeros((4, 1))
    at_plus_limit[0, 0] = H_MAX[0, 0]
    tau, _ = wheel_motor_torque(u_speed_up, at_plus_limit, G, G_PINV, TAU_MAX, H_MAX)
    assert float((-G_PINV @ u_speed_up)[0, 0]) > 0.0
    assert float(tau[0, 0]) == 0.0  # ... but it is at +h_max: blocked
    np.testing.assert_allclose(np.asarray(tau)[1:], (-G_PINV @ u_speed_up)[1:], rtol=1e-15)  # others unaffected
    tau, _ = wheel_motor_torque(u_slow_down, at_plus_limit, G, G_PINV, TAU_MAX, H_MAX)
    np.testing.assert_allclose(tau, -G_PINV @ u_slow_down, rtol=1e-15)  # slowing down is allowed
    # At −h_max it is the other way round; just inside the limit nothing is blocked.
    tau, _ = wheel_motor_torque(u_slow_down, -at_plus_limit, G, G_PINV, TAU_MAX, H_MAX)
    assert float(tau[0, 0]) == 0.0
    tau, _ = wheel_motor_torque(u_speed_up, 0.999 * at_plus_limit, G, G_PINV, TAU_MAX, H_MAX)
    np.testing.assert_allclose(tau, -G_PINV @ u_speed_up, rtol=1e-15)
    # The skewed wheel has its own, larger limit: 1.5 × wheel 1's is inside it.
    skew = np.zeros((4, 1))
    skew[3, 0] = 1.5 * H_MAX[0, 0]
    u_skew = -G[:, [3]] * 1e-4
    tau, _ = wheel_motor_torque(u_skew, skew, G, G_PINV, TAU_MAX, H_MAX)
    np.testing.assert_allclose(tau, -G_PINV @ u_skew, rtol=1e-15)


def test_wheel_momentum_in_body_axes():
    h = np.array([[0.01, 0.0], [0.0, -0.002], [0.0, 0.0], [np.sqrt(3) * 0.001, 0.0]])  # (4, 2)
    np.testing.assert_allclose(wheel_momentum_b(h, G), [[0.011, 0.0], [0.001, -0.002], [0.001, 0.0]], rtol=1e-14)
    np.testing.assert_allclose(wheel_momentum_b(h[:, 0], G), [0.011, 0.001, 0.001], rtol=1e-14)


def test_speed_control_error_is_a_gauss_markov_process_the_body_feels():
    """With no command, each wheel's momentum wanders as I_k δΩ: stationary σ and lag-one
    correlation φ = exp(−T/τ_c) of the Gauss–Markov model, and the body gets exactly −G τ."""
    import jax
    from types import SimpleNamespace

    from coopsat.actuators.reaction_wheels import ReactionWheels as Part
    from coopsat.actuators.wheels import THREE_AXIS_PLUS_SKEW_B

    g = THREE_AXIS_PLUS_SKEW_B
    m, n, period, tau_c = 4, 3, 0.1, 1.0
    sigma = 5.0 / 3.0 * 2.0 * np.pi / 60.0
    inertia = 1.1318e-4
    part = Part(
        jnp.asarray(g), jnp.asarray(np.linalg.pinv(g)), jnp.full((m, 1), inertia), jnp.full((m, 1), 2e-3),
        jnp.full((m, 1), 1e3), jnp.zeros((m, n)), jnp.full((m, 1), sigma), jnp.asarray(np.exp(-period / tau_c)),
        speed_noise=True,
    )
    x = SimpleNamespace(omega_b=jnp.zeros((3, n)))

    def step(state, key):
        pulse, state = part.plan(jnp.zeros((3, n)), x, state, period, key)
        return state, (state["h"], pulse.level_nm, pulse.tau_nm)

    keys = jax.random.split(jax.random.PRNGKey(3), 20000)
    _, (h, level, tau) = jax.lax.scan(step, part.init(n), keys)
    err = np.asarray(h)[2000:] / inertia  # (T, m, n) rad/s, past the start-up from zero
    assert abs(err.std() / sigma - 1.0) < 0.05
    lag1 = np.mean(err[1:] * err[:-1]) / np.mean(err**2)
    assert abs(lag1 - np.exp(-period / tau_c)) < 0.02
    np.testing.assert_allclose(np.asarray(level), np.einsum("im,tmn->tin", g, np.asarray(tau)), atol=1e-18)
