"""Preparing a batch of runs for the engine: one shared time base, bucket sizes, groups, padding.

A batch (:func:`~coopsat.sim.system.stack_systems`) runs as one program. Its runs share the
tick ``dt_s`` (unbatched, so time is the same traced value for all of them); it is padded with
copies of its last run to a bucket size that recurs (:func:`bucket_runs`) and to whole groups
(:func:`_batch_groups`), which are integrated one after another and shared among the devices.
"""

import math
from dataclasses import dataclass, replace

import jax
import jax.numpy as jnp
import numpy as np

from coopsat.sim.period import PeriodState

GROUP_SPACECRAFT = 1024
"""Spacecraft (runs × N) integrated together in one group of a batch: a larger batch is run
group after group (:func:`_batch_groups`), so that the RK4 stages' working set stays in the
core's cache (docs/engine-notes.md, "Groups of a batch")."""

CARRY_AXES = PeriodState(x=0, parts=0, counters=0, tick=None)
"""``vmap`` axes of a batch's carry (:class:`~coopsat.sim.period.PeriodState`). The tick stays
unbatched, so time (and every schedule indexed by it) is the same traced value for all runs: a
branch on time (a planner due every so often) stays a branch under ``vmap`` instead of becoming
a select that evaluates both sides every period."""


@dataclass(frozen=True)
class Batch:
    """A batch ready for the engine (:func:`prepare_batch`).

    Attributes
    ----------
    system : System
        Batch-first, ``dt_s`` unbatched, padded to ``groups`` × (runs per group) runs.
    axes : System
        ``vmap`` axes of ``system``'s leaves (0, and None for ``dt_s``).
    n_runs : int
        Runs asked for; the rest are padding, dropped from the results.
    groups, devices : int
        Groups integrated one after another; devices they are shared among.
    """

    system: object
    axes: object
    n_runs: int
    groups: int
    devices: int


def _shared_time_base(system):
    """A batched system with its tick ``dt_s`` unbatched, and the matching ``vmap`` axes.

    Raises
    ------
    ValueError
        When the runs of the batch have different ticks (they cannot share a time base).
    """
    dt = np.asarray(system.dt_s)
    if not np.all(dt == dt.flat[0]):
        raise ValueError(f"simulate: the runs of a batch share one time base, but their dt_s differ ({sorted(set(dt.tolist()))})")
    system = replace(system, dt_s=jnp.asarray(dt.flat[0]))
    axes = replace(jax.tree_util.tree_map(lambda _: 0, system), dt_s=None)
    return system, axes


def bucket_runs(n_runs, full):
    """Runs a batch of ``n_runs`` is padded to so that its shape recurs: the smallest
    ``ceil(full / 2^j) ≥ n_runs`` (``full``: the largest batch expected, a campaign's batch
    size; ``n_runs`` itself above it).

    A campaign batch split by structure (a dispersed delay choice changes the delay line's
    length) gives groups of every size, and each size would be its own program, traced and
    compiled again (docs/engine-notes.md, "Bucket sizes"). With these sizes a structure has at
    most ``⌈log2(full)⌉ + 1`` programs, a full batch is not padded, and a part batch less than
    doubled."""
    if n_runs >= full:
        return n_runs
    size = full
    while size > 1 and -(-size // 2) >= n_runs:
        size = -(-size // 2)
    return size


def _group_spacecraft():
    """Spacecraft in one group of a batch: :data:`GROUP_SPACECRAFT` on the CPU (its cache);
    None on an accelerator, whose parallelism is the whole batch and for which each further
    group is as many more kernel launches a tick (a GPU ran 1000 runs of N = 5, five groups, at
    86 µs a tick, docs/performance.md)."""
    return GROUP_SPACECRAFT if jax.devices()[0].platform == "cpu" else None


def _batch_groups(n_runs, n_spacecraft, devices=1):
    """(groups, runs per group) for a batch: the fewest groups of at most
    :func:`_group_spacecraft` spacecraft (one group where that is None), balanced (the last is
    padded to the same size), and a multiple of ``devices`` (to share among them)."""
    limit = _group_spacecraft()
    groups = 1 if limit is None else max(1, math.ceil(n_runs * n_spacecraft / limit))
    if devices > 1 and n_runs >= devices:
        groups = math.ceil(groups / devices) * devices
    return groups, math.ceil(n_runs / groups)


def _pad_runs(system, axes, pad):
    """``system`` with ``pad`` copies of its last run appended (their results are dropped)."""
    if not pad:
        return system
    return jax.tree_util.tree_map(
        lambda a, ax: a if ax is None else jnp.concatenate([a, jnp.repeat(a[-1:], pad, axis=0)]), system, axes
    )


def prepare_batch(system, every_core=True, bucket=None):
    """A batched ``system`` as the engine runs it: shared time base, bucket size, groups, padding.

    Parameters
    ----------
    system : System
        A batch from :func:`~coopsat.sim.system.stack_systems`.
    every_core : bool
        Share the groups among every device (else one).
    bucket : int, optional
        Pad to :func:`bucket_runs` (``n_runs``, ``bucket``) runs.

    Returns
    -------
    Batch
    """
    system, axes = _shared_time_base(system)
    n_runs = int(np.shape(system.key)[0])
    devices = len(jax.devices()) if every_core else 1
    n_padded = bucket_runs(n_runs, bucket) if bucket else n_runs
    groups, per_group = _batch_groups(n_padded, system.structure.n_spacecraft, devices)
    devices = devices if groups % devices == 0 else 1
    system = _pad_runs(system, axes, groups * per_group - n_runs)
    return Batch(system=system, axes=axes, n_runs=n_runs, groups=groups, devices=devices)
