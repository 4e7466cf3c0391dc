"""The public design API, ``coopsat.design``: lazy names, frozen results with their proof, and
one known answer per function."""

import dataclasses
import importlib
import json
import math
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import coopsat.design as design

PUBLIC = {
    "lqr": "LQRResult",
    "delay_margin": "DelayMargin",
    "certified_delay": "CertifiedBound",
    "design_delay_gain": "DelayGainDesign",
    "formation_lmi": "LMIGain",
    "sampled_data_check": "SampledDataStability",
}


def assert_frozen(result, type_name, field):
    assert type(result).__name__ == type_name
    assert type(result) is getattr(design, type_name)
    assert dataclasses.is_dataclass(result)
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(result, field, None)


def scalar_delay_system(k):
    """``ẋ = −k x(t − τ)``: A0 = 0, one delayed term, one hop."""
    return [[0.0]], [([[-k]], 1)]


# --- the surface -------------------------------------------------------------------------------


def test_all_lists_exactly_the_functions_and_their_results():
    assert sorted(design.__all__) == sorted([*PUBLIC, *PUBLIC.values()])
    for name in design.__all__:
        value = getattr(design, name)
        assert value.__name__ == name
        assert ("Attributes" if isinstance(value, type) else "Returns") in value.__doc__
    for name, result in PUBLIC.items():
        fn = getattr(design, name)
        assert callable(fn) and not isinstance(fn, type)
        assert fn.__annotations__["return"] in (result, getattr(design, result))
        assert getattr(design, result).__dataclass_params__.frozen
    with pytest.raises(AttributeError, match="no attribute 'riccati_lqr'"):
        design.riccati_lqr  # noqa: B018


def test_names_import_from_the_package():
    from coopsat.design import (  # noqa: F401
        CertifiedBound,
        DelayGainDesign,
        DelayMargin,
        LMIGain,
        LQRResult,
        SampledDataStability,
        certified_delay,
        delay_margin,
        design_delay_gain,
        formation_lmi,
        lqr,
        sampled_data_check,
    )

    assert lqr.__module__ == "coopsat.design.riccati"
    assert sampled_data_check.__module__ == "coopsat.design.sampled_data"


def test_a_function_named_like_its_module_stays_the_function():
    # Importing a submodule sets the package attribute of its name: no public name may be a
    # submodule's, so that the attribute stays the function whichever is loaded first.
    import pkgutil

    submodules = {info.name for info in pkgutil.iter_modules(design.__path__)}
    assert not submodules & set(design.__all__)
    for module in submodules:
        importlib.import_module(f"coopsat.design.{module}")
    for name in ("lqr", "delay_margin"):
        assert callable(getattr(design, name))


def test_importing_the_package_loads_neither_scipy_nor_cvxpy():
    probe = textwrap.dedent(
        """
        import json, sys
        import coopsat.design
        bare = sorted({m.split(".")[0] for m in sys.modules} & {"numpy", "scipy", "cvxpy", "jax"})
        from coopsat.design import lqr, delay_margin, sampled_data_check
        lqr(1.0, 1.0, 1.0, 1.0)
        print(json.dumps({"bare": bare, "cvxpy_after_lqr": "cvxpy" in sys.modules}))
        """
    )
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    report = json.loads(out.stdout.strip().splitlines()[-1])
    assert report == {"bare": [], "cvxpy_after_lqr": False}


# --- lqr ---------------------------------------------------------------------------------------


def test_lqr_double_integrator():
    res = design.lqr([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], np.eye(2), [[1.0]])
    np.testing.assert_allclose(res.K, [[1.0, math.sqrt(3.0)]], rtol=1e-13)
    assert res.residual < 1e-14
    assert_frozen(res, "LQRResult", "K")


# --- delays ------------------------------------------------------------------------------------


@pytest.mark.parametrize("k", [0.5, 1.0, 3.0])
def test_delay_margin_of_the_scalar_dde_is_pi_over_2k(k):
    res = design.delay_margin(*scalar_delay_system(k))
    assert res.tau_s == pytest.approx(math.pi / (2.0 * k), rel=1e-12)
    assert res.omega_rad_s == pytest.approx(k, rel=1e-12)
    assert res.stable_without_delay
    assert res.residual < 1e-12  # σ_min of the characteristic matrix at (jω*, τ*), relative
    assert res.root_speed > 0.0  # the root moves into the right half-plane
    assert_frozen(res, "DelayMargin", "tau_s")


