"""The command's process checks "is this a Dask array?" without importing dask.array, and
Dask arrays stay Dask arrays (coopsat.core.lazy_dask). Each case runs in a fresh interpreter:
what is imported, and when, is the point."""

import subprocess
import sys
import textwrap
import types

from coopsat.core import lazy_dask


def _fresh(code, tmp_path):
    out = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, timeout=300,
                         cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    return out.stdout.split()


def test_a_run_record_is_built_and_written_without_importing_dask_array(tmp_path):
    said = _fresh("""
        import sys
        from coopsat.core import lazy_dask
        lazy_dask.install()
        import numpy as np, xarray as xr
        ds = xr.Dataset({"q": (("time", "spacecraft"), np.zeros((3, 2)))}, coords={"time": [0.0, 1.0, 2.0]})
        ds.to_netcdf("r.nc", engine="h5netcdf")
        with xr.open_dataset("r.nc", engine="h5netcdf") as back:
            back.load()
        from xarray.namedarray.pycompat import _cached_duck_array_modules as cache
        print("dask.array" in sys.modules, cache["dask"].type == (lazy_dask.DaskArray,))
        """, tmp_path)
    # Fails when an xarray release changes its private cache and the stand-in declines (then
    # every run pays dask.array's import again): the bound on xarray in pyproject.toml is
    # raised only with this test passing.
    assert said == ["False", "True"]


def test_dask_arrays_are_still_recognised_once_dask_array_is_imported(tmp_path):
    """Wrapped lazily, opened in chunks: xarray sees Dask arrays as before."""
    said = _fresh("""
        from coopsat.core import lazy_dask
        lazy_dask.install()
        import numpy as np, xarray as xr
        xr.Dataset({"q": ("x", np.arange(4.0))}).to_netcdf("r.nc", engine="h5netcdf")
        import dask.array as da
        from xarray.namedarray.pycompat import array_type
        wrapped = xr.DataArray(da.zeros((4, 3), chunks=2), dims=("x", "y"))
        with xr.open_dataset("r.nc", engine="h5netcdf", chunks={}) as opened:
            print(array_type("dask")[0] is lazy_dask.DaskArray, wrapped.chunks is not None,
                  isinstance(wrapped.data, da.Array), opened["q"].chunks is not None,
                  float((wrapped + 1).sum().compute()), isinstance(np.zeros(2), array_type("dask")))
        """, tmp_path)
    assert said == ["True", "True", "True", "True", "12.0", "False"]


def test_a_cache_of_another_shape_is_left_alone():
    assert not lazy_dask.seed(types.SimpleNamespace())
    changed = types.SimpleNamespace(_cached_duck_array_modules=[], DuckArrayModule=object)
    assert not lazy_dask.seed(changed) and changed._cached_duck_array_modules == []
