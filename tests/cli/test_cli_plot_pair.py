"""``coopsat plot`` redraws a run folder's figures from result.nc (and refuses one it does not
have); ``coopsat pair`` compares time series B − A for every family, or writes no time-series
file when the two runs have none in common (never an empty pair.png or pair.nc)."""

import pytest
import xarray as xr

from coopsat.cli import EXIT_BAD_INPUT, main
from coopsat.workflows.pipeline import run_scenario

SHORT = "sim.t_final_s=1"


def run_main(capsys, argv):
    status = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


@pytest.fixture(scope="module")
def run_folder(tmp_path_factory):
    folder = tmp_path_factory.mktemp("plot") / "run"
    run_scenario("consensus-sync-a-stable", out_dir=folder, overrides=[SHORT], figures=False)
    return folder


def test_plot_redraws_a_named_figure_from_the_record(run_folder, tmp_path, capsys):
    status, out, _ = run_main(capsys, ["plot", run_folder, "--what", "attitude", "--out", tmp_path / "figs"])
    assert status == 0 and "attitude.png" in out
    assert sorted(p.name for p in (tmp_path / "figs").iterdir()) == ["attitude.png"]
    assert not list(run_folder.glob("*.png"))  # --out: the run folder is left as it was


def test_plot_refuses_a_figure_the_run_does_not_have(run_folder, tmp_path, capsys):
    status, out, err = run_main(capsys, ["plot", run_folder, "--what", "attitude", "wheels", "--out", tmp_path / "figs"])
    assert status == EXIT_BAD_INPUT and not out
    (line,) = err.strip().splitlines()
    assert "no figure wheels" in line and "attitude, rates, torque_sat1, sync_error, thrusters" in line
    assert not (tmp_path / "figs").exists()


def test_pair_of_consensus_runs_writes_b_minus_a_series(tmp_path, capsys):
    out_dir = tmp_path / "pair"
    status, out, _ = run_main(capsys, ["pair", "consensus-sync-a-stable", "consensus-sync-b-stable", "--seeds", "1",
                                       "--set", SHORT, "--out", out_dir, "-q"])
    assert status == 0 and "time series B − A: attitude_error_formation_deg, attitude_spread_deg" in out
    with xr.open_dataset(out_dir / "pair.nc", engine="h5netcdf") as ds:
        diffs = [n for n in ds.data_vars if n.endswith("_b_minus_a")]
        assert "attitude_spread_deg_b_minus_a" in diffs and "effort_n_m_s_b_minus_a" in diffs
        assert ds["attitude_spread_deg_b_minus_a"].attrs["units"] == "deg"
        assert abs(ds["effort_n_m_s_b_minus_a"]).max() > 0  # ring (a) against complete graph (b) differ
    assert (out_dir / "pair.png").stat().st_size > 0


def test_pair_with_no_series_in_common_writes_no_time_series_file(tmp_path, capsys):
    # One torque-free spacecraft: no pairwise spread, no reference, no effort: nothing over time.
    out_dir = tmp_path / "pair"
    status, out, _ = run_main(capsys, ["pair", "orbit-two-body", "orbit-two-body", "--seeds", "1",
                                       "--set", "sim.t_final_s=10", "--out", out_dir, "-q"])
    assert status == 0 and "time series: none that both runs have" in out
    assert sorted(p.name for p in out_dir.iterdir()) == ["pair.json", "pair.md"]
    assert "none that both runs have" in (out_dir / "pair.md").read_text()
