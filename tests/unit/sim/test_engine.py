"""Engine mechanics: batching, chunking, recording, non-finite detection."""

import math

import numpy as np
import pytest

from coopsat.workflows.pipeline import prepare, simulate_built
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


# Scenarios that reach every branch of the batch-inner integration: pulsed thrusters (switches
# at different ticks in different runs), impulse bits with LVLH forces on a J2 orbit (a chief
# per run), environment disturbances with their own state and noise, reaction wheels and
# magnetorquers sharing the torque channel, a random delay, and the small-angle model. Each
# case: its horizon, and the field that differs between the three runs of the batch.
# A batch may round differently from a single run in the last bit (XLA fuses it differently);
# outputs that difference ECI positions 7e6 m apart amplify that bit: one ulp of r_eci
# (9.3e-10 m) through the cartwheel LQR's gain (about 6e-5 N/m) moves the force command by
# 5e-14 N, so that output alone is compared at 1e-13 N.
ABS_TOL = {("cartwheel-keeping-ground", "force_command"): 1e-13}
BATCH_CASES = {
    "consensus-sync-b-stable": ("sim.t_final_s=2.0", "spacecraft.0.omega_b_rad_s=[0.0, 0.0, {}]", (0.01, 0.02, 0.03)),
    "cartwheel-keeping-ground": ("sim.t_final_s=200.0", "spacecraft.1.relative.rho_lvlh_m=[{}, 0.0, 0.0]", (1.5, 1.51, 1.52)),
    "deepspace-square-to-line-lmi": ("sim.t_final_s=100.0", "spacecraft.0.r_eci_m=[149597870600.0, -100.0, {}]", (0, 1, 2)),
    "observation-cooperative": ("sim.t_final_s=3.0", "seed={}", (3, 11, 27)),
    "delay-designed": ("sim.t_final_s=2.0", "seed={}", (3, 11, 27)),
    "rigid-body-gravity-gradient": ("sim.t_final_s=20.0", "spacecraft.0.omega_b_rad_s=[0.001, -0.0011, {}]", (0.0, 0.0005, 0.001)),
}


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n.startswith("observation") else n
                                  for n in sorted(BATCH_CASES)])  # observation: 34 s, in CI's second pass
def test_batch_inner_integration_equals_separate_runs(name):
    """Three different runs in one batch give each run's separate result, every recorded
    output (floats to the last few bits)."""
    horizon, field, values = BATCH_CASES[name]
    runs = [_built(name, horizon, field.format(v)) for v in values]
    out = simulate(stack_systems([b.system for b in runs]), runs[0].n_records, runs[0].record_interval_s, batched=True)
    for k, b in enumerate(runs):
        single = simulate(b.system, b.n_records, b.record_interval_s)
        assert out.samples.keys() == single.samples.keys()
        for key, want in single.samples.items():
            got = out.samples[key][k]
            scale = np.max(np.abs(want)) if want.size else 0.0
            tol = ABS_TOL.get((name, key), 1e-12 * max(scale, 1e-3))
            np.testing.assert_allclose(got, want, rtol=0, atol=tol, err_msg=f"{name}: {key}")
    # The runs differ from one another (else the test would prove little).
    assert any(not np.array_equal(out.samples[k][0], out.samples[k][1]) for k in out.samples)


def test_a_batch_run_group_after_group_with_padding_equals_separate_runs(monkeypatch):
    """Five runs in groups of two (the last padded with a copy) give each run's own result."""
    from coopsat.sim import batching

    runs = [_built("consensus-sync-b-stable", "sim.t_final_s=1.0", f"spacecraft.0.omega_b_rad_s=[0.0, 0.0, {w}]")
            for w in (0.01, 0.02, 0.03, 0.04, 0.05)]
    n = runs[0].system.structure.n_spacecraft
    monkeypatch.setattr(batching, "GROUP_SPACECRAFT", 2 * n)
    groups, size = batching._batch_groups(5, n)
    assert groups >= 3 and groups * size > 5  # (4, 2) with two CPU devices
    out = simulate(stack_systems([b.system for b in runs]), runs[0].n_records, runs[0].record_interval_s, batched=True)
    for k, b in enumerate(runs):
        single = simulate(b.system, b.n_records, b.record_interval_s)
        for key, want in single.samples.items():
            assert out.samples[key].shape[0] == 5
            np.testing.assert_allclose(out.samples[key][k], want, rtol=0, atol=1e-12 * max(np.max(np.abs(want)), 1e-3))


