"""Solar radiation pressure on flat facets about the Earth (``kind = "solar-radiation-pressure"``
with ``facets``): the flat-plate model's closed forms for one plate, an independent NumPy
reference written facet by facet for random attitudes (SciPy rotations, no coopsat quaternion
code), the torque and the force from the same facets, the Earth's shadow, a pulsed tick, a
closed-loop run and a batch, and bad input in one line naming the field.

The model, per lit facet (cos θ = n̂·ŝ > 0, ŝ towards the Sun):
``F = −P A cos θ [(1 − ε_s) ŝ + 2 (ε_s cos θ + ε_d/3) n̂]``, P = P₁ (AU/d)² times the sunlit
fraction of the Sun's disc.
"""

import jax.numpy as jnp
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import coopsat
from coopsat.astro.constants import AU_M, MU_SUN_M3_S2, SOLAR_PRESSURE_1AU_N_M2
from coopsat.astro.ephemeris import R_EARTH_M, sun_position_eme2000_m
from coopsat.astro.gravity_field import EGM2008_GM_M3_S2
from coopsat.astro.timescales import run_epoch
from coopsat.cli import EXIT_BAD_INPUT, main
from coopsat.dynamics.plant import PlantState
from coopsat.environment.earth_torques import facet_srp_force_b, facet_srp_torque_b
from coopsat.environment.orbit_forces import EarthSolarRadiationPressure
from coopsat.scenarios.document import Scenario
from coopsat.scenarios.load import bundled_names, bundled_text, load_scenario
from coopsat.workflows.pipeline import prepare, simulate_built
from earth_reference import random_quats, to_body

EPOCH_UTC = "2024-03-20T00:00:00"
JD0_TT = run_epoch(EPOCH_UTC).jd_tt
P1 = SOLAR_PRESSURE_1AU_N_M2
SPECULAR, DIFFUSE = 0.3, 0.2


# --- the independent reference ----------------------------------------------------------------


def reference_facet_forces(s_b, pressure, normals, areas, specular, diffuse):
    """Each facet's force (F, 3), N, body axes, one facet at a time."""
    forces = np.zeros((areas.size, 3))
    for k in range(areas.size):
        n = normals[:, k]
        cos = n @ s_b
        if cos > 0.0:
            forces[k] = -pressure * areas[k] * cos * ((1.0 - specular[k]) * s_b + 2.0 * (specular[k] * cos + diffuse[k] / 3.0) * n)
    return forces


def sun_eci_m(t_s):
    return np.asarray(sun_position_eme2000_m(JD0_TT + t_s / 86400.0))


def state(q, r):
    """Component-major PlantState of n spacecraft from (n, 4) and (n, 3)."""
    q, r = np.atleast_2d(q), np.atleast_2d(r)
    zeros = jnp.zeros((3, q.shape[0]))
    return PlantState(jnp.asarray(q.T), zeros, zeros, jnp.asarray(r.T), zeros, zeros)


def srp_part(normals, areas, specular, diffuse):
    """The force part on facets (its cannonball arrays are not read), conical shadow."""
    f = areas.size
    return EarthSolarRadiationPressure(
        jnp.zeros(1), jnp.zeros(1), jnp.asarray(normals), jnp.asarray(areas), jnp.broadcast_to(jnp.asarray(specular), (f,)),
        jnp.broadcast_to(jnp.asarray(diffuse), (f,)), jnp.asarray(P1), jnp.asarray(AU_M), jnp.asarray(JD0_TT),
    )


def day_side(t_s=0.0, height_m=500e3):
    """A position over the sub-solar point, the unit vector to the Sun from it, and its distance."""
    r_sun = sun_eci_m(t_s)
    r = (R_EARTH_M + height_m) * r_sun / np.linalg.norm(r_sun)
    to_sun = r_sun - r
    d = np.linalg.norm(to_sun)
    return r, to_sun / d, d


def unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


# --- closed forms for one plate -----------------------------------------------------------------


