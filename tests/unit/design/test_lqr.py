"""coopsat.design.riccati: the package's one Riccati solver, against SciPy, closed forms and the
sampled CW keeping gain computed the way it was before lqr existed."""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm, solve_continuous_are, solve_discrete_are

import coopsat
from coopsat.astro.constants import MU_EARTH_M3_S2, R_EARTH_M
from coopsat.design import sampled_data
from coopsat.design.cw import cw_matrices
from coopsat.design.lti import bryson_weights
from coopsat.design.riccati import LQRResult, discretize, lqr

N_CW = math.sqrt(MU_EARTH_M3_S2 / (R_EARTH_M + 500e3) ** 3)  # 500 km chief, rad/s


def random_problem(seed, n=5, m=2):
    """A random stabilisable, detectable problem: (A, B) with an unstable A, Q ≻ 0, R ≻ 0."""
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(n, n))
    a += (0.5 - np.linalg.eigvals(a).real.min()) * np.eye(n)  # every open-loop pole unstable
    b = rng.normal(size=(n, m))
    mq, mr = rng.normal(size=(n, n)), rng.normal(size=(m, m))
    return a, b, mq @ mq.T + np.eye(n), mr @ mr.T + np.eye(m)


def care_residual(a, b, q, r, p):
    return a.T @ p + p @ a - p @ b @ np.linalg.solve(r, b.T @ p) + q


# --- continuous --------------------------------------------------------------------------------


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_continuous_equals_scipy_care_on_a_random_stabilisable_problem(seed):
    a, b, q, r = random_problem(seed)
    assert np.linalg.eigvals(a).real.min() > 0.0  # open loop unstable: the gain matters
    res = lqr(a, b, q, r)
    p_ref = solve_continuous_are(a, b, q, r)
    p_ref = 0.5 * (p_ref + p_ref.T)
    np.testing.assert_allclose(res.P, p_ref, rtol=1e-12, atol=0.0)
    np.testing.assert_allclose(res.K, np.linalg.solve(r, b.T @ p_ref), rtol=1e-12, atol=0.0)
    np.testing.assert_array_equal(res.P, res.P.T)
    poles = np.linalg.eigvals(a - b @ res.K)
    np.testing.assert_allclose(np.sort_complex(res.poles), np.sort_complex(poles), rtol=1e-12)
    assert res.poles.real.max() < 0.0
    assert res.discrete_dt_s is None
    # The residual it reports is the residual of the equation, relative, and small.
    scale = sum(np.linalg.norm(t) for t in (a.T @ res.P, res.P @ a, res.P @ b @ res.K, q))
    assert res.residual == pytest.approx(np.linalg.norm(care_residual(a, b, q, r, res.P)) / scale, rel=1e-6, abs=1e-17)
    assert 0.0 <= res.residual < 1e-12


def test_double_integrator_closed_form():
    # Q = I, R = 1: P = [[√3, 1], [1, √3]], K = [1, √3], poles −√3/2 ± j/2.
    res = lqr([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], np.eye(2), 1.0)
    s3 = math.sqrt(3.0)
    np.testing.assert_allclose(res.K, [[1.0, s3]], rtol=1e-13)
    np.testing.assert_allclose(res.P, [[s3, 1.0], [1.0, s3]], rtol=1e-13)
    np.testing.assert_allclose(np.sort_complex(res.poles), [-s3 / 2 - 0.5j, -s3 / 2 + 0.5j], rtol=1e-13)
    assert res.residual < 1e-14


def test_sign_convention_is_u_equals_minus_k_x():
    # A scalar unstable plant ẋ = x + u, Q = R = 1: P = 1 + √2, K = 1 + √2, pole −√2.
    res = lqr(1.0, 1.0, 1.0, 1.0)
    assert res.K.shape == (1, 1) and res.P.shape == (1, 1)
    assert res.K[0, 0] == pytest.approx(1.0 + math.sqrt(2.0), rel=1e-14)
    assert res.poles[0].real == pytest.approx(-math.sqrt(2.0), rel=1e-14)


def test_result_is_frozen():
    res = lqr(1.0, 1.0, 1.0, 1.0)
    assert isinstance(res, LQRResult)
    with pytest.raises(dataclasses.FrozenInstanceError):
        res.K = np.zeros((1, 1))


# --- sampled with a zero-order hold ------------------------------------------------------------


