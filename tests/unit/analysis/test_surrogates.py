"""The smooth surrogates of coopsat tune against closed forms, limits and finite differences."""

from types import SimpleNamespace

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import trapezoid
from scipy.special import logsumexp

from coopsat.analysis import surrogates as sur
from coopsat.analysis.surrogates import (
    GELFAND_SQUARINGS,
    SMOOTH_MAX_TEMPERATURE,
    Surrogate,
    settled_by,
    smooth_max,
    spectral_radius_bound,
    surrogates,
    time_weighted_error,
)

# --------------------------------------------------------------------------------------------
# smooth_max


@pytest.mark.parametrize("temperature", [1.0, 0.1, 0.02])
def test_smooth_max_is_the_log_sum_exp_and_bounds_the_max(temperature):
    x = np.array([0.3, -1.2, 0.95, 0.9, 0.1])
    closed_form = temperature * np.log(np.sum(np.exp(x / temperature)))
    value = float(smooth_max(jnp.asarray(x), temperature))
    assert value == pytest.approx(closed_form, rel=1e-12)
    assert x.max() < value <= x.max() + temperature * np.log(x.size) + 1e-15


def test_smooth_max_of_equal_samples_exceeds_them_by_exactly_tau_log_n():
    for n in (1, 2, 7, 1000):
        assert float(smooth_max(jnp.full(n, 0.8), 0.05)) == pytest.approx(0.8 + 0.05 * np.log(n), abs=1e-12)


def test_smooth_max_tends_to_the_max_as_the_temperature_vanishes():
    x = jnp.asarray(np.random.default_rng(0).normal(size=50))
    gaps = [float(smooth_max(x, tau)) - float(jnp.max(x)) for tau in (1.0, 1e-1, 1e-2, 1e-3, 1e-4)]
    assert gaps[0] > 0 and all(g >= 0 for g in gaps)  # (a gap below round-off reads 0)
    assert gaps == sorted(gaps, reverse=True)
    assert gaps[-1] < 1e-4 * np.log(50) + 1e-15


def test_smooth_max_does_not_overflow_at_a_small_temperature():
    # x/τ = 1e4: exp alone overflows; the log-sum-exp must not.
    x = jnp.asarray([100.0, 99.0, -5.0])
    assert float(smooth_max(x, 0.01)) == pytest.approx(100.0, abs=1e-12)


def test_smooth_max_gradient_is_the_softmax_and_matches_finite_differences():
    x = np.array([0.2, 0.5, 0.45, -0.3])
    tau = 0.1
    grad = np.asarray(jax.grad(lambda v: smooth_max(v, tau))(jnp.asarray(x)))
    w = np.exp((x - x.max()) / tau)
    np.testing.assert_allclose(grad, w / w.sum(), rtol=1e-12)
    assert grad.sum() == pytest.approx(1.0) and np.all(grad > 0)  # every sample pulls, upward
    h = 1e-6
    fd = [(float(smooth_max(jnp.asarray(x + h * e), tau)) - float(smooth_max(jnp.asarray(x - h * e), tau))) / (2 * h)
          for e in np.eye(x.size)]
    np.testing.assert_allclose(grad, fd, rtol=1e-6)


# --------------------------------------------------------------------------------------------
# settled_by


def _decay(t, tol_ratio, tau_s):
    """A normalised error (1 = the tolerance) that decays from tol_ratio with time constant
    tau_s: exactly at the tolerance at t* = tau_s·ln(tol_ratio)."""
    return tol_ratio * np.exp(-t / tau_s)


def test_settled_by_is_the_smooth_max_of_the_late_samples_less_one():
    t = np.arange(0.0, 100.0, 1.0)
    e = _decay(t, 20.0, 10.0)
    for bound in (0.0, 29.5, 30.0, 99.0):
        late = e[t >= bound]  # samples at or after the bound
        expected = SMOOTH_MAX_TEMPERATURE * logsumexp(late / SMOOTH_MAX_TEMPERATURE) - 1.0
        assert float(settled_by(t, jnp.asarray(e), bound)) == pytest.approx(expected, rel=1e-12, abs=1e-12)