def test_delay_margin_of_a_system_unstable_without_delay_is_zero():
    res = design.delay_margin([[0.0]], [([[1.0]], 1)])
    assert res.tau_s == 0.0 and not res.stable_without_delay and math.isnan(res.residual)


def test_certified_delay_is_below_the_exact_margin():
    k = 2.0
    bound = design.certified_delay(*scalar_delay_system(k))
    exact = math.pi / (2.0 * k)
    # 1.3395/k: time-varying delays, any rate (Park et al. 2011), below the constant-delay π/(2k).
    assert 0.6 < bound.value < exact
    assert bound.value == pytest.approx(1.3395 / k, abs=2e-4)
    assert bound.result.certified and bound.result.status == "optimal"
    assert bound.value < bound.upper <= bound.value + 1e-4
    assert_frozen(bound, "CertifiedBound", "value")
    # A decay rate costs delay.
    slower = design.certified_delay(*scalar_delay_system(k), alpha=0.5)
    assert slower.result.alpha == 0.5 and 0.0 < slower.value < bound.value


def test_design_delay_gain_certifies_what_it_returns():
    def system(gain):
        return scalar_delay_system(float(np.ravel(gain)[0]))

    res = design.design_delay_gain(system, [[1.0]], [[0.5, 2.0]], max_evaluations=3, tol=1e-2)
    k = float(res.gain[0, 0])
    assert 0.5 <= k <= 2.0
    assert res.objective == "delay bound" and res.result.certified and res.status == "optimal"
    # Its certificate is below the exact margin of the gain it returns, and at least what the
    # starting gain certifies (h* k is constant for this system: 1.3395).
    assert 0.0 < res.h < math.pi / (2.0 * k)
    assert res.h * k == pytest.approx(1.3395, abs=2e-2)
    assert res.h >= 1.3395 - 2e-2
    assert_frozen(res, "DelayGainDesign", "gain")


# --- formation LMI -----------------------------------------------------------------------------


def test_formation_lmi_on_a_double_integrator():
    a, b, q, r = [[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], np.eye(2), [[1.0]]
    # "trace": the LQR gain, in the paper's sign (u = gain x).
    trace = design.formation_lmi(a, b, q, r, objective="trace")
    np.testing.assert_allclose(trace.gain, -design.lqr(a, b, q, r).K, rtol=1e-5)
    assert trace.result.certified and math.isnan(trace.gamma)
    # "gamma" with X₀ = I: γ² = λ_max of the Riccati solution [[√3, 1], [1, √3]] = 1 + √3.
    best = design.formation_lmi(a, b, q, r)
    assert best.gamma == pytest.approx(math.sqrt(1.0 + math.sqrt(3.0)), rel=1e-6)
    assert best.result.certified and best.closed_loop_eigs.real.max() < 0.0
    assert_frozen(best, "LMIGain", "gain")
    with pytest.raises(ValueError, match="exceeds gamma_max"):
        design.formation_lmi(a, b, q, r, gamma_max=1.0)


# --- sampled data ------------------------------------------------------------------------------


def test_sampled_data_check_of_one_tracking_spacecraft():
    # Per axis ε̇ = ½δω, I δω̇ = −K ε − D δω held over T: trace 2 − KT²/(4I) − DT/I,
    # det 1 − DT/I + KT²/(4I); Jury: stable iff T < 4D/K, T < 2I/D (and det > −1, here always).
    inertia, k_p, k_d, t = 10.0, 1.0, 2.0, 1.0
    res = design.sampled_data_check(inertia * np.eye(3)[None], [[0.0]], t, 0.0, 0.0, k_p=k_p, k_d=k_d)
    trace = 2.0 - k_p * t**2 / (4 * inertia) - k_d * t / inertia
    det = 1.0 - k_d * t / inertia + k_p * t**2 / (4 * inertia)
    assert res.spectral_radius == pytest.approx(np.abs(np.roots([1.0, -trace, det])).max(), rel=1e-12)
    assert res.max_stable_period_s == pytest.approx(min(4 * k_d / k_p, 2 * inertia / k_d), rel=1e-9)  # 8 s
    assert res.stable and res.continuous_max_real < 0.0
    assert_frozen(res, "SampledDataStability", "stable")
    late = design.sampled_data_check(inertia * np.eye(3)[None], [[0.0]], 9.0, 0.0, 0.0, k_p=k_p, k_d=k_d)
    assert not late.stable and late.spectral_radius > 1.0