def test_a_plate_facing_the_sun_feels_p_a_times_one_plus_specular_plus_two_thirds_diffuse():
    r, s_eci, d = day_side()
    area = 2.5
    q = random_quats(1, 1)
    # The plate's normal is the Sun's direction, in body axes for this attitude.
    part = srp_part(to_body(q[0], s_eci)[:, None], np.array([area]), SPECULAR, DIFFUSE)
    out = part.record(0.0, state(q, r), ())
    assert float(out["sunlight_fraction"][0]) == 1.0
    # cos θ = 1, n̂ = ŝ: F = −P A [(1 − ε_s) + 2 (ε_s + ε_d/3)] ŝ = −P A (1 + ε_s + 2ε_d/3) ŝ.
    expected = -P1 * (AU_M / d) ** 2 * area * (1.0 + SPECULAR + 2.0 * DIFFUSE / 3.0) * s_eci
    np.testing.assert_allclose(np.asarray(out["srp_force"])[:, 0], expected, rtol=1e-12)


def test_a_plate_tilted_sixty_degrees_from_the_sun():
    r, s_eci, d = day_side()
    area = 1.5
    across = unit(np.cross(s_eci, [0.0, 0.0, 1.0]))
    n_eci = 0.5 * s_eci + np.sqrt(3.0) / 2.0 * across  # cos θ = 1/2
    q = random_quats(1, 2)
    part = srp_part(to_body(q[0], n_eci)[:, None], np.array([area]), SPECULAR, DIFFUSE)
    force = np.asarray(part.record(0.0, state(q, r), ())["srp_force"])[:, 0]
    pa = P1 * (AU_M / d) ** 2 * area
    # F = −P A/2 [(1 − ε_s) ŝ + 2 (ε_s/2 + ε_d/3) n̂]: along the ray −P A (1 − ε_s)/2, along the
    # normal −P A (ε_s/2 + ε_d/3); n̂·ŝ = 1/2 gives the projections below.
    along_ray, along_normal = -pa * (1.0 - SPECULAR) / 2.0, -pa * (SPECULAR / 2.0 + DIFFUSE / 3.0)
    np.testing.assert_allclose(force @ s_eci, along_ray + 0.5 * along_normal, rtol=1e-12)  # −P A (1/2 + ε_d/6)
    np.testing.assert_allclose(force @ n_eci, 0.5 * along_ray + along_normal, rtol=1e-12)  # −P A (1/4 + ε_s/4 + ε_d/3)
    np.testing.assert_allclose(force, along_ray * s_eci + along_normal * n_eci, rtol=1e-12)
    assert abs(force @ np.cross(s_eci, n_eci)) < 1e-12 * np.linalg.norm(force)


def test_a_plate_facing_away_or_edge_on_feels_nothing():
    r, s_eci, _ = day_side()
    q = random_quats(1, 3)
    part = srp_part(to_body(q[0], -s_eci)[:, None], np.array([1.0]), SPECULAR, DIFFUSE)
    np.testing.assert_array_equal(np.asarray(part.record(0.0, state(q, r), ())["srp_force"]), 0.0)
    edge_on = facet_srp_force_b(jnp.array([[1.0], [0.0], [0.0]]), jnp.array([P1]), jnp.array([[0.0], [1.0], [0.0]]),
                                jnp.array([1.0]), jnp.array([SPECULAR]), jnp.array([DIFFUSE]))
    np.testing.assert_array_equal(np.asarray(edge_on), 0.0)


# --- random attitudes, several facets -----------------------------------------------------------


def box_with_panel():
    """A box (six faces) and a tilted solar panel: normals (3, 7) unit, areas, optics per facet."""
    normals = np.hstack([np.eye(3), -np.eye(3), unit([0.3, -0.2, 1.0])[:, None]])
    areas = np.array([0.06, 0.03, 0.02, 0.06, 0.03, 0.02, 0.5])
    specular = np.array([0.1, 0.2, 0.0, 0.5, 0.3, 0.05, 0.04])
    diffuse = np.array([0.2, 0.1, 0.6, 0.3, 0.0, 0.25, 0.01])
    return normals, areas, specular, diffuse


