"""The native piecewise tick of a pulsed actuator (coopsat.sim.native, rigid_body.py's
segments kernel) against the engine's XLA tick, alone, in a batch and under vmap; and the
sorting network that orders the switch instants."""

from dataclasses import replace

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from coopsat.workflows.pipeline import prepare
from coopsat.scenarios.load import load_scenario
from coopsat.sim.engine import run_samples
from coopsat.sim.engine import simulate_as_built as simulate  # the kernels as built, whatever COOPSAT_NATIVE says
from coopsat.sim.tick import _sorted_rows
from coopsat.sim.native.rigid_body import SEGMENTS_TARGET
from coopsat.sim.system import stack_systems


def pulsed(t_final_s=3.0, seed=None, substeps=1):
    # PWM at a 0.01 s period, one tick a period: most ticks hold a switch (split ticks).
    system = prepare(load_scenario("consensus-sync-a-stable", [f"sim.t_final_s={t_final_s}"])).system
    system = replace(system, structure=replace(system.structure, substeps=substeps))
    if seed is not None:
        w = np.asarray(system.x0.omega_b) + np.random.default_rng(seed).normal(scale=0.05, size=system.x0.omega_b.shape)
        system = replace(system, x0=system.x0._replace(omega_b=jnp.asarray(w)))
    return system


def xla_only(system):
    return replace(system, structure=replace(system.structure, native=False))


def samples(system, **kw):
    return {k: np.asarray(v) for k, v in simulate(system, 3, 1.0, **kw).samples.items()}


def test_piecewise_kernel_is_compiled_in_and_can_be_turned_off():
    system = pulsed()
    hlo = lambda s: jax.jit(run_samples, static_argnums=1).lower(s, 1).as_text()  # noqa: E731
    assert SEGMENTS_TARGET in hlo(system)
    assert SEGMENTS_TARGET not in hlo(xla_only(system))


@pytest.mark.parametrize("substeps", [1, 2])
def test_pulsed_run_matches_xla(substeps):
    # 300 ticks, most cut at the thrusters' switch instants into up to four segments: the two
    # paths differ only in rounding (XLA's rsqrt estimate and FMAs).
    system = pulsed(substeps=substeps)
    native, xla = samples(system), samples(xla_only(system))
    for key in ("q", "omega", "angular_impulse"):
        np.testing.assert_allclose(native[key], xla[key], rtol=0, atol=1e-12, err_msg=key)
    assert np.max(np.abs(native["omega"] - xla["omega"])) > 0  # two paths, not one compiled twice
    # The thrusters did fire inside ticks (a split tick that lost its torque would differ
    # from XLA by ~1e-4 rad/s here).
    assert np.max(np.abs(native["angular_impulse"][-1])) > 1e-3


def test_pulsed_batch_matches_xla_and_each_run_alone():
    # A batch cuts a tick when any of its runs switches inside it, so a run's ticks may be
    # cut at instants that are not its own (extra steps under the same torque): equal to the
    # run alone to rounding, not bit for bit (a campaign's replay re-runs the whole batch).
    runs = [pulsed(seed=k) for k in range(5)]
    batch = samples(stack_systems(runs), batched=True)
    xla = samples(stack_systems([xla_only(r) for r in runs]), batched=True)
    for key in ("q", "omega", "angular_impulse"):
        np.testing.assert_allclose(batch[key], xla[key], rtol=0, atol=1e-12, err_msg=key)
    for k in (0, 4):
        alone = samples(runs[k])
        for key in ("q", "omega", "angular_impulse"):
            np.testing.assert_allclose(batch[key][k], alone[key], rtol=0, atol=1e-12, err_msg=f"run {k} {key}")


def test_pulsed_vmap_over_runs_equals_each_run():
    # Under vmap the kernel receives the runs as a leading dimension of every argument (a
    # wrong run's data there would differ by ~0.1). Not asserted bit for bit: under vmap XLA
    # fuses the law and the pulse arithmetic differently (seen: 1 ulp).
    runs = [pulsed(t_final_s=1.0, seed=k) for k in range(2)]
    batched = jax.vmap(lambda s: run_samples(s, 2))(stack_systems(runs))
    for k, run in enumerate(runs):
        for key in ("q", "omega"):
            np.testing.assert_allclose(np.asarray(batched[key][k]), np.asarray(run_samples(run, 2)[key]), rtol=0,
                                       atol=1e-14, err_msg=key)


@pytest.mark.parametrize("k", [1, 2, 3, 6, 7])
def test_sorted_rows_is_a_sort(k):
    rng = np.random.default_rng(k)
    a = rng.integers(0, 4, size=(k, 50)).astype(float)  # many ties
    a[:, :10] = rng.normal(size=(k, 10))
    np.testing.assert_array_equal(np.asarray(_sorted_rows(jnp.asarray(a))), np.sort(a, axis=0))


def test_gpu_lowering_keeps_the_xla_piecewise_tick():
    # No GPU here: lower a pulsed run for CUDA (jax.export needs no device) and check that the
    # CPU-only custom call is not in it, while the CPU lowering has it.
    from jax import export

    from coopsat.sim.native.rigid_body import TARGET

    run = jax.jit(lambda s: run_samples(s, 1))

    def module(platform):
        checks = [export.DisabledSafetyCheck.custom_call(t) for t in (TARGET, SEGMENTS_TARGET)]
        return export.export(run, platforms=(platform,), disabled_checks=checks)(pulsed(t_final_s=1.0)).mlir_module()

    assert SEGMENTS_TARGET in module("cpu")
    assert SEGMENTS_TARGET not in module("cuda")
