"""Pareto fronts and matched-settling-time comparison (SPEC §4) against hand cases."""

import math

import numpy as np

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
