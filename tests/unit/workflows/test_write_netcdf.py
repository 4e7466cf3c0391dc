"""The run record is written without xarray's to_netcdf, and is the same file to a reader."""

import subprocess
import sys

import numpy as np
import xarray as xr

from coopsat.workflows.folders import write_netcdf


def test_the_record_reads_back_as_to_netcdf_writes_it(tmp_path):
    ds = xr.Dataset(
        {"q": (("time", "spacecraft", "q_component"), np.random.default_rng(1).normal(size=(5, 2, 4)), {"units": "1"}),
         "fired": (("time",), np.array([0, 1, 0, 2, 1], dtype=np.int64))},
        coords={"time": np.linspace(0.0, 2.0, 5), "spacecraft": ["sat1", "sat2"]},
        attrs={"scenario_toml": "name = 'x'\n", "seed": 3, "run_time_s": 0.25},
    )
    write_netcdf(ds, tmp_path / "ours.nc")
    ds.to_netcdf(tmp_path / "xarray.nc", engine="h5netcdf")
    with xr.open_dataset(tmp_path / "ours.nc", engine="h5netcdf") as ours, \
            xr.open_dataset(tmp_path / "xarray.nc", engine="h5netcdf") as theirs:
        assert ours.identical(theirs) and ours.identical(ds)
        assert ours["fired"].dtype == np.int64 and ours.attrs["seed"] == 3


def test_writing_the_record_imports_no_dask_scheduler(tmp_path):
    script = (
        "import sys, numpy as np, xarray as xr\n"
        "from coopsat.workflows.folders import write_netcdf\n"
        f"write_netcdf(xr.Dataset({{'x': ('t', np.arange(3.0))}}), {str(tmp_path / 'r.nc')!r})\n"
        "print('dask.distributed' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"
