"""The ``coopsat`` command's own process: xarray's "is this a Dask array?" without importing
``dask.array`` while no Dask array can exist.

xarray asks ``isinstance(data, array_type("dask"))`` of every Variable it builds, and its
``array_type`` imports ``dask.array`` to learn that class: 1.2–1.4 s of a 7 s ``coopsat run``
on the development machine (it pulls in scipy.fft, pyarrow and the rest), for a run that never
makes a Dask array. Until ``dask.array`` is imported no object can be one of its arrays, so the
check can answer False without it, and must be the real check once anything has imported it.
:func:`install` puts a class that does exactly that into xarray's cache of duck-array modules
as soon as xarray defines the cache.

It touches xarray's private cache (``xarray.namedarray.pycompat``), so it checks the cache's
shape first and does nothing if that has changed (the import is then paid, as before). A
library import never calls it: :func:`coopsat.cli.configure_process` does, for the command's
own process and the test suite's (docs/api.md).
"""

import importlib.abc
import importlib.util
import sys

PYCOMPAT = "xarray.namedarray.pycompat"
"""The module that holds xarray's cache of duck-array modules."""


class _DaskArrayOnceImported(type):
    def __instancecheck__(cls, obj):
        dask_array = sys.modules.get("dask.array")
        return dask_array is not None and isinstance(obj, dask_array.Array)


class DaskArray(metaclass=_DaskArrayOnceImported):
    """``isinstance(x, DaskArray)`` is ``isinstance(x, dask.array.Array)``, False (without an
    import) while ``dask.array`` is not imported."""


def seed(pycompat):
    """Put :class:`DaskArray` into ``pycompat``'s cache as the type of ``"dask"``, with Dask's
    installed version; returns whether it did (not when Dask is not installed, the entry is
    already there, ``dask.array`` is already imported, or the cache is not the one expected)."""
    cache = getattr(pycompat, "_cached_duck_array_modules", None)
    entry_type = getattr(pycompat, "DuckArrayModule", None)
    if not isinstance(cache, dict) or not isinstance(entry_type, type) or "dask" in cache or "dask.array" in sys.modules:
        return False
    from importlib.metadata import PackageNotFoundError, version

    from packaging.version import Version  # xarray's own dependency (pycompat uses it)

    try:
        dask_version = Version(version("dask"))
    except PackageNotFoundError:
        return False  # no Dask: xarray learns that without a costly import
    entry = object.__new__(entry_type)  # the fields DuckArrayModule.__init__ sets, without its import
    entry.module, entry.version, entry.type, entry.available = None, dask_version, (DaskArray,), True
    cache["dask"] = entry
    return True


class _SeedWhenImported(importlib.abc.MetaPathFinder):
    """Finds nothing itself; when :data:`PYCOMPAT` is imported, seeds it right after it runs."""

    def find_spec(self, name, path, target=None):
        if name != PYCOMPAT:
            return None
        sys.meta_path.remove(self)  # once, and out of the way of the search below
        spec = importlib.util.find_spec(name)
        if spec is not None and spec.loader is not None and hasattr(spec.loader, "exec_module"):
            run = spec.loader.exec_module

            def run_and_seed(module):
                run(module)
                seed(module)

            spec.loader.exec_module = run_and_seed
        return spec


def install():
    """Seed xarray's cache now if xarray is loaded, else as soon as it is. Idempotent."""
    if PYCOMPAT in sys.modules:
        seed(sys.modules[PYCOMPAT])
    elif not any(isinstance(f, _SeedWhenImported) for f in sys.meta_path):
        sys.meta_path.insert(0, _SeedWhenImported())