def test_settled_by_is_one_when_no_sample_is_late():
    t = np.linspace(0.0, 10.0, 11)
    assert float(settled_by(t, jnp.zeros(11), 10.5)) == 1.0
    assert float(settled_by(t, jnp.zeros(11), 10.0)) < 0.0  # the last sample counts (t ≥ bound)


def test_settled_by_holds_exactly_when_the_error_has_settled_by_the_bound():
    # Exact settling time of e(t) = 20 exp(−t/10): t* = 10 ln 20 ≈ 29.96 s.
    t = np.arange(0.0, 200.0, 0.5)
    e = jnp.asarray(_decay(t, 20.0, 10.0))
    assert 29.5 < 10.0 * np.log(20.0) < 30.0  # t*: the first sample inside is at 30 s
    margin = SMOOTH_MAX_TEMPERATURE * np.log(t.size)  # the log-sum-exp's worst excess
    for bound in (0.0, 10.0, 29.0, 29.5):  # the sample at 29.5 s is still outside (1.047)
        assert float(settled_by(t, e, bound)) > 0.0, bound  # some late sample is outside
    # Settled with the margin: the largest late sample is below 1 − margin.
    late_enough = 10.0 * np.log(20.0 / (1.0 - margin))
    for bound in (late_enough + 0.5, 60.0, 150.0):
        assert float(settled_by(t, e, bound)) <= 0.0, bound
    # Monotone in the bound: a later bound is never harder to meet.
    values = [float(settled_by(t, e, b)) for b in np.arange(0.0, 199.0, 40.0)]  # (each length compiles anew)
    assert all(b <= a + 1e-15 for a, b in zip(values, values[1:]))


def test_settled_by_tends_to_the_exact_late_max_as_the_smoothing_vanishes(monkeypatch):
    t = np.arange(0.0, 50.0, 1.0)
    e = _decay(t, 5.0, 8.0) + 0.05 * np.sin(t)
    bound = 12.0
    exact = e[t >= bound].max() - 1.0
    gaps = []
    for tau in (0.1, 0.02, 1e-3, 1e-5):
        monkeypatch.setattr(sur, "SMOOTH_MAX_TEMPERATURE", tau)
        gaps.append(float(settled_by(t, jnp.asarray(e), bound)) - exact)
    assert all(g >= 0 for g in gaps) and gaps == sorted(gaps, reverse=True)
    assert gaps[-1] < 1e-5 * np.log(t.size) + 1e-12


def test_settled_by_gradient_reaches_only_the_late_samples():
    t = np.arange(0.0, 20.0, 1.0)
    e = _decay(t, 3.0, 5.0)
    grad = np.asarray(jax.grad(lambda v: settled_by(t, v, 7.0))(jnp.asarray(e)))
    assert np.all(grad[t < 7.0] == 0.0)
    assert np.all(grad[t >= 7.0] > 0.0) and grad.sum() == pytest.approx(1.0)
    assert np.all(np.isfinite(grad))


# --------------------------------------------------------------------------------------------
# time_weighted_error


@pytest.mark.parametrize("t", [np.linspace(0.0, 10.0, 101), np.linspace(3.0, 10.0, 8), np.array([0.0, 0.1, 0.5, 2.0, 7.0])])
def test_time_weighted_error_of_a_constant_error_is_the_error(t):
    assert float(time_weighted_error(t, jnp.full(t.size, 0.37))) == pytest.approx(0.37, rel=1e-12)


def test_time_weighted_error_is_the_trapezoid_itae_normalised():
    t = np.sort(np.random.default_rng(2).uniform(0.0, 30.0, 40))
    e = np.abs(np.sin(t)) + 0.1
    expected = trapezoid(t * e, t) / (0.5 * (t[-1] ** 2 - t[0] ** 2))
    assert float(time_weighted_error(t, jnp.asarray(e))) == pytest.approx(expected, rel=1e-12)


