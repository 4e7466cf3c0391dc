"""The compiled closed loop's input: one immutable pytree per run (or per batch of runs).

:class:`System` splits into *structure* (static, hashable: which laws, how many ticks per
control period, …) and *data* (arrays: inertias, gains, graph edges, initial state, step). Only
a change of structure recompiles; every number a Monte Carlo campaign disperses is data, and a
batch of runs is a :class:`System` whose data leaves carry a leading batch axis
(:func:`stack_systems`).
"""

import dataclasses
from dataclasses import dataclass


import jax
import jax.numpy as jnp
import numpy as np

from coopsat.dynamics.plant import PlantParams, PlantState


@dataclass(frozen=True)
class Structure:
    """Static description of the closed loop (part of the compiled program's cache key).

    Which laws, actuators and sensors run is not here: it is the type and static fields of
    each part in :class:`System` (also part of the cache key).

    Attributes
    ----------
    n_spacecraft : int
    gravity : {"none", "two-body", "j2"}
        Translational force model; "none" freezes position and velocity.
    attitude : {"rigid-body", "small-angle"}
        Attitude model (:data:`coopsat.dynamics.plant.ATTITUDE_MODELS`).
    ticks_per_period : int
        Base ticks per control period (the controller's zero-order-hold interval).
    periods_per_record : int
        Control periods between recorded samples.
    substeps : int
        RK4 steps per tick (per switch-free segment of a tick when actuation is pulsed).
    native : bool
        Whether a native CPU kernel may integrate the plant where one applies
        (:mod:`coopsat.sim.native`); False keeps the whole loop in XLA (the reference the
        kernels are tested against).
    """

    n_spacecraft: int
    gravity: str
    attitude: str
    ticks_per_period: int
    periods_per_record: int
    substeps: int
    native: bool = True


@dataclass(frozen=True)
class System:
    """Everything one closed-loop run needs: the plant and one part per plug-in.

    Attributes
    ----------
    structure : Structure
        Static.
    dt_s : scalar array
        Base tick, s.
    key : uint32 (2,)
        The run's random key (from the scenario seed); every draw of the run derives from it.
    x0 : PlantState
        Initial state, fields ``(n, ...)``.
    plant : PlantParams
    controller : part
        Flight software (``init``, ``outbox``, ``step``; docs/architecture.md §4).
    network : part
        Delivers outboxes as inboxes (``init``, ``deliver``).
    sensors : tuple of parts
        Each replaces one measured quantity by what it reads (``init``, ``measure``).
    actuators : tuple of parts
        Each turns one command into a pulse on one wrench channel (``init``, ``plan``,
        ``account``).
    disturbances : tuple of parts
        Environment wrenches (``init``, ``update``, ``wrench``).
    """

    structure: Structure
    dt_s: jnp.ndarray
    key: jnp.ndarray
    x0: PlantState
    plant: PlantParams
    controller: object
    network: object
    sensors: tuple
    actuators: tuple
    disturbances: tuple

    @property
    def period_s(self):
        """Control period, s (array; batched with ``dt_s``)."""
        return self.dt_s * self.structure.ticks_per_period


jax.tree_util.register_dataclass(
    System,
    data_fields=[f.name for f in dataclasses.fields(System) if f.name != "structure"],
    meta_fields=["structure"],
)


def stack_systems(systems):
    """Stack systems of one structure into a batch (leading axis on every data leaf).

    Parameters
    ----------
    systems : sequence of System
        Same :class:`Structure` and the same array shapes (same graph size, same laws).

    Returns
    -------
    System
        Batched system for :func:`coopsat.sim.engine.simulate` with ``batched=True``.
    """
    structures = {jax.tree_util.tree_structure(s) for s in systems}
    if len(structures) != 1:
        raise ValueError("stack_systems: systems differ in structure (laws, rates or size); they cannot share a batch")
    # Stacked on the host and moved once per leaf: ``jnp.stack`` of device arrays dispatched one
    # conversion per run and leaf (15 s for 1000 runs of N = 5); the same values either way.
    return jax.tree_util.tree_map(lambda *leaves: jax.device_put(np.stack([np.asarray(v) for v in leaves])), *systems)


def as_arrays(tree):
    """Convert every leaf to a float64/int JAX array (NumPy scalars and lists welcome).

    ``device_put``, not ``jnp.asarray``: the same arrays (dtype, weak type, placement), but
    ``jnp.asarray`` compiles a small conversion program for each new shape and dtype, 7 ms
    apiece on the development machine, which a scenario's build paid 28 times."""
    return jax.tree_util.tree_map(lambda v: jax.device_put(np.asarray(v)), tree)