def old_discrete_lqr(n_rad_s, period_s, q, r):
    """The CW keeping gain as ``cw.discrete_lqr`` computed it before ``lqr`` (SciPy, inline)."""
    a, b = cw_matrices(n_rad_s)
    aug = np.zeros((9, 9))
    aug[:6, :6], aug[:6, 6:] = a, b
    e = expm(aug * period_s)
    phi, gam = e[:6, :6], e[:6, 6:]
    p = solve_discrete_are(phi, gam, q, r)
    p = 0.5 * (p + p.T)
    return np.linalg.solve(r + gam.T @ p @ gam, gam.T @ p @ phi), p, phi, gam


@pytest.mark.parametrize("period_s, mass_kg", [(10.0, 4.0), (1.0, 180.0), (60.0, 30.0)])
def test_discrete_is_the_old_cw_keeping_gain(period_s, mass_kg):
    # The cartwheel plug-in's weights: Bryson on 0.1 m, 1 mm/s and a 1 mN force per mass.
    q, r = bryson_weights([0.1] * 3 + [1e-3] * 3, [1e-3 / mass_kg] * 3)
    k_old, p_old, phi, gam = old_discrete_lqr(N_CW, period_s, q, r)
    res = lqr(*cw_matrices(N_CW), q, r, discrete_dt_s=period_s)
    np.testing.assert_allclose(res.K, k_old, rtol=1e-12, atol=0.0)
    np.testing.assert_allclose(res.P, p_old, rtol=1e-12, atol=0.0)
    assert res.discrete_dt_s == period_s
    # z-plane poles of Φ − ΓK, inside the unit circle.
    np.testing.assert_allclose(np.sort_complex(res.poles), np.sort_complex(np.linalg.eigvals(phi - gam @ res.K)), rtol=1e-10)
    assert np.abs(res.poles).max() < 1.0
    assert 0.0 <= res.residual < 1e-10  # weights span 10² to 10¹⁰: 7e-12 at worst here


@pytest.mark.parametrize("seed", [3, 4])
def test_discrete_equals_scipy_dare_on_the_zoh_samples(seed):
    a, b, q, r = random_problem(seed, n=4, m=2)
    t = 0.05
    phi, gam = expm(a * t), np.linalg.solve(a, (expm(a * t) - np.eye(4)) @ b)  # A invertible here
    p_ref = solve_discrete_are(phi, gam, q, r)
    k_ref = np.linalg.solve(r + gam.T @ p_ref @ gam, gam.T @ p_ref @ phi)
    res = lqr(a, b, q, r, discrete_dt_s=t)
    np.testing.assert_allclose(res.K, k_ref, rtol=1e-9)
    np.testing.assert_allclose(res.P, p_ref, rtol=1e-9)
    assert np.abs(res.poles).max() < 1.0
    assert res.residual < 1e-12


