"""Every bundled scenario runs (short horizon) and leaves a complete, readable run folder."""

import json
from importlib import metadata
import tomllib
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from coopsat.workflows.pipeline import run_scenario
from coopsat.scenarios.load import bundled_names, load_scenario

SHORT = {"orbit-two-body": 100.0, "rigid-body-free": 2.0, "leo-iss-tle-roe": 120.0, "leo-swarm-100": 40.0}  # two 60 s records
SHORT.update({name: 500.0 for name in bundled_names() if name.startswith("deepspace-")})  # 50 s records
SHORT.update({name: 200.0 for name in bundled_names() if name.startswith("cartwheel-")})  # 10 s records, PSO every 100 s

# Every bundled scenario's metrics at these horizons, recorded at the commit before issue 27's
# moves: a move or a split must not change a result. How they are compared (tests/data/README.md):
# bit for bit on the platform they were recorded on; not at all under another jax or jaxlib,
# whose XLA generates the loop's code afresh; elsewhere at the accuracy of the least accurate
# step of the scenario's design (its "design" entry), as CROSS_PLATFORM states.
BEFORE_MOVES = json.loads((Path(__file__).resolve().parents[1] / "data" / "bundled_metrics_a315990.json").read_text())
SAME_XLA = all(metadata.version(name) == v for name, v in BEFORE_MOVES["versions"].items())

CROSS_PLATFORM = {
    # No solver: the closed loop (XLA), expm, eigenvalues. Direct and backward stable, so
    # another CPU's kernels change only the order of roundings: 1e-12 (measured: 5e-13 at most
    # between OpenBLAS's Haswell and SkylakeX kernels on one machine).
    "direct": {"rel": 1e-12, "abs": 0.0},
    # A Riccati or Lyapunov equation (SciPy's Schur methods, LAPACK): backward stable, forward
    # error up to the equation's condition number times the roundoff; 1e-9 allows a condition
    # number of 1e7. The absolute floor is for quantities that are zero but for rounding
    # (chief_eccentricity 1e-16, pso_gap_to_grid_bits: a difference of two equal worths).
    "matrix-equation": {"rel": 1e-9, "abs": 1e-12},
    # An LMI (CLARABEL, SCS). An interior-point answer is accurate to the square root of its
    # tolerance where the solution set is degenerate (Sturm 2000, error bounds for LMIs; the
    # min-γ gain lies on a flat optimal face, coopsat.design.formation_synthesis): CLARABEL's
    # default 1e-8, the loosest CLARABEL rung coopsat accepts, gives 1e-4. Measured: the
    # centroid gain moves by 5.6e-6 and the metrics by 1.0e-6 between the two kernels above.
    "lmi": {"rel": 1e-4, "abs": 1e-12},
}


def platform():
    """What decides the bits of a run's metrics: the versions of the libraries that compute them
    and the BLAS kernels NumPy and SciPy picked for this CPU (threadpoolctl)."""
    import scipy.linalg  # noqa: F401  (loads SciPy's BLAS, so that threadpoolctl lists it)
    from threadpoolctl import threadpool_info

    names = ("jax", "jaxlib", "numpy", "scipy", "cvxpy", "clarabel", "scs")
    blas = sorted(f"{i['internal_api']} {i['version']} {i.get('architecture')}" for i in threadpool_info()
                  if i["user_api"] == "blas")
    return {"versions": {n: metadata.version(n) for n in names}, "blas": blas}


def compare_recorded(record, metrics, exact):
    """``(key, recorded, ours)`` of each metric that differs from ``record`` (one scenario's
    entry) beyond what the comparison policy allows (``exact``: on the recorded platform);
    ``[]`` when they agree."""
    if set(metrics) != set(record["metrics"]):
        return [("names", sorted(record["metrics"]), sorted(metrics))]
    tol = CROSS_PLATFORM[record["design"]]
    out = []
    for key, value in metrics.items():
        old = record["metrics"][key]
        if old is None or value is None:
            agrees = value is old  # reached in one and not the other
        else:
            agrees = value == old if exact else value == pytest.approx(old, **tol)
        if not agrees:
            out.append((key, old, value))
    return out


def _assert_metrics_as_before(name, t_final, metrics):
    before = BEFORE_MOVES["scenarios"].get(name)
    if before is None or not SAME_XLA:  # a scenario added after the moves; another XLA
        return
    assert before["t_final_s"] == t_final
    assert compare_recorded(before, metrics, exact=platform() == BEFORE_MOVES["platform"]) == []