def positions(t_s):
    """Five geocentric positions: day side, two at random over the sunlit hemisphere, one in
    the penumbra (at the edge of the shadow cylinder, 3000 km behind the Earth's centre) and
    one in the umbra (right behind the Earth)."""
    s_hat = unit(sun_eci_m(t_s))
    across = unit(np.cross(s_hat, [0.0, 0.0, 1.0]))
    rng = np.random.default_rng(7)
    lit = [unit(s_hat + 0.6 * rng.normal(size=3)) for _ in range(2)]
    radius = R_EARTH_M + 500e3
    return np.array([radius * s_hat, radius * lit[0], radius * lit[1], -3000e3 * s_hat + R_EARTH_M * across, -radius * s_hat])


def reference_force_eci(t_s, q, r, light, facets):
    """The force on one spacecraft, N, ECI: the plate model facet by facet, SciPy rotations."""
    normals, areas, specular, diffuse = facets
    to_sun = sun_eci_m(t_s) - r
    d = np.linalg.norm(to_sun)
    s_b = to_body(q, to_sun / d)
    force_b = reference_facet_forces(s_b, light * P1 * (AU_M / d) ** 2, normals, areas, specular, diffuse).sum(axis=0)
    return Rotation.from_quat(q, scalar_first=True).apply(force_b)


def test_random_attitudes_and_facets_match_the_facet_by_facet_reference():
    facets = box_with_panel()
    part = srp_part(*facets)
    t = 5000.0
    r = positions(t)
    q = random_quats(r.shape[0], 4)
    out = part.record(t, state(q, r), ())
    force, light = np.asarray(out["srp_force"]), np.asarray(out["sunlight_fraction"])
    assert force.shape == (3, 5)
    assert light[0] == 1.0 and 0.0 < light[3] < 1.0 and light[4] == 0.0
    for i in range(5):
        expected = reference_force_eci(t, q[i], r[i], light[i], facets)
        np.testing.assert_allclose(force[:, i], expected, rtol=1e-12, atol=1e-12 * np.linalg.norm(expected))
    # The attitude matters: the same positions with other attitudes feel other forces.
    other = np.asarray(part.record(t, state(random_quats(5, 5), r), ())["srp_force"])
    assert np.linalg.norm(other[:, 0] - force[:, 0]) > 0.1 * np.linalg.norm(force[:, 0])
    # In the umbra nothing, whatever the attitude.
    np.testing.assert_array_equal(force[:, 4], 0.0)
    np.testing.assert_array_equal(np.asarray(part.wrench(t, state(q, r), ())["force_eci"]), force)


def test_a_pulsed_tick_evaluates_each_spacecraft_at_its_own_time():
    facets = box_with_panel()
    part = srp_part(*facets)
    r = positions(0.0)[:3]
    q = random_quats(3, 6)
    times = np.array([0.0, 4.3e4, 8.6e4])  # the Sun moves 1° a day: half a degree apart
    force = np.asarray(part.wrench(jnp.asarray(times), state(q, r), ())["force_eci"])
    for i, t in enumerate(times):
        alone = np.asarray(part.wrench(t, state(q[i], r[i]), ())["force_eci"])[:, 0]
        np.testing.assert_allclose(force[:, i], alone, rtol=1e-13, atol=0.0)
        np.testing.assert_allclose(force[:, i], reference_force_eci(t, q[i], r[i], 1.0, facets), rtol=1e-12)
    assert np.linalg.norm(force[:, 2] - np.asarray(part.wrench(0.0, state(q[2], r[2]), ())["force_eci"])[:, 0]) > 0.0


