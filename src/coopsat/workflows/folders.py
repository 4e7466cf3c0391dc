"""Output folders written atomically, and the JSON they hold.

Every command that writes a folder (``run``, ``sweep``, ``pair``, ``tune``, ``tradeoff``,
``campaign report``) fills a temporary sibling and renames it into place only once it is
complete, so that a failure or an interrupt leaves nothing half-written, and an existing folder
is replaced only by a complete one.
"""

import os
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from coopsat.workflows import interrupt


def write_netcdf(ds, path):
    """Write a Dataset of NumPy arrays to ``path`` as netCDF-4 (HDF5, through h5netcdf): the file
    ``ds.to_netcdf(path, engine="h5netcdf")`` writes.

    Through xarray's public store (``xarray.backends.H5NetCDFStore``, ``Dataset.dump_to_store``)
    rather than ``to_netcdf``, which imports Dask and ``dask.distributed`` whenever Dask is
    installed to ask which scheduler would close the file and which lock to take (0.3–0.45 s of
    a 2.5 s ``coopsat run`` on the development machine): a record of NumPy arrays written to a
    new file has no scheduler to ask, and takes xarray's process-wide HDF5 lock only (the HDF5
    library is not thread-safe).
    """
    import xarray as xr
    from xarray.backends.locks import HDF5_LOCK

    store = xr.backends.H5NetCDFStore.open(str(path), mode="w", lock=HDF5_LOCK)
    try:
        ds.dump_to_store(store)
    finally:
        store.close()


def json_ready(obj):
    """Plain JSON: NumPy scalars to Python, non-finite numbers to null (strict JSON has neither),
    floats to 15 significant digits (so that 0.05·0.001/0.01 prints as 0.005, not
    0.005000000000000001; float64 carries 15–17, the last ones rounding noise)."""
    if isinstance(obj, dict):
        return {k: json_ready(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [json_ready(v) for v in obj]
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float):
        return float(f"{obj:.15g}") if np.isfinite(obj) else None
    return obj


def _umask():
    """The process's file-mode creation mask (read by setting and restoring it)."""
    mask = os.umask(0)
    os.umask(mask)
    return mask


def check_folder(out_dir, marker, what, error):
    """Refuse, before anything runs, a target that is not a ``what`` folder (one holding
    ``marker``) or cannot be created.

    Raises
    ------
    error
        The caller's exception class, with one line naming ``--out`` and the cause.
    """
    out_dir = Path(out_dir)
    if out_dir.exists() and not (out_dir.is_dir() and (out_dir / marker).is_file()):
        raise error(f"{out_dir}: exists and is not a {what} folder (no {marker}); choose another folder or remove it")
    parent = unwritable_parent(out_dir)
    if parent is not None:
        raise error(f"{out_dir}: cannot create a folder under {parent}")


def unwritable_parent(path):
    """The nearest existing folder above ``path`` when it cannot be written in (where ``path``
    would be created), else None."""
    parent = Path(path).parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    return None if parent.is_dir() and os.access(parent, os.W_OK) else parent


def write_text_atomically(path, text):
    """Write ``text`` (UTF-8) to the file ``path`` through a temporary sibling, so that a failure
    or an interrupt leaves the old file or none, never half of one; the rule of run folders
    (:mod:`coopsat.workflows.interrupt`): a stop requested before the rename writes nothing,
    one after it is told the file is complete."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        tmp.write_text(text, encoding="utf-8")
        interrupt.check()
        with interrupt.holding():
            os.replace(tmp, path)
            interrupt.wrote(path, f"the file {path} is complete")
    finally:
        tmp.unlink(missing_ok=True)


def _rename_into_place(tmp, out_dir):
    """Rename the finished folder ``tmp`` to ``out_dir``, replacing a folder there."""
    if out_dir.exists():
        # Move the old folder aside first, so that the new one is in place before the old
        # one is deleted (a crash in between leaves a hidden sibling, never no folder).
        trash = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}.old.", dir=out_dir.parent))
        out_dir.rename(trash / out_dir.name)
        tmp.rename(out_dir)
        shutil.rmtree(trash, ignore_errors=True)
    else:
        tmp.rename(out_dir)


@contextmanager
def atomic_folder(out_dir, error):
    """Yield a temporary sibling of ``out_dir`` to fill; on success it replaces ``out_dir``, on
    any exception (an interrupt included) it is removed and ``out_dir`` is left as it was.

    A stop requested by a signal before the rename raises here (:class:`~coopsat.workflows.
    interrupt.Interrupted`: nothing written); one during or after it leaves the complete folder,
    noted for the command's last line (:mod:`coopsat.workflows.interrupt`).

    Raises
    ------
    error
        When the temporary folder cannot be created (the caller's exception class).
    """
    out_dir = Path(out_dir)
    try:
        out_dir.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}.", dir=out_dir.parent))
        tmp.chmod(0o777 & ~_umask())  # mkdtemp makes it private (0700); an output folder follows the umask
    except OSError as err:
        raise error(f"{out_dir}: {err.strerror or err}") from None
    try:
        yield tmp
        interrupt.check()  # a stop requested until now leaves nothing (the rule of interrupt.py)
        with interrupt.holding():
            _rename_into_place(tmp, out_dir)
            interrupt.wrote(out_dir, f"the folder {out_dir} is complete")
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def read_result(run_dir, error):
    """A run folder's record, ``result.nc``, as a loaded Dataset: the one reader of run folders
    (``load_run``, ``plot`` and ``export`` all come through it); ``error`` (an exception class)
    names a folder without a readable record in one line."""
    import xarray as xr

    path = Path(run_dir) / "result.nc"
    if not path.is_file():
        raise error(f"{run_dir}: not a run folder (no result.nc; write one with coopsat run)")
    try:
        return xr.load_dataset(path, engine="h5netcdf")
    except (OSError, ValueError) as err:
        raise error(f"{path}: cannot be read as a run's result ({err})") from None
