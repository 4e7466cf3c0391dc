"""A plug-in that fails never costs the run.

A package made here registers a controller, ``probe-sync`` (coopsat's consensus law under
another kind), whose analysis module each test writes: with only ``metrics()``, with metrics
or figures that raise, with a malformed member. ``coopsat`` runs in a subprocess with the
package on PYTHONPATH, as an installed package would be found.
"""

import json
import subprocess
import sys
import textwrap

import pytest
import xarray as xr

from plugins.test_entry_points import coopsat_cmd, fake_distribution

PLUGIN = textwrap.dedent('''
    from typing import Literal

    from coopsat.plugins import Plugin, register
    from coopsat.plugins.consensus import ConsensusSync, _build


    class ProbeSync(ConsensusSync):
        kind: Literal["probe-sync"]


    register(Plugin("controller", "probe-sync", ProbeSync, _build, (), "coopsat_probe_analysis"))
''')

SCENARIO = textwrap.dedent('''
    name = "probe"
    [sim]
    t_final_s = 2.0
    dt_s = 0.01
    record_interval_s = 0.5
    [[spacecraft]]
    inertia_kgm2 = [1.0, 0.1, 0.9]
    q_bi = [0.75, 0.57, 0.30, -0.03]
    omega_b_rad_s = [0.05, 0.0, 0.05]
    [[spacecraft]]
    inertia_kgm2 = [1.5, 0.9, 2.0]
    q_bi = [0.89, 0.35, -0.21, 0.16]
    omega_b_rad_s = [0.05, 0.1, 0.0]
    [network]
    kind = "edges"
    edges = [["sat1", "sat2", 1.0]]
    [controller]
    kind = "probe-sync"
    period_s = 0.01
    alpha = 1.0
    beta = 2.0
    [actuators]
    kind = "pwm-thrusters"
    torque_max_nm = 0.05
    min_pulse_s = 0.001
''')

ONLY_METRICS = "def metrics(ds, built):\n    return {'probe_samples': float(ds.sizes['time'])}\n"


def probe(tmp_path, analysis, figures_module=None):
    """The probe package with ``analysis`` as its analysis module's text, and the scenario."""
    modules = {"coopsat_probe": PLUGIN, "coopsat_probe_analysis": analysis}
    if figures_module is not None:
        modules["coopsat_probe_figures"] = figures_module
    site = fake_distribution(tmp_path / "site", "coopsat-probe", {"probe": "coopsat_probe"}, modules)
    scenario = tmp_path / "probe.toml"
    scenario.write_text(SCENARIO)
    return site, scenario


def test_a_module_with_only_metrics_runs_and_writes_its_folder(tmp_path):
    site, scenario = probe(tmp_path, ONLY_METRICS)
    out = tmp_path / "run"
    proc = coopsat_cmd(["run", str(scenario), "--out", str(out)], site)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert json.loads((out / "metrics.json").read_text())["probe_samples"] == 5.0
    assert {"result.nc", "metrics.json", "report.html", "run.json"} <= {p.name for p in out.iterdir()}
    assert proc.stdout.splitlines()[-1] == f"report: {out / 'report.html'}"


def test_metrics_that_raise_leave_the_record_and_one_line(tmp_path):
    site, scenario = probe(tmp_path, "def metrics(ds, built):\n    return {'ratio': 1 / 0}\n")
    out = tmp_path / "run"
    proc = coopsat_cmd(["run", str(scenario), "--out", str(out)], site)
    assert proc.returncode == 3
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr
    line = proc.stderr.strip()
    assert "metrics stage failed in analysis module 'coopsat_probe_analysis'" in line
    assert "controller 'probe-sync' of coopsat-probe (coopsat_probe)" in line and "ZeroDivisionError" in line
    assert str(out) in line
    with xr.open_dataset(out / "result.nc", engine="h5netcdf") as ds:
        assert ds.sizes["time"] == 5  # the simulated run is kept
    metrics = json.loads((out / "metrics.json").read_text())
    assert "ratio" not in metrics and "final_rate_max_rad_s" in metrics  # coopsat's own metrics are there
    assert (out / "report.html").is_file()