def test_the_torque_and_the_force_come_from_the_same_facet_forces():
    normals, areas, specular, diffuse = box_with_panel()
    rng = np.random.default_rng(8)
    s_b = rng.normal(size=(3, 6))
    s_b /= np.linalg.norm(s_b, axis=0)
    pressure = P1 * rng.uniform(0.5, 1.0, size=6)
    centres = rng.normal(scale=0.3, size=(3, areas.size))
    args = [jnp.asarray(a) for a in (s_b, pressure, normals, areas)]
    force = np.asarray(facet_srp_force_b(*args, jnp.asarray(specular), jnp.asarray(diffuse)))
    torque = np.asarray(facet_srp_torque_b(*args, jnp.asarray(centres), jnp.asarray(specular), jnp.asarray(diffuse)))
    for i in range(6):
        per_facet = reference_facet_forces(s_b[:, i], pressure[i], normals, areas, specular, diffuse)
        total = per_facet.sum(axis=0)
        np.testing.assert_allclose(force[:, i], total, rtol=1e-12, atol=1e-12 * np.linalg.norm(total))
        expected_torque = np.cross(centres.T, per_facet).sum(axis=0)
        np.testing.assert_allclose(torque[:, i], expected_torque, rtol=1e-12, atol=1e-12 * np.linalg.norm(total))
    # Every facet acting at one point c: the torque is c × the force.
    c = np.array([0.2, -0.1, 0.4])
    at_c = np.asarray(facet_srp_torque_b(*args, jnp.asarray(np.tile(c[:, None], areas.size)), jnp.asarray(specular), jnp.asarray(diffuse)))
    np.testing.assert_allclose(at_c, np.cross(c, force.T).T, rtol=1e-12, atol=1e-12 * np.abs(force).max())


# --- a closed-loop run, a formation and a batch -------------------------------------------------

PANEL = "[[1.0, 0.0, 0.0, 0.08, 0.0, 0.0, 0.0], [-1.0, 0.0, 0.0, 0.08, 0.0, 0.0, 0.0], [0.3, -0.2, 1.0, 0.5, 0.0, 0.0, 0.2]]"


def leo_text(srp, *, n=2, t_final_s=600.0, mu=EGM2008_GM_M3_S2):
    text = f'name = "leo-srp-facets"\n[sim]\nt_final_s = {t_final_s}\ndt_s = 10.0\nrecord_interval_s = 60.0\n'
    text += f'[orbit]\ngravity = "two-body"\nmu_m3_s2 = {mu}\nepoch_utc = "{EPOCH_UTC}"\n'
    for k in range(n):
        text += (
            f"[[spacecraft]]\ninertia_kgm2 = [1.0, 2.0, 3.0]\nmass_kg = 20.0\nomega_b_rad_s = [0.01, {0.02 * (k + 1)}, -0.015]\n"
            f"[spacecraft.elements]\na_m = 6878137.0\ne = 0.001\ni_deg = 51.6\nraan_deg = 30.0\nmean_anomaly_deg = {10.0 + k}\n"
        )
    return text + f'[[disturbances]]\nkind = "solar-radiation-pressure"\n{srp}\n'


FACETED = f"facets = {PANEL}\nspecular = [0.1, 0.1, 0.04]\ndiffuse = 0.2"


def test_a_closed_loop_formation_records_the_facet_force(tmp_path):
    path = tmp_path / "leo.toml"
    path.write_text(leo_text(FACETED), encoding="utf-8")
    ds, _ = simulate_built(prepare(load_scenario(path)))
    force = ds.srp_force.values  # (time, spacecraft, component)
    assert force.shape[1:] == (2, 3) and np.isfinite(force).all()
    assert np.linalg.norm(force, axis=-1).max() > 1e-7
    normals = np.asarray([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], unit([0.3, -0.2, 1.0])]).T
    facets = (normals, np.array([0.08, 0.08, 0.5]), np.array([0.1, 0.1, 0.04]), np.full(3, 0.2))
    # Each sample against the reference from the recorded state (the bodies tumble: the force turns).
    for k, t in enumerate(ds.time.values):
        for i in range(2):
            q = ds.q.values[k, i]
            expected = reference_force_eci(t, q, ds.r_eci.values[k, i], ds.sunlight_fraction.values[k, i], facets)
            np.testing.assert_allclose(force[k, i], expected, rtol=1e-9, atol=1e-9 * np.linalg.norm(expected))
    directions = force / np.linalg.norm(force, axis=-1, keepdims=True)
    assert np.abs(directions[:, 0] - directions[0, 0]).max() > 0.1


