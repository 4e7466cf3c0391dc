"""Relative navigation (SPEC §2): each spacecraft's state relative to the chief, in the chief's
LVLH frame, with seeded noise per axis; the chief's own column exactly zero; and spacecraft
placed relative to another in its LVLH frame (``[spacecraft.relative]``)."""

import jax
import numpy as np
import pytest

from coopsat.astro.constants import MU_EARTH_M3_S2
from coopsat.astro.kepler import elements_to_rv
from coopsat.dynamics.plant import PlantState
from coopsat.geometry.frames import eci_to_lvlh
from coopsat.workflows.pipeline import prepare
from coopsat.scenarios.load import ScenarioError, load_scenario
from coopsat.sensors.parts import RelativeNavigation

SCENARIO = """\
name = "relnav"
[sim]
t_final_s = 10.0
dt_s = 1.0
[orbit]
[spacecraft_defaults]
inertia_kgm2 = [0.01, 0.01, 0.01]
mass_kg = 1.0
[[spacecraft]]
name = "chief"
[spacecraft.elements]
a_m = 6878137.0
i_deg = 97.4
[[spacecraft]]
name = "dep"
[spacecraft.relative]
to = "{to}"
rho_lvlh_m = [1.5, -0.3, 0.2]
rho_dot_lvlh_m_s = [1e-3, 2e-3, -4e-4]
"""


def test_a_spacecraft_placed_relative_to_the_chief_is_there_in_its_lvlh_frame(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(SCENARIO.format(to="chief"))
    x0 = prepare(load_scenario(path)).system.x0
    r0, v0 = elements_to_rv(6878137.0, 0.0, np.deg2rad(97.4), 0.0, 0.0, 0.0, MU_EARTH_M3_S2)
    np.testing.assert_allclose(np.asarray(x0.r_eci)[0], r0, rtol=1e-15)
    rho, rho_dot = eci_to_lvlh(np.asarray(x0.r_eci)[0], np.asarray(x0.v_eci)[0], np.asarray(x0.r_eci)[1], np.asarray(x0.v_eci)[1])
    np.testing.assert_allclose(rho, [1.5, -0.3, 0.2], atol=1e-9)
    np.testing.assert_allclose(rho_dot, [1e-3, 2e-3, -4e-4], atol=1e-12)


@pytest.mark.parametrize("to, message", [("nobody", "relative.to: 'nobody'"), ("dep", "relative.to: 'dep'")])
def test_relative_to_a_spacecraft_without_its_own_state_is_one_error(tmp_path, to, message):
    path = tmp_path / "s.toml"
    path.write_text(SCENARIO.format(to=to))
    with pytest.raises(ScenarioError, match=message):
        load_scenario(path)


def test_relative_with_elements_is_one_error(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(SCENARIO.format(to="chief") + "[spacecraft.elements]\na_m = 7e6\n")
    with pytest.raises(ScenarioError, match="not elements and relative"):
        load_scenario(path)


def _state(n=3, seed=0):
    rng = np.random.default_rng(seed)
    r0, v0 = elements_to_rv(6878137.0, 0.001, 1.7, 0.3, 0.2, 0.1, MU_EARTH_M3_S2)
    r = np.asarray(r0)[:, None] + rng.normal(size=(3, n))
    v = np.asarray(v0)[:, None] + 1e-3 * rng.normal(size=(3, n))
    zeros = np.zeros((3, n))
    return PlantState(q_bi=np.zeros((4, n)), omega_b=zeros, h_wheels_b=zeros, r_eci=r, v_eci=v, angle_rad=zeros)


def test_truth_is_the_lvlh_state_and_the_chief_reads_zero_exactly():
    x = _state()
    sensor = RelativeNavigation(sigma=np.array([1e-3] * 3 + [1e-5] * 3), chief=np.int32(1))
    truth = np.asarray(sensor.truth({}, x))
    rho, rho_dot = eci_to_lvlh(x.r_eci[:, 1], x.v_eci[:, 1], x.r_eci.T, x.v_eci.T)
    np.testing.assert_allclose(truth, np.concatenate([rho, rho_dot], axis=1).T, atol=1e-12)
    np.testing.assert_array_equal(truth[:, 1], 0.0)
    value, _ = sensor.measure(truth, x, (), jax.random.PRNGKey(0))
    np.testing.assert_array_equal(np.asarray(value)[:, 1], 0.0)


def test_noise_has_the_stated_deviation_per_axis():
    x = _state(n=2)
    sigma = np.array([3e-5, 3e-5, 3e-5, 1e-6, 1e-6, 1e-6])
    sensor = RelativeNavigation(sigma=sigma, chief=np.int32(0))
    truth = sensor.truth({}, x)
    keys = jax.random.split(jax.random.PRNGKey(7), 4000)
    values = jax.vmap(lambda k: sensor.measure(truth, x, (), k)[0])(keys)
    err = np.asarray(values)[:, :, 1] - np.asarray(truth)[:, 1]
    np.testing.assert_allclose(err.std(axis=0), sigma, rtol=0.05)
    assert np.all(np.abs(err.mean(axis=0)) < 4 * sigma / np.sqrt(4000))
