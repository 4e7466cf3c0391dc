"""The gain search's progress callback (issue 26): it hears every gain scored, in order, with
the best certified gain so far, and it only observes: the design is the same bit for bit."""

import numpy as np

from coopsat.design.delay_gain import BestGain, design_gain


def scalar_delay_system(k):
    """``ẋ = −k x(t − d(t))``: A0 = 0, one delayed term, one hop (certified for k·h below 3/2
    at most, Myshkis)."""
    return np.zeros((1, 1)), [(-np.asarray(k, dtype=float).reshape(1, 1), 1)]


def _search(h, progress=None, starts=()):
    return design_gain(scalar_delay_system, h, [[1.0]], [(0.2, 3.0)], starts=starts, max_evaluations=6, tol=1e-2,
                       progress=progress)


def _same(a, b):
    assert np.array_equal(a.gain, b.gain) and a.h == b.h and a.alpha == b.alpha
    assert a.n_evaluations == b.n_evaluations and a.result.relative_margins == b.result.relative_margins


def test_progress_counts_each_gain_once_in_order_and_changes_nothing():
    reports = []
    observed = _search(None, lambda *report: reports.append(report))
    _same(observed, _search(None))
    stages, done, totals, bests = zip(*reports)
    assert set(stages) == {"gain search"} and set(totals) == {6}
    # The stage is announced at 0, then one report per gain newly scored.
    assert list(done) == list(range(observed.n_evaluations + 1))
    assert bests[0] is None and all(isinstance(b, BestGain) for b in bests[1:])
    values = [b.value for b in bests[1:]]
    assert values == sorted(values) and values[0] > 0.0  # h*(K), s: only ever improves
    assert values[-1] == observed.h and np.array_equal(bests[-1].gain, observed.gain)


def test_at_a_given_h_the_best_is_the_decay_rate_and_each_start_is_a_stage():
    reports = []
    observed = _search(0.5, lambda *report: reports.append(report), starts=[[[2.0]]])
    _same(observed, _search(0.5, starts=[[[2.0]]]))
    # Six gains: the first start converges after five, the second gets the last one.
    assert list(dict.fromkeys(r[0] for r in reports)) == ["gain search from start 1/2", "gain search from start 2/2"]
    done = [r[1] for r in reports]
    assert done == sorted(done) and done[-1] == observed.n_evaluations == 6
    assert reports[-1][3].value == observed.alpha > 0.0  # α*(K) at h, 1/s
