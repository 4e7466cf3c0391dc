"""Design results solved once per exact input in a process.

A campaign builds every run from its own dispersed scenario, and most of its design-time
problems do not depend on what was dispersed: the same LMI, or the same bisection over LMIs,
came back run after run (a ``delay-designed`` run spent 1 s of its build certifying one of
eight delay bounds, a ``deepspace`` run 0.18 s designing an observer on an undispersed model,
an ``observation`` run 0.3 s propagating its undispersed orbits to find when the target rises,
a consensus run 7 ms in the sampled-data bisection when its inertias are not dispersed).
The solvers are deterministic, so a result looked up by the exact bytes of its inputs is the
result a new solve would give.
"""

import copy
import functools

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
            result = fn(*args, **kwargs)
            if len(cache) >= MAX_ENTRIES:
                cache.pop(next(iter(cache)))
            cache[key] = result
        return copy.deepcopy(cache[key])

    memoized.cache = cache
    return memoized
