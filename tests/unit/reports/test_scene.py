"""The report's 3D view: frame choice, body axes and ground targets against independent
constructions (SciPy rotations, geometry by hand)."""

import numpy as np
import pytest
import xarray as xr
from scipy.spatial.transform import Rotation

from coopsat.astro.constants import MU_EARTH_M3_S2, R_EARTH_M
from coopsat.reports.scene import CLOSE_FRACTION, build_scene, frame_indices, ground_targets
from coopsat.scenarios.schema import Orbit


def _dataset(**variables):
    n_t = next(iter(variables.values())).shape[0]
    n = next(iter(variables.values())).shape[1]
    dims = {"q": ("time", "spacecraft", "q_component"), "angle": ("time", "spacecraft", "component")}
    data = {k: (dims.get(k, ("time", "spacecraft", "component")), v) for k, v in variables.items()}
    return xr.Dataset(data, coords={"time": np.arange(n_t) * 1.0, "spacecraft": [f"s{k}" for k in range(n)]})


def test_frame_indices_keep_first_and_last_and_cap_the_count():
    idx = frame_indices(10_001, 200)
    assert idx[0] == 0 and idx[-1] == 10_000 and len(idx) == 200 and np.all(np.diff(idx) > 0)
    assert np.array_equal(frame_indices(5, 200), np.arange(5))


def test_attitude_only_run_draws_body_axes_as_scipy_rotates_them():
    rng = np.random.default_rng(1)
    q = rng.normal(size=(3, 4, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    scene = build_scene(_dataset(q=q))
    assert "not simulated" in scene.note and scene.central_body is None
    expected = Rotation.from_quat(q.reshape(-1, 4), scalar_first=True).as_matrix().reshape(3, 4, 3, 3)
    # row a of body_axes is body axis a in inertial components: column a of C_ib
    np.testing.assert_allclose(scene.body_axes, np.swapaxes(expected, -1, -2), atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(scene.positions, axis=-1), 1.0)  # the display circle


def test_small_angles_are_drawn_as_a_rotation_vector():
    angle = np.zeros((2, 1, 3))
    angle[1, 0] = [0.0, 0.0, 0.1]
    scene = build_scene(_dataset(angle=angle))
    np.testing.assert_allclose(scene.body_axes[0, 0], np.eye(3), atol=1e-15)
    np.testing.assert_allclose(scene.body_axes[1, 0, 0], [np.cos(0.1), np.sin(0.1), 0.0], atol=1e-15)


def _circular(r_m, t_s):
    """Equatorial circular orbit positions and velocities, (t, 3)."""
    n = np.sqrt(MU_EARTH_M3_S2 / r_m**3)
    u = n * t_s
    r = r_m * np.stack([np.cos(u), np.sin(u), 0 * u], -1)
    v = r_m * n * np.stack([-np.sin(u), np.cos(u), 0 * u], -1)
    return r, v


def test_close_formation_is_drawn_in_the_chiefs_lvlh_frame():
    t = np.linspace(0.0, 600.0, 7)
    r_c, v_c = _circular(7.0e6, t)
    radial = r_c / np.linalg.norm(r_c, axis=-1, keepdims=True)
    along = v_c / np.linalg.norm(v_c, axis=-1, keepdims=True)
    # deputy 1: 100 m below the chief (towards the Earth); deputy 2: 50 m ahead, 20 m north
    r1 = r_c - 100.0 * radial
    r2 = r_c + 50.0 * along + np.array([0.0, 0.0, 20.0])
    r = np.stack([r_c, r1, r2], axis=1)
    v = np.stack([v_c, v_c, v_c], axis=1)
    scene = build_scene(_dataset(r_eci=r, v_eci=v), Orbit())
    assert scene.frame.startswith("LVLH of s0") and scene.central_body is None
    np.testing.assert_allclose(scene.positions[:, 0], 0.0, atol=1e-9)
    # LVLH: x along-track, y the negative orbit normal (north is -y here), z towards the Earth
    np.testing.assert_allclose(scene.positions[:, 1], np.tile([0.0, 0.0, 100.0], (7, 1)), atol=1e-6)
    np.testing.assert_allclose(scene.positions[:, 2], np.tile([50.0, -20.0, 0.0], (7, 1)), atol=1e-6)


def test_single_spacecraft_in_orbit_is_drawn_in_eci_with_the_earth():
    t = np.linspace(0.0, 6000.0, 50)
    r, v = _circular(7.0e6, t)
    scene = build_scene(_dataset(r_eci=r[:, None], v_eci=v[:, None]), Orbit())
    assert scene.frame == "ECI" and scene.central_body == ("Earth", pytest.approx(R_EARTH_M * 1e-3))
    np.testing.assert_allclose(np.linalg.norm(scene.positions[:, 0], axis=-1), 7.0e3)  # km


def test_wide_formation_is_not_drawn_in_lvlh():
    t = np.linspace(0.0, 60.0, 3)
    r, v = _circular(7.0e6, t)
    far = r * (1.0 + 2.0 * CLOSE_FRACTION)
    scene = build_scene(_dataset(r_eci=np.stack([r, far], 1), v_eci=np.stack([v, v], 1)), Orbit())
    assert scene.frame == "ECI"


def test_ground_target_is_where_the_line_of_sight_meets_the_sphere():
    r = np.array([[7.0e6, 0.0, 0.0], [7.0e6, 0.0, 0.0]])
    los = np.array([[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    hit = ground_targets(r, los, R_EARTH_M)
    np.testing.assert_allclose(hit[0], [R_EARTH_M, 0.0, 0.0])
    assert np.all(np.isnan(hit[1]))  # looking away from the Earth: no target
    # an oblique line: the point lies on the sphere and on the line
    d = np.array([-0.8, 0.6, 0.0])
    p = ground_targets(r[0], d, R_EARTH_M)
    assert np.linalg.norm(p) == pytest.approx(R_EARTH_M)
    assert np.linalg.norm(np.cross(p - r[0], d)) < 1e-6 * R_EARTH_M