def test_figures_that_raise_leave_the_other_figures(tmp_path):
    figures = "def figures(ds, built):\n    raise RuntimeError('no axes\\nfor this')\n"
    site, scenario = probe(tmp_path, ONLY_METRICS + "FIGURES = 'coopsat_probe_figures'\n", figures)
    out = tmp_path / "run"
    proc = coopsat_cmd(["run", str(scenario), "--out", str(out), "--figures"], site)
    assert proc.returncode == 3
    assert proc.stderr.strip().count("\n") == 0
    assert "figures stage failed in analysis module 'coopsat_probe_analysis'" in proc.stderr
    assert "RuntimeError: no axes; for this" in proc.stderr
    names = {p.name for p in out.iterdir()}
    assert {"result.nc", "metrics.json", "report.html", "attitude.png"} <= names


@pytest.mark.parametrize(("member", "text"), [
    ("EXPLAINERS", "EXPLAINERS = ['not', 'a', 'dict']\n"),
    ("metrics", "metrics = 3.0\n"),
    ("FIGURES", "FIGURES = object\n"),
])
def test_a_malformed_member_is_one_line_before_the_run(tmp_path, member, text):
    site, scenario = probe(tmp_path, text)
    proc = coopsat_cmd(["validate", str(scenario)], site)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert proc.stderr.startswith(f"coopsat: error: analysis module 'coopsat_probe_analysis' of plug-in controller "
                                  f"'probe-sync' of coopsat-probe (coopsat_probe): {member} must be")
    out = tmp_path / "run"
    assert coopsat_cmd(["run", str(scenario), "--out", str(out)], site).returncode == 2
    assert not out.exists()


def test_a_malformed_registration_is_one_line(tmp_path):
    bad = PLUGIN.replace("ProbeSync, _build, ()", "ProbeSync, 'not callable', ()")
    site = fake_distribution(tmp_path / "site", "coopsat-probe", {"probe": "coopsat_probe"}, {"coopsat_probe": bad})
    proc = coopsat_cmd(["validate", "rigid-body-free"], site)
    assert proc.returncode == 2
    assert proc.stderr.strip() == (
        "coopsat: error: plug-in controller 'probe-sync' of coopsat-probe (coopsat_probe): build must be a function "
        "(table, ctx) -> part")


def test_the_library_raises_with_the_partial_result(tmp_path):
    site, scenario = probe(tmp_path, "def metrics(ds, built):\n    return {'ratio': 1 / 0}\n")
    script = textwrap.dedent(f'''
        import sys
        sys.path.insert(0, {str(site)!r})
        import coopsat
        try:
            coopsat.run({str(scenario)!r})
        except coopsat.StageError as err:
            print(len(err.failures), err.failures[0].stage, err.result.dataset.sizes["time"], err.out_dir)
            err.result.save({str(tmp_path / "saved")!r})
    ''')
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.split() == ["1", "metrics", "5", "None"]
    assert (tmp_path / "saved" / "result.nc").is_file()


def test_software_in_the_loop_keeps_its_run_too(tmp_path):
    site, scenario = probe(tmp_path, "def metrics(ds, built):\n    return {'ratio': 1 / 0}\n")
    out = tmp_path / "sil"
    proc = coopsat_cmd(["sil", str(scenario), "--out", str(out), "-q", "--set", "sim.t_final_s=1.0"], site)
    assert proc.returncode == 3, proc.stderr[-3000:]
    assert proc.stderr.strip().count("\n") == 0 and "metrics stage failed in analysis module" in proc.stderr
    with xr.open_dataset(out / "result.nc", engine="h5netcdf") as ds:
        assert ds.sizes["time"] == 3 and "sil_events" in ds.attrs
