"""``coopsat export`` (docs/export.md): the done-when of issue 29 item 3 through the command, and
its refusals: one ``coopsat: error:`` line, exit 2, no traceback, no file."""

import numpy as np
import pytest

import coopsat
from coopsat.cli import EXIT_BAD_INPUT, main


def _run_dir(tmp_path_factory, name, t_final_s):
    result = coopsat.run(coopsat.Scenario.load(name).set("sim.t_final_s", t_final_s))
    out = tmp_path_factory.mktemp(name)
    result.dataset.to_netcdf(out / "result.nc", engine="h5netcdf")
    return out, result.dataset


@pytest.fixture(scope="module")
def gravity_gradient(tmp_path_factory):
    return _run_dir(tmp_path_factory, "rigid-body-gravity-gradient", 20.0)


def test_export_writes_an_oem_and_an_aem_that_two_readers_read_back(gravity_gradient, tmp_path, capsys):
    import oem as oem_lib
    from ccsds_ndm.ndm_io import NdmIo

    run_dir, ds = gravity_gradient
    assert main(["export", str(run_dir), "--format", "oem", "--out", str(tmp_path / "orbit.oem")]) == 0
    assert main(["export", str(run_dir), "--format", "aem"]) == 0
    assert capsys.readouterr().out.splitlines() == [f"wrote {tmp_path / 'orbit.oem'}",
                                                     f"wrote {run_dir / 'rigid-body-gravity-gradient.aem'}"]
    (segment,) = list(oem_lib.OrbitEphemerisMessage.open(tmp_path / "orbit.oem"))
    np.testing.assert_allclose(np.array([s.position for s in segment]), ds.r_eci.values[:, 0] / 1e3, rtol=1e-15, atol=0)
    states = NdmIo().from_path(tmp_path / "orbit.oem").body.segment[0].data.state_vector
    np.testing.assert_allclose([s.z_dot.value for s in states], ds.v_eci.values[:, 0, 2] / 1e3, rtol=1e-15, atol=0)
    attitude = NdmIo().from_path(run_dir / "rigid-body-gravity-gradient.aem").body.segment[0].data.attitude_state
    np.testing.assert_array_equal([s.quaternion_state.quaternion.q3 for s in attitude], ds.q.values[:, 0, 3])


@pytest.mark.parametrize("fmt", ["oem", "czml"])
def test_an_attitude_only_run_is_refused_positions_in_one_line(tmp_path_factory, fmt, capsys):
    run_dir, _ = _run_dir(tmp_path_factory, "consensus-sync-a-stable", 1.0)
    out = run_dir / f"out.{fmt}"
    assert main(["export", str(run_dir), "--format", fmt, "--out", str(out)]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert err.startswith("coopsat: error: consensus-sync-a-stable: ") and "no [orbit]" in err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert sorted(p.name for p in run_dir.iterdir()) == ["result.nc"]


def test_bad_input_is_one_line(tmp_path, capsys):
    assert main(["export", str(tmp_path), "--format", "oem"]) == EXIT_BAD_INPUT
    assert capsys.readouterr().err == f"coopsat: error: {tmp_path}: not a run folder (no result.nc; write one with coopsat run)\n"


def test_an_unknown_format_is_one_line(gravity_gradient, capsys):
    assert main(["export", str(gravity_gradient[0]), "--format", "kml"]) == EXIT_BAD_INPUT
    assert capsys.readouterr().err == "coopsat: error: format 'kml': choose one of oem, aem, czml\n"
