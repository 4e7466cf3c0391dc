"""The Earth-environment tables (``aerodynamic-torque``, ``solar-pressure-torque``,
``residual-dipole``, ``magnetorquers``, ``sun-sensor``, ``magnetometer``): what the bundled
observation-cooperative scenario builds from them, and bad input as one ScenarioError line (and
``coopsat validate`` exit 2) naming the table and the fault.

observation-cooperative, changed with ``--set`` style overrides, is the base. The cases its
observation controller would reject first (no ``[orbit]``, another central body, the
small-angle model) put each table alone into a small bundled scenario instead.
"""

import tomllib

import erfa
import numpy as np
from astropy.time import Time
import pytest

from coopsat.actuators.magnetorquers import Magnetorquers
from coopsat.astro.timescales import run_epoch
from coopsat.cli import EXIT_BAD_INPUT, main
from coopsat.environment.earth_torques import AerodynamicTorque, ResidualDipoleTorque, SolarPressureTorque
from coopsat.scenarios.build import build
from coopsat.scenarios.load import ScenarioError, bundled_text, load_scenario
from coopsat.sensors.environment_sensors import Magnetometer, SunSensor

COOP = "observation-cooperative"
# observation-cooperative: disturbances[1] aerodynamic, [2] solar pressure, [3] residual dipole;
# actuators[1] magnetorquers; sensors[2] sun sensor, [3] magnetometer.
AERO, SRP, DIPOLE = "disturbances.1", "disturbances.2", "disturbances.3"


def _of(parts, kind):
    found = [p for p in parts if isinstance(p, kind)]
    assert len(found) == 1
    return found[0]


def test_observation_cooperative_builds_its_tables_into_parts():
    """Normals normalised (one given as [2, 0, 0] here), per-facet fractions, the epoch's Julian
    date and sidereal angle, the sun sensor's degrees in radians."""
    raw = tomllib.loads(bundled_text(COOP))
    specular = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7]
    scenario = load_scenario(COOP, [f"{AERO}.facets.0.0=2.0", f"{SRP}.specular={specular}"])
    system = build(scenario).system
    epoch = run_epoch(raw["orbit"]["epoch_utc"])
    jd = epoch.jd_tt  # the ephemerides read the run's clock, TT
    ut1 = Time(raw["orbit"]["epoch_utc"], scale="utc").ut1  # astropy's own UT1 (bundled IERS-A)
    era = erfa.era00(ut1.jd1, ut1.jd2)
    tables = {t["kind"]: t for t in raw["disturbances"]}
    facets = np.asarray(tables["aerodynamic-torque"]["facets"], float)  # the bundled normals are unit

    aero = _of(system.disturbances, AerodynamicTorque)
    np.testing.assert_array_equal(np.asarray(aero.normals_b), facets[:, :3].T)
    np.testing.assert_array_equal(np.asarray(aero.areas_m2), facets[:, 3])
    np.testing.assert_array_equal(np.asarray(aero.centres_b_m), facets[:, 4:].T)
    assert float(aero.cd) == 2.2

    srp = _of(system.disturbances, SolarPressureTorque)
    np.testing.assert_array_equal(np.asarray(srp.specular), specular)
    np.testing.assert_array_equal(np.asarray(srp.diffuse), np.full(8, 0.2))
    assert float(srp.jd0) == jd
    assert float(srp.pressure_1au_n_m2) == pytest.approx(4.54e-6, rel=1e-3)

    dipole = _of(system.disturbances, ResidualDipoleTorque)
    np.testing.assert_array_equal(np.asarray(dipole.dipole_b_am2), np.full((3, 1), 0.02))
    # IAU 2006 by default: ERA of UT1, to 1 m at the surface (1.6e-7 rad; astropy merges its IERS tables
    # its own way, measured 6e-9 rad here)
    assert float(np.mod(dipole.earth.angle_rad[0], 2 * np.pi)) == pytest.approx(era, abs=1.6e-7)

    torquers = _of(system.actuators, Magnetorquers)
    assert float(torquers.dipole_max_am2) == 2.5 and np.array_equal(torquers.earth.q_c2i, dipole.earth.q_c2i)
    assert torquers.command == "dipole_b"

    sun = _of(system.sensors, SunSensor)
    np.testing.assert_allclose(np.asarray(sun.sigma_rad), np.full(3, np.radians(0.2)), rtol=1e-15)
    assert float(sun.jd0) == jd
    mag = _of(system.sensors, Magnetometer)
    np.testing.assert_array_equal(np.asarray(mag.sigma_t), np.full(3, 3e-10))
    np.testing.assert_array_equal(np.asarray(mag.bias_t), np.zeros(3))
    np.testing.assert_array_equal(np.asarray(mag.earth.angle_rad), np.asarray(dipole.earth.angle_rad))


def _one_line_error(overrides, base=COOP):
    with pytest.raises(ScenarioError) as info:
        build(load_scenario(base, overrides))
    message = str(info.value)
    assert "\n" not in message and "Traceback" not in message
    return message


