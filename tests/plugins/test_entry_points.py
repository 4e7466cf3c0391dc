"""Plug-ins from other packages, through the entry-point group ``coopsat.plugins``.

The example package (examples/plugin-example) is installed into a temporary folder, never into
the virtual environment, and ``coopsat`` runs in a subprocess with that folder on PYTHONPATH:
its scenario runs with the example's law and thrusters, and the run folder shows what they did.
Two more packages made here show the errors: one claiming a kind coopsat has, one that fails
to import. The cold-gas actuator is checked against a hand computation.
"""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "plugin-example"

BIT_NMS = 6e-5
"""The example scenario's minimum impulse bit, N·m·s."""


def _setuptools_builds_wheels():
    """Whether this environment's setuptools can build a wheel by itself (offline): 70.1 and
    later can, older ones need the ``wheel`` package."""
    import importlib.metadata
    import importlib.util

    try:
        version = tuple(int(p) for p in importlib.metadata.version("setuptools").split(".")[:2])
    except (importlib.metadata.PackageNotFoundError, ValueError):
        return False
    return version >= (70, 1) or importlib.util.find_spec("wheel") is not None


def pip_install(source, target):
    """``pip install --no-deps --target`` of a source folder (copied first: pip builds in it).

    Without build isolation and without an index when this environment's setuptools can build
    the wheel, so it works offline; otherwise (Python 3.11's venv brings setuptools 65 without
    ``wheel``) pip's usual isolated build, which fetches setuptools as the install of coopsat
    itself did."""
    copy = target.parent / f"{source.name}-src"
    shutil.copytree(source, copy, ignore=shutil.ignore_patterns("build", "*.egg-info", "__pycache__"))
    cmd = [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--target", str(target), str(copy)]
    if _setuptools_builds_wheels():
        cmd[5:5] = ["--no-build-isolation", "--no-index"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return target


def fake_distribution(root, name, entry_points, modules):
    """An installed distribution as importlib.metadata finds it: ``<name>-0.1.dist-info`` with
    its METADATA and entry_points.txt, beside the modules' source (``{module: text}``)."""
    info = root / f"{name.replace('-', '_')}-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.1\n")
    lines = "".join(f"{k} = {v}\n" for k, v in entry_points.items())
    (info / "entry_points.txt").write_text(f"[coopsat.plugins]\n{lines}")
    for module, text in modules.items():
        (root / f"{module}.py").write_text(text)
    return root


def coopsat_cmd(args, *paths, cwd=None):
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([*(str(p) for p in paths), *filter(None, [env.get("PYTHONPATH")])])
    return subprocess.run([sys.executable, "-m", "coopsat.cli", *args], capture_output=True, text=True, env=env, cwd=cwd)


@pytest.fixture(scope="module")
def example_site(tmp_path_factory):
    return pip_install(EXAMPLE, tmp_path_factory.mktemp("example") / "site")


@pytest.fixture(scope="module")
def example_run(example_site, tmp_path_factory):
    """The example scenario run by ``coopsat run`` with the example installed, recorded every
    control period (0.1 s) so that each period's impulse can be read."""
    out = tmp_path_factory.mktemp("runs") / "run"
    proc = coopsat_cmd(
        ["run", str(EXAMPLE / "scenario.toml"), "--out", str(out), "--no-figures", "--set", "sim.record_interval_s=0.1"],
        example_site,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return out


def test_the_install_declares_the_entry_point(example_site):
    info = next(example_site.glob("coopsat_example-*.dist-info"))
    assert "[coopsat.plugins]\nexample = coopsat_example.plugin" in (info / "entry_points.txt").read_text()


def test_the_example_law_synchronises_the_formation(example_run):
    m = json.loads((example_run / "metrics.json").read_text())
    # The law acted: the largest pairwise attitude error fell from about 60 deg to a fraction of
    # a degree (limited by the thrusters' dead band), and stayed there.
    assert m["sync_error_initial_deg"] > 50.0
    assert m["sync_error_final_deg"] < 1.0
    assert m["sync_error_reduction"] > 50.0
    assert m["sync_time_s"] is not None and m["sync_time_s"] < 40.0
    assert m["rate_spread_final_rad_s"] < 1e-3
    assert m["final_rate_max_rad_s"] < 0.01
    # The design checks of both plug-ins ran.
    assert m["cold_gas_deadband_torque_nm"] == pytest.approx(BIT_NMS / 0.1)
    assert m["cold_gas_delay_s"] == pytest.approx(0.1) and m["law_torque_max_nm"] == 0.015


def test_the_cold_gas_thrusters_fire_whole_bits_late(example_run):
    m = json.loads((example_run / "metrics.json").read_text())
    assert m["valve_openings"] > 100 and m["commands_below_bit"] > 100
    assert all(m[f"sat{k}_impulse_nms"] > 0.0 for k in range(1, 5))
    assert sum(m[f"sat{k}_firings"] for k in range(1, 5)) == m["valve_openings"]
    with xr.open_dataset(example_run / "result.nc", engine="h5netcdf") as ds:
        period_impulse = np.diff(ds["angular_impulse"].values, axis=0)  # (periods, n, 3): one per period
        command = ds["torque_command"].values  # (samples, n, 3): at each period's start
        assert ds["commands_below_bit"].values[-1].sum() == m["commands_below_bit"]
    fired = np.abs(period_impulse[period_impulse != 0.0])
    # Nothing below the minimum impulse bit is executed; the law's bound (0.015 N m) keeps every
    # pulse below the thrusters' full period (0.02 N m x 0.1 s).
    assert fired.min() >= BIT_NMS * (1 - 1e-9) and fired.max() <= 0.015 * 0.1 * (1 + 1e-9)
    # The valve opens one period late: period k fires what period k - 1 commanded.
    wanted = command * 0.1
    executed = np.where(np.abs(wanted) >= BIT_NMS, wanted, 0.0)
    assert np.all(period_impulse[0] == 0.0)
    np.testing.assert_allclose(period_impulse[1:], executed[:-2], rtol=0, atol=1e-15)


def test_two_packages_claiming_one_kind_is_one_line_naming_both(tmp_path):
    clash = fake_distribution(
        tmp_path / "clash", "coopsat-clash", {"clash": "coopsat_clash"},
        {"coopsat_clash": (
            "from typing import Literal\n"
            "from coopsat.plugins import Plugin, Table, register\n\n"
            "class Clash(Table):\n"
            "    kind: Literal['consensus-sync']\n\n"
            "register(Plugin('controller', 'consensus-sync', Clash, lambda table, ctx: None))\n"
        )},
    )
    proc = coopsat_cmd(["validate", "consensus-sync-a-stable"], clash)
    assert proc.returncode == 2
    assert proc.stderr == (
        "coopsat: error: plug-in controller 'consensus-sync' is registered by coopsat (coopsat.plugins.consensus) "
        "and by coopsat-clash (coopsat_clash)\n"
    )


def test_two_third_party_packages_claiming_one_kind(tmp_path, example_site):
    rival = fake_distribution(
        tmp_path / "rival", "coopsat-rival", {"thrusters": "coopsat_rival"},
        {"coopsat_rival": (
            "from typing import Literal\n"
            "from coopsat.plugins import Plugin, Table, register\n\n"
            "class Rival(Table):\n"
            "    kind: Literal['cold-gas-thrusters']\n\n"
            "register(Plugin('actuator', 'cold-gas-thrusters', Rival, lambda table, ctx: None))\n"
        )},
    )
    proc = coopsat_cmd(["validate", str(EXAMPLE / "scenario.toml")], example_site, rival)
    assert proc.returncode == 2
    assert proc.stderr == (
        "coopsat: error: plug-in actuator 'cold-gas-thrusters' is registered by coopsat-example (coopsat_example.plugin) "
        "and by coopsat-rival (coopsat_rival)\n"
    )


def test_an_entry_point_that_fails_to_import_is_one_line(tmp_path):
    broken = fake_distribution(
        tmp_path / "broken", "coopsat-broken", {"broken": "coopsat_broken"},
        {"coopsat_broken": "import coopsat_missing_dependency\n"},
    )
    proc = coopsat_cmd(["validate", "consensus-sync-a-stable"], broken)
    assert proc.returncode == 2
    assert proc.stderr == (
        "coopsat: error: plug-in entry point 'broken' of coopsat-broken (coopsat_broken) failed to import: "
        "ModuleNotFoundError: No module named 'coopsat_missing_dependency'\n"
    )


def test_an_entry_point_naming_an_object_or_reading_the_registry_is_refused(tmp_path):
    odd = fake_distribution(
        tmp_path / "odd", "coopsat-odd", {"callable": "coopsat_odd:plugins", "early": "coopsat_early"},
        {"coopsat_odd": "def plugins():\n    return []\n", "coopsat_early": "from coopsat.plugins import plugins\nplugins('controller')\n"},
    )
    proc = coopsat_cmd(["validate", "consensus-sync-a-stable"], odd)
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1
    assert "plug-in entry point 'callable' of coopsat-odd (coopsat_odd:plugins): names an object" in proc.stderr
    assert (
        "the plug-in registry was read while it loads (while importing coopsat-odd's entry point 'early'): a plug-in "
        "module must not read it, nor import coopsat.scenarios (which reads it), at import time"
    ) in proc.stderr


def test_cold_gas_thrusters_against_a_hand_computation(example_site, monkeypatch):
    import jax.numpy as jnp

    from coopsat.plugins import plugins, protocols

    plugins("actuator")  # the registry loads without the example (it is not on sys.path yet)
    monkeypatch.syspath_prepend(str(example_site))
    from coopsat_example.cold_gas import ColdGasThrusters, executed_impulse

    # torque 0.02 N m, bit 6e-5 N m s, period 0.25 s (a power of two: command x period is exact):
    # dead band 2.4e-4 N m, a valve open for the whole period gives 5e-3 N m s.
    part = ColdGasThrusters(jnp.asarray(0.02), jnp.asarray(6e-5), delay_periods=2)
    assert protocols.protocol_problems(part, "actuator") == [] and isinstance(part, protocols.Actuator)
    # Per axis (x, y, z) of one spacecraft. Period 0: below the bit (2e-4 N m: 5e-5 N m s), one
    # proportional (-4e-3 N m: 1e-3 N m s, valve open 50 ms), one above the thrusters' torque
    # (0.05 N m: clipped to the whole period, 5e-3 N m s). Period 1: exactly one bit, either sign.
    commands = [jnp.array([[2e-4], [-4e-3], [0.05]]), jnp.array([[0.0], [2.4e-4], [-2.4e-4]]), jnp.zeros((3, 1)), jnp.zeros((3, 1))]
    state = part.init(1)
    pulses = []
    for k, u in enumerate(commands):
        pulse, state = part.plan(u, None, state, 0.25, None, 0.25 * k)
        pulses.append(pulse)
    # Delay of two periods: nothing fires in periods 0 and 1.
    for pulse in pulses[:2]:
        assert np.all(np.asarray(pulse.t_off_s) == 0.0)
    # Period 2 fires period 0's command: x not executed, y -0.02 N m for 50 ms, z +0.02 N m for 0.25 s.
    np.testing.assert_allclose(np.asarray(pulses[2].level_nm)[:, 0], [0.0, -0.02, 0.02])
    np.testing.assert_allclose(np.asarray(pulses[2].t_off_s)[:, 0], [0.0, 0.05, 0.25], rtol=1e-12)
    # Period 3 fires period 1's: one bit is the shortest opening, 6e-5 / 0.02 = 3 ms.
    np.testing.assert_allclose(np.asarray(pulses[3].level_nm)[:, 0], [0.0, 0.02, -0.02])
    np.testing.assert_allclose(np.asarray(pulses[3].t_off_s)[:, 0], [0.0, 0.003, 0.003], rtol=1e-12)
    # One command (x in period 0) was not executed; zero commands are not counted.
    assert np.asarray(part.record(None, state)["commands_below_bit"])[:, 0].tolist() == [1, 0, 0]
    counts = part.account(pulses[2])
    np.testing.assert_allclose(np.asarray(counts["angular_impulse"])[:, 0], [0.0, -1e-3, 5e-3], rtol=1e-12)
    np.testing.assert_allclose(np.asarray(counts["thruster_on_time"])[:, 0], [0.0, 0.0, 0.0, 0.05, 0.25, 0.0], rtol=1e-12)
    assert np.asarray(counts["thruster_firings"])[:, 0].tolist() == [0, 0, 0, 1, 1, 0]
    np.testing.assert_allclose(executed_impulse(jnp.array([-5.99e-5, 6e-5, 6e-3]), 6e-5, 5e-3), [0.0, 6e-5, 5e-3])
    # Without delay the same period fires.
    now = ColdGasThrusters(jnp.asarray(0.02), jnp.asarray(6e-5))
    pulse, _ = now.plan(commands[0], None, now.init(1), 0.25, None, 0.0)
    np.testing.assert_allclose(np.asarray(pulse.t_off_s)[:, 0], [0.0, 0.05, 0.25], rtol=1e-12)


def test_saturated_consensus_against_a_hand_computation(example_site, monkeypatch):
    import jax.numpy as jnp

    from coopsat.plugins import Inbox, plugins, protocols

    plugins("controller")
    monkeypatch.syspath_prepend(str(example_site))
    from coopsat_example.saturated_consensus import SaturatedConsensus

    law = SaturatedConsensus(jnp.asarray(0.2), jnp.asarray(0.3), jnp.asarray(0.1), jnp.asarray(0.015))
    assert protocols.protocol_problems(law, "controller") == [] and isinstance(law, protocols.Controller)
    # Two spacecraft hearing each other (weight 1): sat2 turned by 10 deg about z, sat1 spinning
    # at 0.01 rad/s about x. Edge list sorted by receiver: link 0 (sat2 -> sat1), link 1 (sat1 -> sat2).
    h = np.radians(10.0) / 2
    q = jnp.array([[1.0, np.cos(h)], [0.0, 0.0], [0.0, 0.0], [0.0, np.sin(h)]])
    omega = jnp.array([[0.01, 0.0], [0.0, 0.0], [0.0, 0.0]])
    src, dst = jnp.array([1, 0]), jnp.array([0, 1])
    y = {"q": q, "omega": omega}
    out = law.outbox(y, ())
    inbox = Inbox({k: v[:, src] for k, v in out.items()}, jnp.ones(2), dst, {})
    commands, _, record = law.step(0.0, y, inbox, (), None)
    u = np.asarray(commands["torque_b"])
    # sat1: H(q_2* q_1) = (0, 0, -sin 5 deg); s = [0.3 * 0.01 + 0.1 * 0.01, 0, -0.2 sin 5 deg].
    s1 = np.array([0.004, 0.0, -0.2 * np.sin(h)])
    s2 = np.array([-0.003, 0.0, 0.2 * np.sin(h)])
    np.testing.assert_allclose(u[:, 0], -0.015 * np.tanh(s1 / 0.015), rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(u[:, 1], -0.015 * np.tanh(s2 / 0.015), rtol=1e-12, atol=1e-18)
    np.testing.assert_array_equal(np.asarray(record["torque_command"]), u)
    # The same links as a padded in-neighbour table (d = 1, n = 2) give the same command.
    padded = Inbox({k: v[:, None, ::-1] for k, v in out.items()}, jnp.ones((1, 2)), jnp.array([[0, 1]]), {})
    np.testing.assert_allclose(np.asarray(law.step(0.0, y, padded, (), None)[0]["torque_b"]), u, rtol=1e-14)
