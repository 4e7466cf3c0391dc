"""docs/plugins.md's plug-in, shipped as §7 says: its file (§1's block, taken from the page)
saved as ``pd_attitude.py`` in a package ``coopsat-pd`` with the entry point ``pd``, and
``coopsat`` run in a subprocess with that package on PYTHONPATH, as an installed one is found.

The doc test (tests/meta/test_doc_examples.py) runs the file as a script; here the same code
runs as an installed kind: from a scenario file, with figures, and with the page's error
messages, which must be what coopsat prints.
"""

import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
import xarray as xr

from plugins.test_entry_points import coopsat_cmd, fake_distribution

PAGE = Path(__file__).resolve().parents[2] / "docs" / "plugins.md"

SCENARIO = textwrap.dedent('''
    name = "pd"
    [sim]
    t_final_s = 20.0
    dt_s = 0.1
    record_interval_s = 0.5
    [spacecraft_defaults]
    inertia_kgm2 = [1.0, 0.8, 0.6]
    [[spacecraft]]
    q_bi = [0.75, 0.57, 0.30, -0.03]
    [[spacecraft]]
    q_bi = [0.89, 0.35, -0.21, 0.16]
    [controller]
    kind = "pd-attitude"
    period_s = 0.1
    k_p_nm = 0.5
    k_d_nms = 1.0
    torque_max_nm = 0.05
    q_commanded = [0.7071, 0.7071, 0.0, 0.0]
''')


def page_plugin():
    """The text of §1's file, as the page shows it."""
    (text,) = [b for b in re.findall(r"```python\n(.*?)```", PAGE.read_text(encoding="utf-8"), re.S)
               if b.startswith('"""pd_attitude.py')]
    return text


def page_errors():
    """The page's one-line messages about pd-attitude, by their distinctive words."""
    lines = [line for block in re.findall(r"```text\n(.*?)```", PAGE.read_text(encoding="utf-8"), re.S)
             for line in block.splitlines() if "'pd-attitude'" in line]
    return {key: next(line for line in lines if key in line)
            for key in ("EXPLAINERS must be", "metrics stage failed", "build must be", "registered after")}


def package(tmp_path, text):
    """The page's package with ``text`` as pd_attitude.py, and the scenario file."""
    site = fake_distribution(tmp_path / "site", "coopsat-pd", {"pd": "pd_attitude"}, {"pd_attitude": text})
    (tmp_path / "pd.toml").write_text(SCENARIO)
    return site


def test_the_installed_plugin_runs_from_a_scenario_file_with_its_figures(tmp_path):
    site = package(tmp_path, page_plugin())
    out = tmp_path / "run"
    proc = coopsat_cmd(["run", str(tmp_path / "pd.toml"), "--out", str(out), "--figures", "-q"], site)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "sat2_pointing_time_s" in (out / "metrics.json").read_text()
    with xr.open_dataset(out / "result.nc", engine="h5netcdf") as ds:
        assert ds["q_desired"].dims == ("time", "spacecraft", "q_component")
        assert ds["torque_command"].attrs["units"] == "N m"
    # q_desired recorded: the attitude figure has the panel of the error to the desired attitude
    # (§5), and coopsat plot draws it again from result.nc for an installed kind.
    from coopsat.analysis.series import run_series

    with xr.open_dataset(out / "result.nc", engine="h5netcdf") as ds:
        assert "attitude_error_desired_deg" in {s.name for s in run_series(ds)}
    assert (out / "attitude.png").is_file()
    proc = coopsat_cmd(["plot", str(out), "--what", "attitude", "--out", str(tmp_path / "again")], site)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert (tmp_path / "again" / "attitude.png").is_file()


def test_a_malformed_analysis_member_is_the_pages_line(tmp_path):
    site = package(tmp_path, page_plugin() + "\nEXPLAINERS = []\n")
    proc = coopsat_cmd(["validate", str(tmp_path / "pd.toml")], site)
    assert proc.returncode == 2
    assert proc.stderr.strip() == page_errors()["EXPLAINERS must be"]


def test_metrics_that_raise_are_the_pages_line_and_exit_3(tmp_path):
    site = package(tmp_path, page_plugin() + "\n\ndef metrics(ds, built):\n    return {'x': 1 / 0}\n")
    proc = coopsat_cmd(["run", str(tmp_path / "pd.toml"), "--out", "runs/pd", "-q"], site, cwd=tmp_path)
    assert proc.returncode == 3
    assert proc.stderr.strip() == page_errors()["metrics stage failed"]
    assert (tmp_path / "runs" / "pd" / "result.nc").is_file()


def test_a_malformed_registration_is_the_pages_line(tmp_path):
    text = page_plugin()
    assert "PdAttitudeTable, build, (" in text
    site = package(tmp_path, text.replace("PdAttitudeTable, build, (", "PdAttitudeTable, 'build', ("))
    proc = coopsat_cmd(["validate", str(tmp_path / "pd.toml")], site)
    assert proc.returncode == 2
    assert proc.stderr.strip() == page_errors()["build must be"]


def test_registering_after_a_scenario_was_loaded_is_the_pages_line(tmp_path):
    (tmp_path / "pd_attitude.py").write_text(page_plugin())
    script = textwrap.dedent('''
        import coopsat
        from coopsat.plugins import PluginError

        coopsat.Scenario.load("rigid-body-free")
        try:
            import pd_attitude
        except PluginError as err:
            print(err)
    ''')
    proc = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.strip() == page_errors()["registered after"]


@pytest.mark.parametrize("q", [[0.7071, 0.7071, 0.0, 0.0], [0.75, 0.57, 0.30, -0.03]])
def test_the_resolved_scenario_keeps_the_quaternion_as_written(tmp_path, q):
    # §2: the table holds the numbers written, so the resolved scenario replays bit for bit.
    (tmp_path / "pd_attitude.py").write_text(page_plugin())
    script = textwrap.dedent(f'''
        import pd_attitude
        import coopsat

        s = coopsat.Scenario.load("rigid-body-free").set("controller", {{
            "kind": "pd-attitude", "period_s": 0.1, "k_p_nm": 0.5, "k_d_nms": 1.0, "torque_max_nm": 0.05,
            "q_commanded": {q!r}}})
        print(s.resolved()["controller.q_commanded"])
    ''')
    proc = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert eval(proc.stdout.strip()) in (q, tuple(q))