def test_discrete_tends_to_continuous_for_short_periods():
    # Q, R weigh samples: Q_d = Q T, R_d = R T approach the continuous cost as T → 0.
    a, b, q, r = [[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], np.eye(2), np.eye(1)
    t = 1e-4
    res = lqr(a, b, q * t, r * t, discrete_dt_s=t)
    np.testing.assert_allclose(res.K, [[1.0, math.sqrt(3.0)]], rtol=1e-3)
    np.testing.assert_allclose(np.log(res.poles) / t, lqr(a, b, q, r).poles, rtol=1e-3)


def test_one_zero_order_hold_in_the_design_package():
    design = Path(coopsat.__file__).parent / "design"
    defined = sorted(p.name for p in design.glob("*.py") if "def discretize(" in p.read_text(encoding="utf-8"))
    assert defined == ["riccati.py"]
    a, b, g = np.array([[0.0, 0.5], [0.0, 0.0]]), np.array([[0.0], [0.1]]), np.array([[1.0, 2.0]])
    phi, gam = discretize(a, b, 0.7)
    np.testing.assert_array_equal(sampled_data.period_map(a, b, g, 0.7), phi - gam @ g)


def test_only_lqr_calls_the_scipy_riccati_solvers():
    src = Path(coopsat.__file__).parent
    users = sorted(
        str(p.relative_to(src))
        for p in src.rglob("*.py")
        if "solve_continuous_are" in p.read_text(encoding="utf-8") or "solve_discrete_are" in p.read_text(encoding="utf-8")
    )
    assert users == ["design/riccati.py"]


# --- errors ------------------------------------------------------------------------------------

DI = ([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], np.eye(2), [[1.0]])


@pytest.mark.parametrize(
    "args, kwargs, match",
    [
        ((DI[0], DI[1], np.eye(3), DI[3]), {}, r"shapes do not match: A \(2, 2\), B \(2, 1\), Q \(3, 3\)"),
        ((DI[0], np.ones((3, 1)), DI[2], DI[3]), {}, "shapes do not match"),
        ((DI[0], DI[1], DI[2], np.eye(2)), {}, "shapes do not match"),
        ((np.ones((2, 3)), DI[1], DI[2], DI[3]), {}, "shapes do not match"),
        ((DI[0], DI[1], DI[2], [[0.0]]), {}, "R must be positive definite"),
        ((DI[0], DI[1], DI[2], [[-1.0]]), {}, "R must be positive definite"),
        ((DI[0], np.ones((2, 2)), DI[2], [[1.0, 0.5], [0.0, 1.0]]), {}, "R must be symmetric"),
        ((DI[0], DI[1], [[1.0, 2.0], [0.0, 1.0]], DI[3]), {}, "Q must be symmetric"),
        (([[np.nan, 1.0], [0.0, 0.0]], DI[1], DI[2], DI[3]), {}, "A must be a finite 2-D array"),
        (DI, {"discrete_dt_s": 0.0}, "discrete_dt_s must be finite and > 0"),
        (DI, {"discrete_dt_s": -1.0}, "discrete_dt_s must be finite and > 0"),
        (DI, {"discrete_dt_s": math.inf}, "discrete_dt_s must be finite and > 0"),
        # Not stabilisable: SciPy fails (continuous and sampled), re-raised as one line.
        (([[1.0]], [[0.0]], [[1.0]], [[1.0]]), {}, "continuous Riccati equation has no stabilising solution"),
        (([[1.0]], [[0.0]], [[1.0]], [[1.0]]), {"discrete_dt_s": 0.1}, "discrete Riccati equation has no stabilising solution"),
        # Stabilisable but Q blind to the double integrator: P = 0, K = 0, poles at 0.
        ((DI[0], DI[1], np.zeros((2, 2)), DI[3]), {}, "a closed-loop pole lies outside the stability region"),
    ],
)
def test_bad_problems_raise_one_line_value_errors(args, kwargs, match):
    with pytest.raises(ValueError, match=match) as info:
        lqr(*args, **kwargs)
    assert "\n" not in str(info.value)
    assert type(info.value) is ValueError


def test_steady_kalman_is_the_fixed_point_of_the_filter_recursion():
    """The steady covariances equal the Kalman recursion iterated to convergence (prediction,
    update) on a sampled double integrator measured in position, at the solver's accuracy."""
    from coopsat.design.riccati import steady_kalman

    phi = np.array([[1.0, 2.0], [0.0, 1.0]])
    h = np.array([[1.0, 0.0]])
    q = np.array([[2.0**3 / 3.0, 2.0**2 / 2.0], [2.0**2 / 2.0, 2.0]]) * 1e-3
    r = np.array([[0.25]])
    p = np.eye(2)
    for _ in range(5000):
        post = p - p @ h.T @ np.linalg.solve(h @ p @ h.T + r, h @ p)
        p = phi @ post @ phi.T + q
    prior, posterior = steady_kalman(phi, h, q, r)
    np.testing.assert_allclose(prior, p, rtol=1e-9)
    np.testing.assert_allclose(posterior, post, rtol=1e-9)
    with pytest.raises(ValueError, match="^steady_kalman: R must be positive definite"):
        steady_kalman(phi, h, q, [[0.0]])


def test_sampled_noise_of_a_double_integrator_is_its_closed_form():
    """White acceleration of density q on a double integrator: Q = q [[T³/3, T²/2], [T²/2, T]]
    (to the matrix exponential's accuracy)."""
    from coopsat.design.riccati import sampled_noise

    t, q = 5.0, 2e-9
    closed = q * np.array([[t**3 / 3.0, t**2 / 2.0], [t**2 / 2.0, t]])
    np.testing.assert_allclose(sampled_noise(DI[0], [[0.0, 0.0], [0.0, q]], t), closed, rtol=1e-10)