@pytest.mark.parametrize("full", [1, 2, 7, 20, 50, 64, 1000])
def test_bucket_sizes_recur_cover_and_pad_at_most_double(full):
    from coopsat.sim.engine import bucket_runs

    sizes = [bucket_runs(n, full) for n in range(1, full + 1)]
    assert all(s >= n for n, s in zip(range(1, full + 1), sizes))
    assert all(s < 2 * n or s == 1 for n, s in zip(range(1, full + 1), sizes))
    assert sizes[-1] == full  # a full batch is not padded
    assert len(set(sizes)) <= math.ceil(np.log2(full)) + 1  # few programs per structure
    assert bucket_runs(full + 3, full) == full + 3  # above the expected size: as it is


def test_padded_batch_gives_each_run_what_the_unpadded_batch_gives():
    """Padding with copies of the last run (bucket) changes no run's result, and the padding
    runs are not returned."""
    runs = [_built("consensus-sync-a", f"spacecraft.1.omega_b_rad_s=[0.5, {w}, 0.0]") for w in (5.0, 4.0, 3.0)]
    batch = stack_systems([b.system for b in runs])
    plain = simulate(batch, runs[0].n_records, runs[0].record_interval_s, batched=True, every_core=False)
    padded = simulate(batch, runs[0].n_records, runs[0].record_interval_s, batched=True, every_core=False, bucket=16)
    assert padded.samples.keys() == plain.samples.keys()
    for k in plain.samples:
        assert padded.samples[k].shape == plain.samples[k].shape  # 3 runs, not 4
        np.testing.assert_allclose(padded.samples[k], plain.samples[k], rtol=0, atol=1e-13)


def test_a_run_is_two_programs_and_the_chunks_take_the_last_sample():
    """One simulate compiles two programs (first sample, chunk: the chunks take the last sample
    too) and a second run of the same structure reuses them. Every sample equals the
    differentiable path's (run_samples: a static count of periods, the last sample compiled on
    its own, as the engine had it), the last one with each actuator's mean output over the one
    period after the end, not over a record interval: with the last sample inside a chunk, at
    a chunk's end, and in a chunk of its own."""
    import jax

    from coopsat.sim import engine

    built = _built("consensus-sync-a", "sim.t_final_s=6.0", "sim.record_interval_s=1.5")  # 4 records of 3 periods
    engine._COMPILED.clear()
    first = simulate(built.system, built.n_records, built.record_interval_s)
    (programs,) = engine._COMPILED.values()
    assert len(programs) == 2 and all(hasattr(p, "cost_analysis") for p in programs)
    again = simulate(built.system, built.n_records, built.record_interval_s)
    assert again.compile_s < first.compile_s and engine._COMPILED[next(iter(engine._COMPILED))] is programs
    for k in first.samples:
        np.testing.assert_array_equal(first.samples[k], again.samples[k])
    reference = jax.jit(engine.run_samples, static_argnums=1)(built.system, built.n_records)
    assert set(reference) == set(first.samples)
    torque = reference["torque"]
    assert not np.allclose(torque[-1], torque[-2])  # the last period's mean differs from the last interval's
    for chunk in (2, 4, 5, 8):  # 5 samples: 2+2+1, 4+1, 5, 5 of 8
        out = simulate(built.system, built.n_records, built.record_interval_s, chunk=chunk)
        for k, v in reference.items():
            assert out.samples[k].shape == v.shape, k
            np.testing.assert_allclose(out.samples[k], v, rtol=0, atol=1e-12, err_msg=f"{k}, chunk {chunk}")