def test_time_weighted_error_converges_to_the_integral_closed_form():
    # e(t) = exp(−t/τ) on [0, T]: ∫ t e dt = τ²(1 − e^(−T/τ)(1 + T/τ)), ∫ t dt = T²/2.
    tau, big_t = 4.0, 20.0
    exact = tau**2 * (1.0 - np.exp(-big_t / tau) * (1.0 + big_t / tau)) / (0.5 * big_t**2)
    errors = []
    for n in (11, 101, 1001):
        t = np.linspace(0.0, big_t, n)
        errors.append(abs(float(time_weighted_error(t, jnp.asarray(np.exp(-t / tau)))) - exact))
    assert errors[-1] < 1e-5 * exact
    assert errors[1] / errors[2] == pytest.approx(100.0, rel=0.05)  # the trapezoid's h² error


def test_time_weighted_error_weighs_late_error_more():
    t = np.linspace(0.0, 10.0, 101)
    early = np.where(t < 5.0, 1.0, 0.0)
    late = np.where(t >= 5.0, 1.0, 0.0)
    assert float(time_weighted_error(t, jnp.asarray(late))) > 2 * float(time_weighted_error(t, jnp.asarray(early)))
    # Linear in the error: the gradient is the per-sample weight, positive, growing with t.
    grad = np.asarray(jax.grad(lambda e: time_weighted_error(t, e))(jnp.asarray(early)))
    assert np.all(grad[1:] > 0.0) and np.all(np.diff(grad[1:-1]) > 0.0) and grad[0] == 0.0


# --------------------------------------------------------------------------------------------
# spectral_radius_bound


def _rho(m):
    return np.abs(np.linalg.eigvals(m)).max()


def test_spectral_radius_bound_is_a_tight_upper_bound_on_random_matrices():
    rng = np.random.default_rng(5)
    for n in (2, 5, 12):
        for _ in range(3):
            m = rng.normal(size=(n, n)) / np.sqrt(n)
            bound = float(spectral_radius_bound(jnp.asarray(m)))
            assert _rho(m) * (1 - 1e-9) <= bound <= _rho(m) * 1.002, (n, bound, _rho(m))


def test_spectral_radius_bound_of_a_symmetric_matrix_has_its_closed_form():
    # Normal M: ‖M^k‖_F = (Σ|λ|^(2k))^½, so the bound is ρ·m^(1/(2k)), m the multiplicity of ρ.
    k = 2**GELFAND_SQUARINGS
    q, _ = np.linalg.qr(np.random.default_rng(7).normal(size=(6, 6)))
    for eigs, mult in (([0.9, -0.9, 0.5, 0.1, 0.0, 0.3], 2), ([0.97, 0.2, 0.2, 0.2, -0.4, 0.5], 1)):
        m = q @ np.diag(eigs) @ q.T
        expected = max(np.abs(eigs)) * mult ** (1.0 / (2 * k))
        assert float(spectral_radius_bound(jnp.asarray(m))) == pytest.approx(expected, rel=1e-9)


def test_spectral_radius_bound_neither_overflows_nor_underflows():
    m = np.array([[0.0, 2.0], [-0.5, 0.1]])
    for scale in (1e-120, 1e-3, 1.0, 1e3, 1e120):
        assert float(spectral_radius_bound(jnp.asarray(scale * m))) == pytest.approx(scale * _rho(m), rel=1e-3)


@pytest.mark.parametrize("n, lam, eps", [(4, 0.8, 1.0), (12, -0.95, 0.3), (36, 0.8, 0.05)])
def test_spectral_radius_bound_of_a_jordan_block_is_gelfands_formula(n, lam, eps):
    # M = λI + εN (N the shift): M^k = Σ_p C(k, p) λ^(k−p) ε^p N^p, and N^p has n − p ones,
    # so ‖M^k‖_F² = Σ_p (n − p) (C(k, p) |λ|^(k−p) ε^p)²: the bound in closed form (log domain).
    from scipy.special import gammaln

    k = 2**GELFAND_SQUARINGS
    p = np.arange(n)
    log_terms = gammaln(k + 1) - gammaln(p + 1) - gammaln(k - p + 1) + (k - p) * np.log(abs(lam)) + p * np.log(eps)
    expected = np.exp(0.5 * logsumexp(2 * log_terms, b=n - p) / k)
    m = lam * np.eye(n) + eps * np.eye(n, k=1)
    bound = float(spectral_radius_bound(jnp.asarray(m)))
    assert bound == pytest.approx(expected, rel=1e-9)
    assert abs(lam) < bound  # above ρ by the Jordan block's polynomial growth, ^(1/k)