def test_the_comparison_policy_tells_rounding_from_a_change():
    record = {"design": "lmi", "metrics": {"gain_error_m": 2.0, "never_s": None}}
    assert compare_recorded(record, {"gain_error_m": 2.0 * (1 + 5e-5), "never_s": None}, exact=False) == []
    assert compare_recorded(record, {"gain_error_m": 2.0 * (1 + 5e-5), "never_s": None}, exact=True) != []
    assert compare_recorded(record, {"gain_error_m": 2.0, "never_s": None}, exact=True) == []
    assert compare_recorded(record, {"gain_error_m": 2.0 * (1 + 5e-4), "never_s": None}, exact=False) != []
    assert compare_recorded(record, {"gain_error_m": 2.0, "never_s": 3.0}, exact=False) != []
    assert compare_recorded(record, {"gain_error_m": 2.0}, exact=False) != []
    direct = {"design": "direct", "metrics": {"spread_deg": 1.0}}
    assert compare_recorded(direct, {"spread_deg": 1.0 + 5e-13}, exact=False) == []
    assert compare_recorded(direct, {"spread_deg": 1.0 + 5e-12}, exact=False) != []
    assert all(set(entry) == {"design", "metrics", "t_final_s"} and entry["design"] in CROSS_PLATFORM
               for entry in BEFORE_MOVES["scenarios"].values())


@pytest.mark.parametrize("name", bundled_names())
def test_bundled_scenario_runs_and_writes_its_folder(name, tmp_path):
    t_final = SHORT.get(name, 5.0)
    run_scenario(name, out_dir=tmp_path / name, overrides=[f"sim.t_final_s={t_final}"], figures=False)
    folder = tmp_path / name
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]  # no temporary folder left behind
    with xr.open_dataset(folder / "result.nc", engine="h5netcdf") as ds:
        # The attitude: a quaternion, or small angles in the small-angle model (SPEC §3).
        attitude = "angle" if "angle" in ds else "q"
        assert {attitude, "omega"} <= set(ds.data_vars)
        effort = "torque" if "torque" in ds else "force"  # a torque or a force actuator
        if load_scenario(name).actuator_list:
            assert ds[effort].attrs["units"] == {"torque": "N m", "force": "N"}[effort]
        else:  # free flight (leo-pair-differential-drag-free): nothing acts but the environment
            assert "torque" not in ds and "force" not in ds
        if attitude == "q":
            assert ds.q.dims == ("time", "spacecraft", "q_component") and ds.sizes["q_component"] == 4
        else:
            assert ds.angle.dims == ("time", "spacecraft", "component") and ds.angle.attrs["units"] == "rad"
        assert ds.omega.attrs["units"] == "rad/s"
        assert ds.time.values[-1] == pytest.approx(t_final)
        assert np.all(np.isfinite(ds[attitude].values))
        resolved = tomllib.loads(ds.attrs["scenario_toml"])
        assert resolved["name"] == name and ds.attrs["coopsat_version"] and "seed" in ds.attrs
        # The stored scenario replays: it validates to the scenario that ran.
        replay = tmp_path / "replay.toml"
        replay.write_text(ds.attrs["scenario_toml"])
        assert load_scenario(replay).model_dump() == load_scenario(name, [f"sim.t_final_s={t_final}"]).model_dump()
    metrics = json.loads((folder / "metrics.json").read_text())
    assert all(v is None or isinstance(v, (int, float)) for v in metrics.values())
    _assert_metrics_as_before(name, t_final, metrics)
    if load_scenario(name).published:
        rows = json.loads((folder / "comparison.json").read_text())
        assert rows and all(
            set(r) >= {"quantity", "unit", "published", "ours", "verdict", "reason"} and r["verdict"] in ("agrees", "differs")
            for r in rows
        )
        assert (folder / "comparison.md").read_text().startswith("# ")


def test_figures_are_drawn_on_request(tmp_path):
    run_scenario("consensus-track", out_dir=tmp_path / "plain", overrides=["sim.t_final_s=5.0"])
    assert not list((tmp_path / "plain").glob("*.png")) and (tmp_path / "plain" / "report.html").is_file()
    run_scenario("consensus-track", out_dir=tmp_path / "r", overrides=["sim.t_final_s=5.0"], figures=True)
    names = {p.name for p in (tmp_path / "r").iterdir()}
    assert {"attitude.png", "rates.png", "torque_sat1.png", "sync_error.png"} <= names
    for png in (tmp_path / "r").glob("*.png"):
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_rerun_replaces_the_folder_atomically(tmp_path):
    out = tmp_path / "r"
    run_scenario("rigid-body-free", out_dir=out, overrides=["sim.t_final_s=1.0"], figures=False)
    (out / "stale.txt").write_text("from an earlier run")
    run_scenario("rigid-body-free", out_dir=out, overrides=["sim.t_final_s=2.0"], figures=False)
    assert not (out / "stale.txt").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r"]
