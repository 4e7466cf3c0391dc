"""How many runs of a batch one compiled call may hold: the device's memory against a run's.

A batch is simulated as one vmapped program (:mod:`coopsat.sim.batching`); on a GPU its whole
working set lives in the device's memory, so a batch of 1e5 runs must be cut into calls that
fit. A run's share is its loop state and one chunk of its record, from their shapes alone
(``jax.eval_shape``: nothing is allocated), the state counted :data:`WORKING_COPIES` times for
the integrator's stages. The engine runs a larger batch part after part
(:func:`coopsat.sim.engine.simulate_as_built`).
"""

import functools
import math
import os

import jax
import jax.numpy as jnp
import numpy as np

DEVICE_SHARE = 0.5
"""Share of the device's memory one call's runs may take: the rest is XLA's temporaries, the
compiled program and, on the CPU, everything else the process and the machine hold."""

WORKING_COPIES = 6
"""Copies of a run's loop state one integration step holds at once: the state, RK4's four
stage derivatives and the next state."""


def device_memory_bytes(device=None):
    """Memory of ``device`` (default: JAX's first device), bytes: an accelerator's allocator
    limit (``memory_stats()["bytes_limit"]``), else the machine's physical memory."""
    device = device or jax.devices()[0]
    stats = device.memory_stats() if device.platform != "cpu" else None
    if stats and stats.get("bytes_limit"):
        return int(stats["bytes_limit"])
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


def _nbytes(tree):
    return sum(math.prod(leaf.shape) * np.dtype(leaf.dtype).itemsize for leaf in jax.tree_util.tree_leaves(tree))


def run_bytes(system, chunk):
    """Device bytes one run of a batch holds during a compiled call: :data:`WORKING_COPIES` ×
    its loop state plus one chunk of its record.

    Parameters
    ----------
    system : System
        One run (interface layout; a batch's leaves without their leading axis); its leaves
        may be ``jax.ShapeDtypeStruct``.
    chunk : int
        Record intervals per compiled call.
    """
    leaves, treedef = jax.tree_util.tree_flatten(system)
    return _run_bytes(treedef, tuple(jax.ShapeDtypeStruct(np.shape(v), jnp.result_type(v)) for v in leaves), chunk)


@functools.lru_cache(maxsize=64)
def _run_bytes(treedef, leaves, chunk):
    """:func:`run_bytes` by the system's structure and leaf shapes: tracing the loop's shapes
    takes as long as tracing the program, once per structure, not once per call."""
    from coopsat.sim.programs import _initial_carry, _run_chunk

    system = jax.tree_util.tree_unflatten(treedef, leaves)
    carry = jax.eval_shape(_initial_carry, system)
    _, out = jax.eval_shape(lambda s, c: _run_chunk(s, c, 0, chunk, chunk), system, carry)
    return WORKING_COPIES * _nbytes(carry) + _nbytes(out)


def runs_per_call(batch_system, chunk, memory_bytes=None):
    """The most runs of ``batch_system`` one compiled call holds within :data:`DEVICE_SHARE` of
    ``memory_bytes`` (default :func:`device_memory_bytes`); at least one.

    Parameters
    ----------
    batch_system : System
        A batch (leading axis on every data leaf, :func:`~coopsat.sim.system.stack_systems`).
    chunk : int
        Record intervals per compiled call.
    """
    one = jax.tree_util.tree_map(lambda leaf: jax.ShapeDtypeStruct(np.shape(leaf)[1:], jnp.result_type(leaf)),
                                 batch_system)
    memory = device_memory_bytes() if memory_bytes is None else memory_bytes
    return max(1, int(DEVICE_SHARE * memory // run_bytes(one, chunk)))
