"""The attitude PID's and the free flight's per-spacecraft forms (what software in the loop runs
in each flight software process) against their formation-wide steps (what the compiled loop
runs)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from coopsat.control.free import NoControl
from coopsat.control.pid import AttitudePid, LvlhPd
from coopsat.network.delivery import Inbox
from coopsat.sim.flight_software import as_flight_software
from coopsat.sim.system import as_arrays
from per_spacecraft import OneByOne

N = 4


def _pid(integral_max):
    q_target = np.array([0.5, 0.5, -0.5, 0.5])
    return AttitudePid(*as_arrays((2.0, 3.0, 0.7, q_target, 0.1, integral_max)))


def _measurements(rng):
    """Random attitudes (both hemispheres) and rates of N spacecraft, component-major."""
    q = rng.normal(size=(4, N))
    return {"q": jnp.asarray(q / np.linalg.norm(q, axis=0)), "omega": jnp.asarray(rng.normal(size=(3, N)))}


def _ring_inbox():
    """A ring's links with nothing on them (neither law reads its inbox)."""
    dst = np.roll(np.arange(N), 1)
    return Inbox({}, jnp.ones(N), jnp.asarray(dst), {})


@pytest.mark.parametrize("jit", [False, True])
def test_pid_per_spacecraft_form_equals_the_formation_step(jit):
    """Eight periods with the integral carried, the clamp reached on some components: the
    torque, the integral and the record bit for bit (the same elementwise operations)."""
    law = _pid(integral_max=0.12)
    one = as_flight_software(OneByOne(law), N)
    whole_step, split_step = (jax.jit(f) if jit else f for f in (law.step, one.step))
    rng, key, inbox = np.random.default_rng(5), jax.random.PRNGKey(0), _ring_inbox()
    s_whole = s_split = law.init(N)
    assert law.outbox(_measurements(rng), s_whole) == one.outbox(_measurements(rng), s_split) == {}
    for k in range(8):
        y = _measurements(rng)
        (c_whole, s_whole, r_whole) = whole_step(0.1 * k, y, inbox, s_whole, key)
        (c_split, s_split, r_split) = split_step(0.1 * k, y, inbox, s_split, key)
        assert np.shape(c_split["torque_b"]) == (3, N)
        np.testing.assert_array_equal(np.asarray(c_split["torque_b"]), np.asarray(c_whole["torque_b"]))
        np.testing.assert_array_equal(np.asarray(s_split), np.asarray(s_whole))
        assert set(r_split) == set(r_whole) == {"torque_command", "attitude_error_integral"}
        for v in r_whole:
            np.testing.assert_array_equal(np.asarray(r_split[v]), np.asarray(r_whole[v]), err_msg=v)
    clamped = np.abs(np.asarray(s_whole)) == 0.12
    assert clamped.any() and not clamped.all()  # the anti-windup acted, and not everywhere
    assert np.any(np.asarray(law.k_i) * np.asarray(s_whole) != 0.0)  # the integral term enters


def test_no_control_per_spacecraft_form_is_empty():
    law = NoControl()
    assert law.reads == ()
    one = as_flight_software(OneByOne(law), N)
    y = _measurements(np.random.default_rng(1))
    assert law.outbox_one(0, {}, ()) == {} and one.outbox({}, law.init(N)) == {}
    assert law.step_one(2, 0.0, {}, _ring_inbox(), (), jax.random.PRNGKey(0)) == ({}, (), {})
    assert one.step(0.0, y, _ring_inbox(), law.init(N), jax.random.PRNGKey(0)) == ({}, (), {})


@pytest.mark.parametrize("jit", [False, True])
def test_lvlh_pd_per_spacecraft_form_equals_the_formation_step(jit):
    """On a measured relative state ``x_lvlh`` (a sensor's or a filter's), spacecraft by
    spacecraft, before and after ``start_s``: the force and the record bit for bit; the chief
    (spacecraft 0) commands nothing."""
    rng = np.random.default_rng(3)
    targets = rng.normal(size=(3, N)) * 50.0
    targets[:, 0] = 0.0
    law = LvlhPd(*as_arrays((2e-3, 0.25, targets, 10.0)))
    one = as_flight_software(OneByOne(law), N)
    whole_step, split_step = (jax.jit(f) if jit else f for f in (law.step, one.step))
    assert law.reads == ("x_lvlh",) and law.outbox({}, ()) == {}
    for t in (0.0, 10.0, 25.0):
        y = {"x_lvlh": jnp.asarray(rng.normal(size=(6, N)) * np.array([100.0] * 3 + [0.1] * 3)[:, None])}
        c_whole, _, r_whole = whole_step(t, y, _ring_inbox(), (), jax.random.PRNGKey(0))
        c_split, _, r_split = split_step(t, y, _ring_inbox(), (), jax.random.PRNGKey(0))
        force = np.asarray(c_whole["force_lvlh"])
        assert np.all(force[:, 0] == 0.0) and (np.any(force != 0.0) == (t >= 10.0))
        np.testing.assert_array_equal(np.asarray(c_split["force_lvlh"]), force)
        for v in r_whole:
            np.testing.assert_array_equal(np.asarray(r_split[v]), np.asarray(r_whole[v]), err_msg=v)
