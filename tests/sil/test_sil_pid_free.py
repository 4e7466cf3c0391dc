"""Software in the loop with the laws that use no network: free flight (``none``: no reads, no
commands, an empty outbox) and the attitude PID (its integral carried in each process; an
empty outbox on a ring network). Every recorded variable equals ``coopsat run``'s, as
tests/sil/test_sil.py checks for the consensus laws. Each run starts one process per
spacecraft."""

import numpy as np
import pytest

import coopsat
from coopsat.workflows.sil.run import sil

PID = {"kind": "attitude-pid", "period_s": 0.01, "k_p": 1.0, "k_d": 1.0, "k_i": 0.2, "integral_max": 0.05}
"""Sampled-data stable at T = 0.01 s on the consensus formation's inertias (the design check's
spectral radius is asserted below); the clamp is reached within the run."""


def _free(n):
    """rigid-body-free (one torque-free body) for 1 s, with ``n`` spacecraft (the extra ones
    the same body at other attitudes and rates)."""
    s = coopsat.Scenario.load("rigid-body-free").set("sim.t_final_s", 1.0)
    if n == 1:
        return s
    sc = s.model.spacecraft[0].model_dump(exclude_none=True, exclude={"name"})
    more = [{**sc, "q_bi": [0.5, 0.5, 0.5, 0.5]}, {**sc, "omega_b_rad_s": [0.0, 0.3, -0.2]}]
    return s.update({"spacecraft": [sc, *more[: n - 1]]})


def _assert_equal_runs(ours, ref):
    assert set(ours.dataset.data_vars) == set(ref.dataset.data_vars)
    for v in ref.dataset.data_vars:
        np.testing.assert_allclose(ours.dataset[v].values, ref.dataset[v].values, rtol=0, atol=1e-12, err_msg=v)
    assert ours.metrics == ref.metrics


@pytest.mark.parametrize("n", [1, 3])
def test_free_flight_in_sil_equals_the_compiled_loop(n):
    s = _free(n)
    ours, ref = sil(s), coopsat.run(s)
    _assert_equal_runs(ours, ref)
    assert "torque_command" not in ref.dataset  # nothing commanded, nothing recorded by the law


def test_attitude_pid_in_sil_equals_the_compiled_loop():
    """consensus-sync-a-stable's five spacecraft, ring and PWM thrusters, flown by the PID for
    2 s (200 periods). Measured: everything bit for bit but one element of the integral, 3e-18 s
    apart (the same arithmetic compiled alone and inside the loop's fusions)."""
    s = coopsat.Scenario.load("consensus-sync-a-stable").set("sim.t_final_s", 2.0).set("published", []).update(
        {"controller": PID})
    ours, ref = sil(s), coopsat.run(s)
    _assert_equal_runs(ours, ref)
    assert ref.metrics["attitude_pid_spectral_radius"] < 1.0
    integral = ref.dataset["attitude_error_integral"].values
    assert np.abs(integral).max() == PID["integral_max"]  # the anti-windup acted: the state carried
    assert np.abs(ref.dataset["torque_command"].values).max() > 0.0
