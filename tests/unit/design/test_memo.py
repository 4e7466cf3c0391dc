"""Design results solved once per exact input (coopsat.design.memo)."""

import numpy as np
import pytest

from coopsat.core import runtime
from coopsat.design import memo
from coopsat.design.memo import by_value


@pytest.fixture(autouse=True)
def private_disk(tmp_path, monkeypatch):
    """Each test its own persistent cache (the suite's outlives a session: a result kept by
    the last session would not be solved at all)."""
    monkeypatch.setattr(runtime, "persistent_cache_dir", lambda kind: tmp_path / f"coopsat-{kind}")
    return tmp_path / "coopsat-design"


def _counted():
    calls = []

    @by_value
    def solve(a, terms, h=1.0):
        calls.append(1)
        if h < 0:
            raise ValueError("negative h")
        return {"p": a @ a.T + h, "n": len(terms)}

    return solve, calls


def test_same_input_is_solved_once_and_gives_the_same_result():
    solve, calls = _counted()
    a = np.arange(4.0).reshape(2, 2)
    first = solve(a, [(a, 1.0)], h=2.0)
    second = solve(a.copy(), [(a.copy(), 1.0)], h=2.0)  # equal values, other objects
    assert len(calls) == 1
    np.testing.assert_array_equal(first["p"], second["p"])


def test_one_ulp_in_any_input_is_a_new_problem():
    solve, calls = _counted()
    a = np.arange(4.0).reshape(2, 2)
    solve(a, [(a, 1.0)])
    b = a.copy()
    b[1, 1] = np.nextafter(b[1, 1], np.inf)
    solve(b, [(a, 1.0)])
    solve(a, [(a, np.nextafter(1.0, 2.0))])
    solve(a, [(a, 1.0)], h=np.nextafter(1.0, 2.0))
    solve(a.astype(np.float32), [(a, 1.0)])
    assert len(calls) == 5


def test_a_caller_changing_its_result_does_not_change_the_next_callers():
    solve, _ = _counted()
    a = np.eye(2)
    solve(a, [])["p"][:] = -7.0
    np.testing.assert_array_equal(solve(a, [])["p"], np.eye(2) + 1.0)


def test_errors_are_raised_every_time_not_stored():
    solve, calls = _counted()
    for _ in range(2):
        with pytest.raises(ValueError, match="negative h"):
            solve(np.eye(2), [], h=-1.0)
    assert len(calls) == 2


def test_the_delay_lmi_bisection_is_shared_between_equal_calls():
    """A campaign's runs certify the same delay bound: the second call is the stored answer,
    equal to a fresh solve."""
    from coopsat.design import delay_bounds

    a0, terms = np.array([[0.0, 1.0], [0.0, 0.0]]), [(np.array([[0.0, 0.0], [-1.0, -1.5]]), 1.0)]
    delay_bounds.max_decay_rate.cache.clear()
    first = delay_bounds.max_decay_rate(a0, terms, 0.2)
    assert len(delay_bounds.max_decay_rate.cache) == 1
    again = delay_bounds.max_decay_rate(a0, terms, 0.2)
    assert len(delay_bounds.max_decay_rate.cache) == 1
    fresh = delay_bounds.max_decay_rate.__wrapped__(a0, terms, 0.2)
    assert first.value == again.value == fresh.value > 0.0


def test_a_new_process_takes_the_result_from_disk_without_solving(private_disk):
    solve, calls = _counted()
    a = np.arange(4.0).reshape(2, 2)
    first = solve(a, [(a, 1.0)], h=2.0)
    assert len(list(private_disk.glob("*.pickle"))) == 1
    solve.cache.clear()  # what a new process starts with
    again = solve(a, [(a, 1.0)], h=2.0)
    assert len(calls) == 1
    np.testing.assert_array_equal(first["p"], again["p"])
    solve(a, [(a, 1.0)], h=3.0)
    assert len(calls) == 2 and len(list(private_disk.glob("*.pickle"))) == 2


def test_a_damaged_file_is_solved_again(private_disk):
    solve, calls = _counted()
    a = np.eye(2)
    solve(a, [])
    (path,) = private_disk.glob("*.pickle")
    path.write_bytes(b"not a pickle")
    solve.cache.clear()
    np.testing.assert_array_equal(solve(a, [])["p"], np.eye(2) + 1.0)
    assert len(calls) == 2


def test_another_coopsat_source_is_another_key(private_disk, monkeypatch):
    solve, calls = _counted()
    solve(np.eye(2), [])
    solve.cache.clear()
    monkeypatch.setattr(memo, "_install_digest", lambda: "edited source")
    solve(np.eye(2), [])
    assert len(calls) == 2


def test_without_a_persistent_cache_nothing_is_written(tmp_path, monkeypatch):
    monkeypatch.setattr(runtime, "persistent_cache_dir", lambda kind: None)
    solve, calls = _counted()
    solve(np.eye(2), [])
    solve.cache.clear()
    solve(np.eye(2), [])
    assert len(calls) == 2 and not list(tmp_path.rglob("*.pickle"))


def test_a_result_that_cannot_be_pickled_is_still_returned(private_disk):
    @by_value
    def solve(a):
        return {"f": lambda: a}  # a lambda cannot be pickled

    assert solve(np.eye(2))["f"]() is not None
    assert not list(private_disk.glob("*.pickle"))