def test_spectral_radius_bound_has_a_gradient_where_the_eigenvalues_repeat():
    # M(a) = a·I ⊗ R: every eigenvalue of R repeats, ρ(M(a)) = |a|·ρ(R), dρ/da = ρ(R).
    r = np.array([[0.6, 0.3], [-0.3, 0.6]])  # eigenvalues 0.6 ± 0.3i, ρ = √0.45
    base = np.kron(np.eye(3), r)

    def f(a):
        return spectral_radius_bound(a * jnp.asarray(base))

    g = float(jax.grad(f)(1.1))
    h = 1e-5
    fd = (float(f(1.1 + h)) - float(f(1.1 - h))) / (2 * h)
    assert np.isfinite(g)
    assert g == pytest.approx(fd, rel=1e-5)
    assert g == pytest.approx(np.sqrt(0.45), rel=1e-3)
    # And entrywise: the gradient of ρ w.r.t. M at a simple real eigenvalue is u vᵀ/(uᵀv)
    # (left and right eigenvectors), which the smooth bound must reproduce.
    m = np.array([[0.5, 0.2, 0.0], [0.1, 0.3, 0.05], [0.0, 0.4, -0.2]])
    w, vl, vr = _eig_lr(m)
    top = np.argmax(np.abs(w))
    u, v = vl[:, top], vr[:, top]
    analytic = np.sign(w[top].real) * np.real(np.outer(u.conj(), v) / (u.conj() @ v))
    grad = np.asarray(jax.grad(spectral_radius_bound)(jnp.asarray(m)))
    np.testing.assert_allclose(grad, analytic, atol=2e-3)


def _eig_lr(m):
    from scipy.linalg import eig

    w, vl, vr = eig(m, left=True, right=True)
    return w, vl, vr


# --------------------------------------------------------------------------------------------
# surrogates(built): the table a run's paper modules offer


def test_surrogates_collects_every_paper_modules_table_in_plugin_order():
    from coopsat.analysis.papers import consensus_2010, deep_space_2008

    def built(*modules):
        return SimpleNamespace(plugins=[SimpleNamespace(analysis=m, role="controller", kind=f"law{k}", origin="tests")
                                        for k, m in enumerate(modules)])

    formation = surrogates(built("coopsat.analysis.papers.deep_space_2008", None))
    assert formation == deep_space_2008.SURROGATES
    both = surrogates(built("coopsat.analysis.papers.consensus_2010", "coopsat.analysis.papers.deep_space_2008",
                            "coopsat.analysis.papers.consensus_2010"))
    assert set(both) == set(consensus_2010.SURROGATES) | set(deep_space_2008.SURROGATES)
    # A paper module without surrogates contributes nothing; no module, no surrogates.
    assert surrogates(built("coopsat.analysis.papers.cartwheel_keeping")) == {}
    assert surrogates(built()) == {}
    for name, s in both.items():
        assert isinstance(s, Surrogate) and s.what, name
        assert s.objective is not None or s.constraint is not None
        assert s.constraint is None or callable(s.constraint)
    assert "settling_time_s" in both and "sync_time_s" in both


def test_spectral_radius_bound_of_a_nilpotent_matrix_is_zero():
    # ρ = 0: some power vanishes (here M² = 0, or M itself), and the bound is 0, not NaN.
    for m in (np.array([[0.0, 1.0], [0.0, 0.0]]), np.zeros((3, 3)), np.eye(4, k=1) * 3.0):
        assert float(spectral_radius_bound(jnp.asarray(m))) == 0.0
    # Next to it, the bound follows ρ = √ε of [[0, 1], [ε, 0]] down.
    for eps in (1e-2, 1e-8, 1e-30):
        m = np.array([[0.0, 1.0], [eps, 0.0]])
        assert float(spectral_radius_bound(jnp.asarray(m))) == pytest.approx(np.sqrt(eps), rel=1e-3)
