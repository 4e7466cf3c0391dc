"""The native rigid-body tick (coopsat.sim.native) against the engine's XLA tick, invariants
of the free rigid body, and the properties the engine relies on: a run's result does not
depend on the batch it is in, vmap, derivatives."""

from dataclasses import replace

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from coopsat.sim.synthetic import bench_system
from coopsat.sim.engine import run_samples
from coopsat.sim.engine import simulate_as_built as simulate  # the kernels as built, whatever COOPSAT_NATIVE says
from coopsat.sim.native.consensus import TARGET as LAW_TARGET
from coopsat.sim.native.rigid_body import TARGET
from coopsat.sim.system import stack_systems


def xla_only(system):
    return replace(system, structure=replace(system.structure, native=False))


def samples(system, n_records=2, interval_s=2.0, **kw):
    return {k: np.asarray(v) for k, v in simulate(system, n_records, interval_s, **kw).samples.items()}


def hlo(system):
    return jax.jit(run_samples, static_argnums=1).lower(system, 1).as_text()


def test_native_tick_is_compiled_in_and_can_be_turned_off():
    system = bench_system(7, "consensus-sync", record_ticks=100)
    assert TARGET in hlo(system)
    assert TARGET not in hlo(xla_only(system))


@pytest.mark.parametrize("substeps", [1, 3])
def test_native_consensus_run_matches_xla(substeps):
    # 400 ticks of law (3) on a ring of 50 with saturating torques: the two paths differ only
    # in rounding (XLA's rsqrt estimate and FMAs), a few ulps a tick.
    system = bench_system(50, "consensus-sync", record_ticks=200)
    system = replace(system, structure=replace(system.structure, substeps=substeps))
    native, xla = samples(system), samples(xla_only(system))
    for key in ("q", "omega", "torque_command"):
        np.testing.assert_allclose(native[key], xla[key], rtol=0, atol=1e-13, err_msg=key)
    assert np.max(np.abs(native["q"] - xla["q"])) > 0  # two paths, not one compiled twice


def test_native_tick_keeps_held_wheel_momentum():
    # A wheel momentum that no actuator drives stays constant but still enters the
    # gyroscopic term: the kernel must read it (a dropped h_w changes ω by ~1e-3 here).
    system = bench_system(9, "none", record_ticks=200)
    h_w = np.random.default_rng(3).normal(scale=0.05, size=(9, 3))
    system = replace(system, x0=system.x0._replace(h_wheels_b=jnp.asarray(h_w)))
    native, xla = samples(system), samples(xla_only(system))
    np.testing.assert_allclose(native["omega"], xla["omega"], rtol=0, atol=1e-14)
    without = samples(replace(system, x0=system.x0._replace(h_wheels_b=jnp.zeros((9, 3)))))
    assert np.max(np.abs(without["omega"] - native["omega"])) > 1e-4


def test_free_body_conserves_energy_and_momentum():
    # Torque-free: rotational energy and |I ω| are invariants; RK4 at h = 0.01 s with
    # |ω| ~ 0.1 rad/s keeps them to ~1e-13 over 1000 ticks.
    system = bench_system(40, "none", record_ticks=500)
    out = samples(system, n_records=2, interval_s=5.0)
    inertia = np.asarray(system.plant.inertia_kgm2)
    w = out["omega"]
    energy = 0.5 * np.sum(inertia * w**2, axis=-1)
    momentum = np.linalg.norm(inertia * w, axis=-1)
    np.testing.assert_allclose(energy[-1], energy[0], rtol=1e-11)
    np.testing.assert_allclose(momentum[-1], momentum[0], rtol=1e-11)
    np.testing.assert_allclose(np.linalg.norm(out["q"], axis=-1), 1.0, rtol=0, atol=4e-16)


def test_run_in_a_batch_equals_run_alone_bit_for_bit():
    # The kernel is per spacecraft, so the batch around a run (and how it is split between
    # devices) cannot change it: not a tolerance, equality.
    runs = [bench_system(5, "consensus-sync", record_ticks=100, seed=k) for k in range(13)]
    batch = samples(stack_systems(runs), batched=True)
    for k in (0, 6, 12):
        alone = samples(runs[k])
        for key in ("q", "omega", "torque_command"):
            np.testing.assert_array_equal(batch[key][k], alone[key], err_msg=f"run {k} {key}")


def test_vmap_over_runs_equals_each_run():
    # Under vmap the kernel receives the runs as a leading dimension.
    runs = [bench_system(6, "consensus-sync", record_ticks=50, seed=k) for k in range(3)]
    batched = jax.vmap(lambda s: run_samples(s, 2))(stack_systems(runs))
    for k, run in enumerate(runs):
        alone = run_samples(run, 2)
        np.testing.assert_array_equal(np.asarray(batched["q"][k]), np.asarray(alone["q"]))


@pytest.mark.slow  # long: runs in CI's second pytest pass (README)
def test_gradient_through_native_tick_is_xla_gradient():
    # Derivatives come from the XLA tick (custom_jvp): d(final attitude)/d(gain, inertia).
    system = bench_system(6, "consensus-sync", record_ticks=50)

    def final_q(alpha, inertia, s):
        s = replace(s, controller=replace(s.controller, alpha=alpha),
                    plant=s.plant._replace(inertia_kgm2=inertia, inertia_inv=1.0 / inertia))
        return jnp.sum(run_samples(s, 2)["q"][-1] * jnp.arange(4.0))

    args = (jnp.asarray(system.controller.alpha), jnp.asarray(system.plant.inertia_kgm2))
    native = jax.grad(final_q, argnums=(0, 1))(*args, system)
    xla = jax.grad(final_q, argnums=(0, 1))(*args, xla_only(system))
    for a, b in zip(native, xla):
        assert np.all(np.isfinite(np.asarray(a))) and np.max(np.abs(np.asarray(b))) > 0
        np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-9, atol=1e-14)


def test_gpu_lowering_keeps_the_xla_tick():
    # No GPU here: lower the same run for CUDA (jax.export needs no device) and check that the
    # CPU-only custom call is not in it, while the CPU lowering has it.
    from jax import export

    system = bench_system(200, "consensus-sync", record_ticks=100)  # large enough for the law kernel
    run = jax.jit(lambda s: run_samples(s, 1))

    def module(platform):
        checks = [export.DisabledSafetyCheck.custom_call(t) for t in (TARGET, LAW_TARGET)]
        return export.export(run, platforms=(platform,), disabled_checks=checks)(system).mlir_module()

    cpu, cuda = module("cpu"), module("cuda")
    assert TARGET in cpu and LAW_TARGET in cpu
    assert TARGET not in cuda and LAW_TARGET not in cuda
