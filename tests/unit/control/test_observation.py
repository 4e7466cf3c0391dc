"""The staring laws of SPEC §5 (control/observation.py) against closed forms and independent
numerical derivatives."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from coopsat.control.observation import (
    angular_acceleration,
    body_error,
    cooperative_target,
    desired_motion,
    dumping_dipole,
    law8_torque,
    law23_torque,
    stare_quaternion,
)
from coopsat.geometry.quaternion import quat_angle, quat_conjugate, quat_multiply, quat_rotate, quat_vector

RNG = np.random.default_rng(5)
INERTIA = np.diag([0.28, 0.33, 0.35])


def _random_quat():
    q = Rotation.random(random_state=RNG).as_quat(scalar_first=True)
    return q if q[0] >= 0 else -q


def _random_los(q_sun):
    """A line of sight within 150° of the sun-pointing camera axis (eq. 2 is singular at 180°)."""
    while True:
        v = RNG.normal(size=3) * RNG.uniform(1e5, 2e6)
        z = np.asarray(quat_rotate(q_sun, np.array([0.0, 0.0, 1.0])))
        if v @ z / np.linalg.norm(v) > np.cos(np.radians(150)):
            return v


@pytest.mark.parametrize("trial", range(20))
def test_stare_puts_the_camera_exactly_on_the_target(trial):
    q_s = _random_quat()
    los = _random_los(q_s)
    q_d = np.asarray(stare_quaternion(los, q_s))
    z_eci = np.asarray(quat_rotate(q_d, np.array([0.0, 0.0, 1.0])))
    assert np.linalg.norm(z_eci - los / np.linalg.norm(los)) < 1e-14
    # The least rotation (eq. 2): its angle is δ = angle(z, p) and its axis lies in the x-y plane of Q_s.
    r = np.asarray(quat_multiply(quat_conjugate(q_s), q_d))
    p = np.asarray(quat_rotate(quat_conjugate(q_s), los))
    delta = np.arccos(p[2] / np.linalg.norm(p))
    assert abs(float(quat_angle(r)) - delta) < 1e-12
    assert abs(r[3]) < 1e-15


def _los_track(t):
    """A smooth line of sight (ECI, m) of a low orbit over a target turning with the Earth."""
    n, w = 1.1e-3, 7.29e-5
    r_sc = 6.9e6 * jnp.stack([jnp.cos(n * t), 0.2 * jnp.sin(n * t), 0.98 * jnp.sin(n * t)])
    r_g = 6.37e6 * jnp.stack([jnp.cos(w * t + 0.05), jnp.sin(w * t + 0.05), jnp.asarray(0.1)])
    return r_g - r_sc


def _central(f, t, h, order):
    """Derivative of ``order`` 1 or 2 by 8th-order central differences (an independent check)."""
    c1 = np.array([1 / 280, -4 / 105, 1 / 5, -4 / 5, 0, 4 / 5, -1 / 5, 4 / 105, -1 / 280])
    c2 = np.array([-1 / 560, 8 / 315, -1 / 5, 8 / 5, -205 / 72, 8 / 5, -1 / 5, 8 / 315, -1 / 560])
    samples = np.array([np.asarray(f(t + k * h)) for k in range(-4, 5)])
    return np.tensordot((c1, c2)[order - 1], samples, axes=1) / h**order


@pytest.mark.parametrize("t0", [0.0, 400.0, 900.0])
def test_feed_forward_rate_and_acceleration_against_numerical_derivatives(t0):
    q_s = _random_quat()

    def q_of_t(t):
        return stare_quaternion(_los_track(t), q_s)

    los = _los_track(t0)
    rho_dot = jax.jacfwd(_los_track)(t0)
    rho_ddot = jax.jacfwd(jax.jacfwd(_los_track))(t0)
    q_d, w_d, w_dot_d = (np.asarray(v) for v in desired_motion(los, rho_dot, rho_ddot, q_s))
    q_dot = _central(q_of_t, t0, 0.5, 1)
    w_num = 2.0 * np.asarray(quat_vector(quat_multiply(quat_conjugate(q_d), q_dot)))
    assert np.max(np.abs(w_d - w_num)) < 1e-10 * max(1.0, np.max(np.abs(w_d))) + 1e-13

    def w_of_t(t):
        lo = _los_track(t)
        return desired_motion(lo, jax.jacfwd(_los_track)(t), jax.jacfwd(jax.jacfwd(_los_track))(t), q_s)[1]

    w_dot_num = _central(w_of_t, t0, 0.5, 1)
    assert np.max(np.abs(w_dot_d - w_dot_num)) < 1e-9 * np.max(np.abs(w_dot_d)) + 1e-14
    assert np.max(np.abs(w_d)) > 1e-4  # a real slew rate, not a trivially zero case


def test_cooperative_target_is_the_reference_when_desired_attitudes_agree():
    q_rd, q_r = _random_quat(), _random_quat()
    w_rd, wd_rd, w_r, wd_r = (RNG.normal(size=3) * 0.01 for _ in range(4))
    dq_r = body_error(q_r, q_rd)
    q_t, w_t, wd_t = (np.asarray(v) for v in cooperative_target(q_rd, w_rd, wd_rd, dq_r, w_r, wd_r, w_rd, wd_rd))
    assert float(quat_angle(quat_multiply(quat_conjugate(q_t), q_r))) < 1e-12
    assert np.allclose(w_t, w_r, atol=1e-16) and np.allclose(wd_t, wd_r, atol=1e-16)


def test_cooperative_target_rate_is_the_derivative_of_its_attitude():
    """ω_T and ω̇_T against differences of q_T(t) = q_fd(t) ⊗ q_rd(t)* ⊗ q_r(t) along smooth motions.

    Its own generator, so the draw does not depend on which tests ran before: this one takes
    the reference's error through 180° at t ≈ 50.4 s, where ``body_error`` changes hemisphere,
    so the differenced samples are put on the hemisphere of q_T(t0) first."""
    rng = np.random.default_rng(5)
    a0, a1, b0, b1, c0, c1 = (rng.normal(size=3) * s for s in (0.5, 0.01, 0.5, 0.012, 0.5, 0.02))

    def rot(v0, v1, t):
        angle = v0 + v1 * t + 0.3 * v1 * jnp.sin(0.01 * t)
        theta = jnp.sqrt(jnp.sum(angle**2))
        return jnp.concatenate([jnp.cos(theta / 2)[None], jnp.sin(theta / 2) * angle / theta])

    def body_rate(qf, t):
        q = qf(t)
        return 2.0 * quat_vector(quat_multiply(quat_conjugate(q), jax.jacfwd(qf)(t)))

    q_fd, q_rd, q_r = (lambda t, a=a, b=b: rot(a, b, t) for a, b in ((a0, a1), (b0, b1), (c0, c1)))
    t0 = 50.0

    def target(t):
        rates = [body_rate(f, t) for f in (q_fd, q_rd, q_r)]
        accs = [jax.jacfwd(lambda s, f=f: body_rate(f, s))(t) for f in (q_fd, q_rd, q_r)]
        return cooperative_target(q_fd(t), rates[0], accs[0], body_error(q_r(t), q_rd(t)), rates[2], accs[2], rates[1], accs[1])

    q_t, w_t, wd_t = (np.asarray(v) for v in target(t0))
    def q_target(t):
        q = np.asarray(target(t)[0])
        return q if q @ q_t >= 0.0 else -q

    q_dot = _central(q_target, t0, 0.5, 1)
    w_num = 2.0 * np.asarray(quat_vector(quat_multiply(quat_conjugate(q_t), q_dot)))
    assert np.max(np.abs(w_t - w_num)) < 1e-9
    wd_num = _central(lambda t: target(t)[1], t0, 0.5, 1)
    assert np.max(np.abs(wd_t - wd_num)) < 1e-9


def test_law23_closed_loop_is_linear_in_the_tracking_error():
    """With law 23 the rigid body obeys I Δω̇ = −k1 vec(δq) − k2 Δω exactly (eq. 29)."""
    k1, k2 = 0.03, 0.1
    q, q_t = _random_quat(), _random_quat()
    w, w_t, wd_t, h = (RNG.normal(size=3) * s for s in (0.02, 0.02, 1e-3, 5e-3))
    tau = law23_torque(q, w, h, q_t, w_t, wd_t, INERTIA, k1, k2)
    w_dot = np.asarray(angular_acceleration(w, h, tau, INERTIA))
    # d/dt of Δω = ω − C(δq)ᵀ ω_T, with δq̇ = ½ δq ⊗ Δω.
    dq = np.asarray(body_error(q, q_t))
    to_body = quat_conjugate(dq)
    w_t_b = np.asarray(quat_rotate(to_body, w_t))
    d_omega = w - w_t_b
    d_omega_dot = w_dot - (np.asarray(quat_rotate(to_body, wd_t)) - np.cross(d_omega, w_t_b))
    expected = np.linalg.solve(INERTIA, -k1 * dq[1:] - k2 * d_omega)
    assert np.max(np.abs(d_omega_dot - expected)) < 1e-15


def test_law8_holds_a_spacecraft_already_on_its_desired_motion():
    """On the desired motion (δq = 1, ω = ω_d) law 8's torque makes ω̇ equal the desired acceleration."""
    q_d = _random_quat()
    w_d, wd_d, h = RNG.normal(size=3) * 0.01, RNG.normal(size=3) * 1e-4, RNG.normal(size=3) * 1e-3
    tau = law8_torque(q_d, w_d, h, q_d, w_d, wd_d, INERTIA, 0.03, 0.1)
    assert np.max(np.abs(np.asarray(angular_acceleration(w_d, h, tau, INERTIA)) - wd_d)) < 1e-17


def test_dumping_torque_opposes_the_momentum_across_the_field():
    h, b = RNG.normal(size=3) * 1e-3, RNG.normal(size=3) * 3e-5
    torque = np.cross(np.asarray(dumping_dipole(h, b)), b)
    b_hat = b / np.linalg.norm(b)
    across = h - (h @ b_hat) * b_hat
    assert np.allclose(torque, -across, atol=1e-18)
