"""Engine mechanics: batching, chunking, recording, non-finite detection."""

import numpy as np
import pytest

from coopsat.pipeline import prepare, simulate_built
from coopsat.scenarios.load import load_scenario
from coopsat.sim.engine import NonFiniteStateError, simulate
from coopsat.sim.system import stack_systems


def _built(name="consensus-sync-a", *extra):
    return prepare(load_scenario(name, ["sim.t_final_s=5.0", *extra]))


def test_chunked_run_equals_one_call():
    built = _built()
    whole = simulate(built.system, built.n_records, built.record_interval_s)
    chunked = simulate(built.system, built.n_records, built.record_interval_s, chunk=3)  # 10 records: 3+3+3+1(pad 2)
    assert whole.samples.keys() == chunked.samples.keys()
    for k in whole.samples:
        np.testing.assert_array_equal(whole.samples[k], chunked.samples[k])


def test_vmap_batch_equals_separate_runs():
    runs = [_built("consensus-sync-a", f"spacecraft.1.omega_b_rad_s=[0.5, {w}, 0.0]") for w in (5.0, 4.0, 3.0)]
    batch = stack_systems([b.system for b in runs])
    out = simulate(batch, runs[0].n_records, runs[0].record_interval_s, batched=True)
    for k, b in enumerate(runs):
        single = simulate(b.system, b.n_records, b.record_interval_s)
        for key in single.samples:
            np.testing.assert_allclose(out.samples[key][k], single.samples[key], rtol=0, atol=1e-13)


def test_stack_refuses_mixed_structures():
    with pytest.raises(ValueError, match="structure"):
        stack_systems([_built().system, _built("consensus-sync-a-stable").system])


def test_samples_have_interface_layout_and_both_ends():
    built = _built()
    ds, _ = simulate_built(built)
    assert ds.q.dims == ("time", "spacecraft", "q_component")
    assert ds.omega.dims == ds.torque.dims == ("time", "spacecraft", "component")
    assert ds.time.values[0] == 0.0 and ds.time.values[-1] == 5.0 and len(ds.time) == 11
    np.testing.assert_allclose(np.linalg.norm(ds.q.values, axis=-1), 1.0, atol=1e-14)
    # The first sample is the initial state as given (normalised).
    q0 = np.array([0.75, 0.57, 0.30, -0.03])
    np.testing.assert_allclose(ds.q.values[0, 0], q0 / np.linalg.norm(q0), atol=1e-15)
    # PWM: mean applied torque never exceeds T_max; on-time accumulates monotonically.
    assert np.abs(ds.torque.values).max() <= 0.05 + 1e-15
    assert np.all(np.diff(ds.thruster_on_time.values, axis=0) >= 0)


def test_impulse_equals_integral_of_applied_torque():
    built = _built("consensus-sync-a", "sim.record_interval_s=0.5")
    ds, _ = simulate_built(built)
    # One sample per control period: the recorded mean torque times T sums to the impulse.
    impulse_from_torque = np.cumsum(np.abs(ds.torque.values[:-1]) * 0.5, axis=0)
    np.testing.assert_allclose(ds.impulse.values[1:], impulse_from_torque, atol=1e-12)
    on_time_total = ds.thruster_on_time.values[-1].sum(axis=-1)
    np.testing.assert_allclose(ds.impulse.values[-1].sum(axis=-1), 0.05 * on_time_total, rtol=1e-12)


def test_non_finite_state_is_reported_with_time_and_spacecraft():
    overrides = [
        "actuators.kind=ideal-torque", "controller.alpha=1e6", "controller.beta=1e6", "controller.period_s=0.1",
        "sim.dt_s=0.1", "sim.record_interval_s=0.1", "sim.t_final_s=50.0",
    ]
    built = prepare(load_scenario("consensus-sync-a", overrides))
    with pytest.raises(NonFiniteStateError, match=r"non-finite: .* spacecraft index \d at t = "):
        simulate(built.system, built.n_records, built.record_interval_s)