def test_a_batch_gives_the_single_runs_force():
    doc = Scenario.from_toml(leo_text(FACETED, n=1, t_final_s=300.0))
    other = doc.set("disturbances.0.specular", 0.5)
    single = coopsat.run(other).dataset.srp_force.values
    batch = coopsat.run_batch([doc, other])
    assert batch.n_batches == 1
    np.testing.assert_allclose(batch.results[1].dataset.srp_force.values, single, rtol=1e-9, atol=1e-15)
    assert not np.allclose(batch.results[0].dataset.srp_force.values, single)


# --- scenario input -----------------------------------------------------------------------------


def error_line(tmp_path, capsys, text):
    path = tmp_path / "bad.toml"
    path.write_text(text, encoding="utf-8")
    status = main(["validate", str(path)])
    captured = capsys.readouterr()
    assert status == EXIT_BAD_INPUT, captured.err
    assert "Traceback" not in captured.err
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("coopsat: error: "), captured.err
    return lines[0]


CANNONBALL = "area_m2 = 1.0\nreflectivity = 0.3"
BAD = [
    ("area-and-facets", f"{CANNONBALL}\nfacets = {PANEL}", ["area_m2", "facets", "one of them"]),
    ("neither", "reflectivity = 0.3", ["area_m2", "facets", "one of them"]),
    ("facet-negative-area", "facets = [[1.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0]]", ["facets[0]", "area_m2"]),
    ("facet-zero-normal", "facets = [[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]]", ["facets[0]", "normal"]),
    ("reflectivity-with-facets", f"facets = {PANEL}\nreflectivity = 0.3", ["reflectivity", "area_m2"]),
    ("specular-with-a-cannonball", f"{CANNONBALL}\nspecular = 0.5", ["specular", "facets"]),
    ("cannonball-without-reflectivity", "area_m2 = 1.0", ["reflectivity", "area_m2"]),
    ("specular-out-of-range", f"facets = {PANEL}\nspecular = 1.5", ["disturbances[0].specular"]),
    ("specular-miscounted", f"facets = {PANEL}\nspecular = [0.1, 0.2]", ["specular", "2 values", "3 facets"]),
    ("reflects-more-than-all", f"facets = {PANEL}\nspecular = 0.7\ndiffuse = 0.4", ["solar-radiation-pressure", "facet 0"]),
]


@pytest.mark.parametrize(("srp", "words"), [c[1:] for c in BAD], ids=[c[0] for c in BAD])
def test_bad_input_is_one_line_naming_the_field(tmp_path, capsys, srp, words):
    line = error_line(tmp_path, capsys, leo_text(srp, n=1))
    for word in words:
        assert word in line, f"{word!r} not in {line!r}"


def test_facets_about_the_sun_are_refused_naming_the_field(tmp_path, capsys):
    text = leo_text(f"facets = {PANEL}", n=1, mu=MU_SUN_M3_S2).replace(
        "[spacecraft.elements]\na_m = 6878137.0", "[spacecraft.elements]\na_m = 1.496e11"
    )
    line = error_line(tmp_path, capsys, text)
    assert "disturbances.facets" in line and "about the Earth" in line


def test_valid_scenarios_validate(tmp_path, capsys):
    for k, srp in enumerate([FACETED, CANNONBALL, f"facets = {PANEL}"]):
        path = tmp_path / f"ok{k}.toml"
        path.write_text(leo_text(srp, n=1), encoding="utf-8")
        status = main(["validate", str(path)])
        assert status == 0, capsys.readouterr().err



def test_the_bundled_cannonballs_still_build():
    names = [name for name in bundled_names() if 'kind = "solar-radiation-pressure"' in bundled_text(name)]
    assert len(names) >= 2
    for name in names:
        # Resolved: every default written back (specular, diffuse) must not read as a facet field.
        coopsat.validate(Scenario.load(name).resolved())