@pytest.mark.parametrize(
    ("overrides", "expected"),
    [
        ([f"{AERO}.facets.0.{k}=0.0" for k in range(3)], "disturbances[1]: facets[0]: the normal [nx, ny, nz] must not be zero"),
        ([f"{SRP}.facets.2.{k}=0.0" for k in range(3)], "disturbances[2]: facets[2]: the normal [nx, ny, nz] must not be zero"),
        ([f"{AERO}.facets.2.3=0.0"], "disturbances[1]: facets[2]: area_m2 must be in (0, 1e4] m², got 0"),
        ([f"{SRP}.facets.7.3=-0.18"], "disturbances[2]: facets[7]: area_m2 must be in (0, 1e4] m², got -0.18"),
        ([f"{AERO}.facets.0=[1.0, 0.0, 0.0, 0.06, 0.09, -0.005]"], "disturbances[1].facets[0][6]: Field required"),
        ([f"{AERO}.facets.0.4=nan"], "disturbances[1].facets[0][4]: Input should be a finite number"),
        ([f"{AERO}.facets=[]"], "disturbances[1].facets: List should have at least 1 item"),
        ([f"{AERO}.cd=0.0"], "disturbances[1].cd: Input should be greater than 0"),
        ([f"{SRP}.specular=1.5"], "less than or equal to 1"),
        ([f"{DIPOLE}.dipole_am2=[0.1, 0.1]"], "disturbances[3].dipole_am2: List should have at least 3 items"),
        (["actuators.1.dipole_max_am2=0.0"], "actuators[1].dipole_max_am2: Input should be greater than 0"),
        (["actuators.1.dipole_max_am2=-2.5"], "actuators[1].dipole_max_am2: Input should be greater than 0"),
        (["sensors.3.sigma_t=-1e-9"], "sensors[3].sigma_t: must be finite and ≥ 0"),
    ],
)
def test_bad_tables_are_one_line_errors(overrides, expected):
    message = _one_line_error(overrides)
    assert expected in message
    if "specular" in overrides[0]:
        assert message.startswith("disturbances[2].specular")


@pytest.mark.parametrize(
    ("overrides", "expected"),
    [
        # One value for every facet: 0.9 + the default diffuse 0.2.
        ([f"{SRP}.specular=0.9"], "solar-pressure-torque facet 0 reflects more than all its light (specular + diffuse > 1)"),
        # One value per facet: only the last facet reflects too much.
        ([f"{SRP}.diffuse=[0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.95]"], "solar-pressure-torque facet 7 reflects more than all its light"),
        ([f"{SRP}.specular=[0.1, 0.2]"], "specular: 2 values given for 8 facets (give one, or one each)"),
    ],
)
def test_fractions_that_do_not_fit_the_facets_are_design_errors(overrides, expected):
    assert expected in _one_line_error(overrides)


# Each table alone, in a scenario without an orbit (rigid-body-free) or with one
# (orbit-two-body, whose [orbit] is Earth's).
TABLES = {
    "aerodynamic-torque": 'disturbances=[{kind = "aerodynamic-torque", facets = [[1.0, 0.0, 0.0, 0.1, 0.1, 0.0, 0.0]]}]',
    "solar-pressure-torque": 'disturbances=[{kind = "solar-pressure-torque", facets = [[1.0, 0.0, 0.0, 0.1, 0.1, 0.0, 0.0]]}]',
    "residual-dipole": 'disturbances=[{kind = "residual-dipole", dipole_am2 = [0.1, 0.0, 0.0]}]',
    "magnetorquers": 'actuators=[{kind = "magnetorquers", dipole_max_am2 = 1.0}]',
    "sun-sensor": 'sensors=[{kind = "sun-sensor", sigma_deg = 0.1}]',
    "magnetometer": 'sensors=[{kind = "magnetometer", sigma_t = 1e-9}]',
}
PLACE = {
    "aerodynamic-torque": "disturbances: aerodynamic-torque", "solar-pressure-torque": "disturbances: solar-pressure-torque",
    "residual-dipole": "disturbances: residual-dipole", "magnetorquers": "actuators: magnetorquers",
    "sun-sensor": 'sensors[0]: kind = "sun-sensor"', "magnetometer": 'sensors[0]: kind = "magnetometer"',
}


@pytest.mark.parametrize("kind", sorted(TABLES))
def test_each_table_needs_the_earth_as_central_body_of_a_rigid_body_run(kind):
    # The control case: with Earth's [orbit] and rigid bodies the table builds.
    build(load_scenario("orbit-two-body", [TABLES[kind]]))
    message = _one_line_error([TABLES[kind]], base="rigid-body-free")
    assert message == f"{PLACE[kind]} needs an [orbit] table (it depends on the position about the Earth)"
    message = _one_line_error([TABLES[kind], "orbit.mu_m3_s2=1.32712440e20"], base="orbit-two-body")
    assert message.startswith(f"{PLACE[kind]} models the Earth's environment")
    assert "mu_m3_s2 = 1.32712e+20 is not the Earth's" in message
    message = _one_line_error([TABLES[kind], 'sim.attitude="small-angle"'], base="orbit-two-body")
    assert message.startswith(PLACE[kind]) and 'needs sim.attitude = "rigid-body"' in message


@pytest.mark.parametrize(
    ("override", "expected"),
    [
        ("actuators.1.dipole_max_am2=0", "actuators[1].dipole_max_am2: Input should be greater than 0"),
        (f"{SRP}.specular=0.9", "facet 0 reflects more than all its light"),
    ],
)
def test_validate_exits_2_with_one_line(capsys, override, expected):
    status = main(["validate", COOP, "--set", override])
    captured = capsys.readouterr()
    assert status == EXIT_BAD_INPUT
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("coopsat: error: ") and expected in lines[0], captured.err
    assert "Traceback" not in captured.err
