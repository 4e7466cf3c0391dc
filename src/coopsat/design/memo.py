"""Design results solved once per exact input in a process.

A campaign builds every run from its own dispersed scenario, and most of its design-time
problems do not depend on what was dispersed: the same LMI, or the same bisection over LMIs,
came back run after run (a ``delay-designed`` run spent 1 s of its build certifying one of
eight delay bounds, a ``deepspace`` run 0.18 s designing an observer on an undispersed model,
an ``observation`` run 0.3 s propagating its undispersed orbits to find when the target rises,
a consensus run 7 ms in the sampled-data bisection when its inertias are not dispersed).
The solvers are deterministic, so a result looked up by the exact bytes of its inputs is the
result a new solve would give.

Where the process keeps JAX's persistent compilation cache (the command line; a library user
who opted in), results are also kept on disk (:func:`coopsat.core.runtime.persistent_cache_dir`),
keyed as well by coopsat's source and the solvers' versions, so that a new process does not
solve again what the last one solved: the sampled-data bisection of ``consensus-sync-a``, 45
matrix exponentials, was 0.4 s of every ``coopsat run`` of it.
"""

import copy
import functools
import hashlib
import pickle
from importlib import metadata
from pathlib import Path

import numpy as np

MAX_ENTRIES = 256
"""Results kept per function (oldest dropped first)."""


def _key(value):
    """A hashable stand-in for ``value`` that differs whenever a bit of it does: arrays by shape,
    type and bytes, sequences element by element, anything else by ``repr`` (exact for floats;
    an object without its own ``repr`` shows its address, so it only matches itself)."""
    if isinstance(value, np.ndarray):
        return ("ndarray", value.shape, value.dtype.str, value.tobytes())
    if isinstance(value, (list, tuple)):
        return (type(value).__name__, tuple(_key(v) for v in value))
    return (type(value).__name__, repr(value))


@functools.cache
def _install_digest():
    """Hash of coopsat's source (every module: a design function calls others) and of the
    versions of Python and the numerical libraries a result depends on."""
    import sys

    root = Path(__file__).resolve().parents[1]
    digest = hashlib.sha256(sys.version.encode())
    for name in ("numpy", "scipy", "cvxpy", "clarabel", "scs"):
        try:
            digest.update(f"{name}={metadata.version(name)};".encode())
        except metadata.PackageNotFoundError:
            digest.update(f"{name}=none;".encode())
    for path in sorted(root.rglob("*.py")):
        digest.update(path.relative_to(root).as_posix().encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


def _disk_path(name, key):
    """File of the result named ``name`` for ``key`` in the persistent cache, or None when there
    is none."""
    from coopsat.core.runtime import persistent_cache_dir

    folder = persistent_cache_dir("design")
    if folder is None:
        return None
    digest = hashlib.sha256(pickle.dumps((_install_digest(), key), protocol=5)).hexdigest()[:40]
    return folder / f"{name}-{digest}.pickle"


def _load(path):
    """The result kept at ``path``: (True, result), or (False, None) when none can be read."""
    try:
        return True, pickle.loads(path.read_bytes())
    except (OSError, pickle.UnpicklingError, EOFError, AttributeError, ImportError, TypeError, ValueError):
        return False, None


def _keep(path, result):
    """Write ``result`` to ``path``; one that cannot be pickled is skipped (the cache only
    saves time)."""
    from coopsat.core.runtime import keep_in_cache

    try:
        data = pickle.dumps(result, protocol=5)
    except (pickle.PicklingError, TypeError, AttributeError):
        return
    keep_in_cache(path, data)


def kept(name, key, compute):
    """``compute()``, from the persistent cache when it holds the result named ``name`` for
    ``key`` (any picklable value that differs whenever the result would), and put there when it
    does not. Without a persistent cache, ``compute()``."""
    path = _disk_path(name, key)
    if path is not None:
        found, result = _load(path)
        if found:
            return result
    result = compute()
    if path is not None:
        _keep(path, result)
    return result


def by_value(fn):
    """Decorate a pure design function so that it is solved once per exact input.

    Each call gets its own deep copy of the stored result, so a caller that changes it cannot
    change what the next caller gets. Exceptions are not stored.
    """
    cache = {}

    @functools.wraps(fn)
    def memoized(*args, **kwargs):
        key = (_key(args), _key(sorted(kwargs.items())))
        if key not in cache:
            result = kept(f"{fn.__module__}.{fn.__qualname__}", key, lambda: fn(*args, **kwargs))
            if len(cache) >= MAX_ENTRIES:
                cache.pop(next(iter(cache)))
            cache[key] = result
        return copy.deepcopy(cache[key])

    memoized.cache = cache
    return memoized
