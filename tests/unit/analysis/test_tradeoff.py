"""Pareto fronts and matched-settling-time comparison (SPEC §4) against hand cases."""

import math

import numpy as np
import pytest

from coopsat.analysis.tradeoff import fuel_on_front, matched_saving, pareto_front


def test_front_keeps_only_non_dominated_runs_in_settling_order():
    settle = [100.0, 200.0, 150.0, 300.0, 120.0, math.nan]
    fuel = [10.0, 5.0, 12.0, 6.0, 8.0, 1.0]
    # 150 s/12 is beaten by 120 s/8; 300 s/6 by 200 s/5; the NaN run never settled.
    np.testing.assert_array_equal(pareto_front(settle, fuel), [0, 4, 1])


def test_fuel_on_front_interpolates_inside_and_is_nan_outside():
    settle, fuel = [100.0, 200.0, 300.0], [30.0, 20.0, 15.0]
    got = fuel_on_front(settle, fuel, [50.0, 150.0, 250.0, 350.0])
    assert math.isnan(got[0]) and math.isnan(got[3])
    np.testing.assert_allclose(got[1:3], [25.0, 17.5])


def test_matched_saving_on_the_overlap_only():
    # A spends 10 % less than B at every settling time where both reach.
    sa, fa = [100.0, 200.0, 300.0], [90.0, 45.0, 30.0]
    sb, fb = [150.0, 200.0, 400.0], [60.0, 50.0, 25.0]
    m = matched_saving(sa, fa, sb, fb, n_points=4)  # 150, 200, 250, 300 s
    assert m["overlap_s"] == (150.0, 300.0)
    assert m["settle_s"][0] == 150.0 and m["settle_s"][-1] == 300.0
    np.testing.assert_allclose(m["saving_percent"][m["settle_s"] == 200.0], [10.0])
    expected = 100.0 * (np.interp(m["settle_s"], sb, fb) - np.interp(m["settle_s"], sa, fa)) / np.interp(m["settle_s"], sb, fb)
    np.testing.assert_allclose(m["saving_percent"], expected)


def test_no_overlap_gives_no_comparison():
    m = matched_saving([100.0, 200.0], [2.0, 1.0], [300.0, 400.0], [2.0, 1.0])
    assert m["overlap_s"] is None and m["saving_percent"].size == 0


# --- the rest-to-rest fuel bound ---------------------------------------------------------------

M_KG, F_N = 700.0, 0.1


def test_rest_to_rest_fuel_meets_its_two_limits():
    from coopsat.analysis.tradeoff import rest_to_rest_fuel_ns

    d = 200.0
    t_bang = 2.0 * np.sqrt(M_KG * d / F_N)  # bang-bang: accelerate half the way, brake the other
    assert rest_to_rest_fuel_ns(d, t_bang, M_KG, F_N) == pytest.approx(F_N * t_bang, rel=1e-12)
    assert rest_to_rest_fuel_ns(d, 0.999 * t_bang, M_KG, F_N) == np.inf
    # A long time: an impulse 2·m·D/T (start and stop) to first order.
    assert rest_to_rest_fuel_ns(d, 1e8, M_KG, F_N) == pytest.approx(2.0 * M_KG * d / 1e8, rel=1e-9)


def test_rest_to_rest_fuel_is_what_a_bang_coast_bang_profile_spends():
    from coopsat.analysis.tradeoff import rest_to_rest_fuel_ns

    d, t = 150.0, 5000.0
    fuel = float(rest_to_rest_fuel_ns(d, t, M_KG, F_N))
    t_burn = fuel / (2.0 * F_N)  # each end burns F for t_burn
    # Integrate the profile: +F for t_burn, coast, −F for t_burn; it must arrive at rest at d.
    ts = np.linspace(0.0, t, 2_000_001)
    a = np.where(ts < t_burn, F_N, np.where(ts > t - t_burn, -F_N, 0.0)) / M_KG
    from scipy.integrate import cumulative_trapezoid

    v = cumulative_trapezoid(a, ts, initial=0.0)
    x = cumulative_trapezoid(v, ts, initial=0.0)
    assert abs(v[-1]) < 1e-7 and x[-1] == pytest.approx(d, rel=1e-5)


def test_the_formation_bound_takes_the_free_translation():
    from coopsat.analysis.tradeoff import formation_fuel_bound_ns, rest_to_rest_fuel_ns

    # Two spacecraft that must both move +100 m in x: a translation of the whole formation,
    # which costs nothing (the formation error ignores it).
    assert formation_fuel_bound_ns(np.array([[100.0, 0.0], [100.0, 0.0]]), 4000.0, M_KG, F_N) == pytest.approx(0.0, abs=1e-9)
    # Moving apart by 200 m: each moves 100 m whatever the translation (convex, symmetric).
    apart = formation_fuel_bound_ns(np.array([[100.0, 0.0], [-100.0, 0.0]]), 4000.0, M_KG, F_N)
    assert apart == pytest.approx(2.0 * float(rest_to_rest_fuel_ns(100.0, 4000.0, M_KG, F_N)), rel=1e-6)
    # A tolerance shortens each move by itself.
    tol = formation_fuel_bound_ns(np.array([[100.0, 0.0], [-100.0, 0.0]]), 4000.0, M_KG, F_N, tolerance_m=5.0)
    assert tol == pytest.approx(2.0 * float(rest_to_rest_fuel_ns(95.0, 4000.0, M_KG, F_N)), rel=1e-6)
