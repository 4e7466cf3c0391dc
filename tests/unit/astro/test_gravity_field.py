"""The gravity field to degree and order 70: EGM2008's shipped coefficients, Pines' acceleration
against brahe 1.8's Clenshaw evaluation and against the gradient of an independently written
potential, the J2 limit, the poles, shapes, and bad degrees."""

import brahe as bh
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from coopsat.astro.gravity_field import MAX_DEGREE, egm2008, harmonic_accel_ecef, harmonic_potential
from coopsat.dynamics.translational import j2_accel

R_LOW = 6378137.0 + 500e3
_ACCEL = jax.jit(harmonic_accel_ecef)
_BATCH = 16


def _accel(points, f):
    """Our acceleration (count, 3), m/s², at each of ``points`` (count ≤ 16, 3), compiled.

    The points are padded to a batch of 16, so that each degree is one program for the whole
    module: the degree-70 field evaluated op by op took a minute a test (hundreds of small
    programs, one per array shape) and grew the worker by 0.8 GB."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    padded = np.concatenate([points, np.repeat(points[:1], _BATCH - len(points), axis=0)])
    return np.asarray(_ACCEL(padded, f.c, f.s, f.gm_m3_s2, f.radius_m))[: len(points)]


def _points(count, seed=0):
    rng = np.random.default_rng(seed)
    u = rng.normal(size=(count, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    radius = rng.uniform(6378137.0 + 150e3, 6378137.0 + 36000e3, size=(count, 1))
    return u * radius


@pytest.fixture(scope="module")
def brahe_model():
    return bh.GravityModel.from_model_type(bh.GravityModelType.EGM2008_120)


def test_shipped_coefficients_are_egm2008(brahe_model):
    # Pavlis et al. (2012), EGM2008 tide-free: C̄20, C̄22, S̄22, C̄30 as published.
    f = egm2008(70)
    assert f.c[2, 0] == -0.484165143790815e-3
    assert (f.c[2, 2], f.s[2, 2]) == (0.243938357328313e-5, -0.140027370385934e-5)
    assert f.c[3, 0] == 0.957161207093473e-6
    assert (f.gm_m3_s2, f.radius_m) == (brahe_model.gm, brahe_model.radius)
    n, m = 70, 37
    assert (f.c[n, m], f.s[n, m]) == brahe_model.get(n, m)


@pytest.mark.parametrize("degree", [2, 8, 20, MAX_DEGREE])
def test_acceleration_matches_brahe(brahe_model, degree):
    f = egm2008(degree)
    points = _points(12, seed=degree)
    for r, ours in zip(points, _accel(points, f)):
        # brahe returns the whole field: take its point mass away.
        ref = brahe_model.compute_spherical_harmonics(r, degree, degree) + f.gm_m3_s2 * r / np.linalg.norm(r) ** 3
        # Taking the point mass (10³ … 10⁴ times the rest) away leaves the whole field's rounding.
        assert np.linalg.norm(ours - ref) <= 1e-14 * f.gm_m3_s2 / np.dot(r, r)


def test_order_below_degree_matches_brahe(brahe_model):
    f = egm2008(12, 4)
    r = _points(1, seed=3)[0]
    ours = _accel(r, f)[0]
    ref = brahe_model.compute_spherical_harmonics(r, 12, 4) + f.gm_m3_s2 * r / np.linalg.norm(r) ** 3
    assert np.linalg.norm(ours - ref) <= 1e-14 * f.gm_m3_s2 / np.dot(r, r)
    # …and the orders above 4 are really left out: the full 12×12 differs by far more.
    full = _accel(r, egm2008(12))[0]
    assert np.linalg.norm(full - ours) >= 1e3 * np.linalg.norm(ours - ref)


@pytest.mark.parametrize("degree", [4, 10])
def test_acceleration_is_the_gradient_of_the_classical_potential(degree):
    # harmonic_potential sums P̄_nm(sin φ)(C̄ cos mλ + S̄ sin mλ): another formulation, differentiated by JAX.
    f = egm2008(degree)
    r = _points(6, seed=10 + degree)
    grad = jax.jit(jax.vmap(jax.grad(lambda x: harmonic_potential(x, f.c, f.s, f.gm_m3_s2, f.radius_m))))(jnp.asarray(r))
    ours = _accel(r, f)
    assert (np.linalg.norm(ours - grad, axis=1) <= 1e-12 * np.linalg.norm(grad, axis=1)).all()


def test_zonal_degree_two_is_j2():
    f = egm2008(2, 0)
    j2 = -np.sqrt(5.0) * f.c[2, 0]  # unnormalised J2 = −√5 C̄20
    points = _points(5, seed=4)
    for r, ours in zip(points, _accel(points, f)):
        np.testing.assert_allclose(ours, j2_accel(r, f.gm_m3_s2, j2, f.radius_m), rtol=1e-12, atol=1e-18)


def test_finite_over_the_poles_and_on_the_equator():
    f = egm2008(MAX_DEGREE)
    points = np.array([[0.0, 0.0, R_LOW], [0.0, 0.0, -R_LOW], [1e-9, 0.0, R_LOW], [R_LOW, 0.0, 0.0]])
    a = _accel(points, f)
    assert np.isfinite(a).all()
    # Next to the pole the field is continuous: 1e-9 m off it changes nothing visible.
    np.testing.assert_allclose(a[2], a[0], rtol=1e-9)


def test_component_major_batches_and_jit():
    f = egm2008(10)
    r = _points(6, seed=5)  # (6, 3)
    expected = _accel(r, f)  # the interface's point-major layout
    fn = jax.jit(lambda x: harmonic_accel_ecef(x, f.c, f.s, f.gm_m3_s2, f.radius_m, axis=0))
    np.testing.assert_allclose(fn(r.T), expected.T, rtol=1e-14)
    batch = r.T.reshape(3, 2, 3)  # (3, B, n)
    np.testing.assert_allclose(fn(batch), expected.T.reshape(3, 2, 3), rtol=1e-14)


@pytest.mark.parametrize("degree, order, field", [(71, None, "degree 71"), (1, None, "degree 1"), (10, 11, "order 11")])
def test_bad_degree_or_order_is_named(degree, order, field):
    with pytest.raises(ValueError, match=field):
        egm2008(degree, order)
