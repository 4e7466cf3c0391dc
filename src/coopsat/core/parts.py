"""What every in-loop plug-in part shares: the pytree decorator, the output description and the
per-spacecraft random draw.

A *part* is the compiled-loop half of a plug-in (a controller, actuator, sensor, network model
or disturbance): a frozen dataclass whose array fields are pytree data (traced; batched by
``vmap``; a Monte Carlo campaign disperses them without recompiling) and whose ``static``
fields are hashable configuration that shapes the program (part of the compiled program's
cache key). Its methods are the pure in-loop functions (``init``, ``step``, …) documented by
each role in docs/architecture.md §4.
"""

import dataclasses
from typing import NamedTuple


import jax
import jax.numpy as jnp


def part(static=()):
    """Class decorator: a frozen dataclass registered as a JAX pytree.

    Parameters
    ----------
    static : sequence of str
        Fields that are configuration (hashable; a change recompiles); every other field is
        array data.
    """

    def wrap(cls):
        cls = dataclasses.dataclass(frozen=True)(cls)
        names = [f.name for f in dataclasses.fields(cls)]
        unknown = set(static) - set(names)
        if unknown:
            raise TypeError(f"{cls.__name__}: static fields {sorted(unknown)} are not fields")
        jax.tree_util.register_dataclass(
            cls, data_fields=[n for n in names if n not in static], meta_fields=list(static)
        )
        return cls

    return wrap


class OutputSpec(NamedTuple):
    """How one recorded quantity appears in the run's dataset.

    Attributes
    ----------
    dims : tuple of str
        Dimensions after ``time`` (and ``spacecraft`` when ``per_spacecraft``), e.g.
        ``("component",)``.
    units : str
        UDUNITS string (``"N m"``, ``"rad/s"``, ``"1"``).
    frame : str
        Frame of a vector's components (``"body"``, ``"ECI"``, ``"LVLH"``), or "".
    long_name : str
    per_spacecraft : bool
        The engine's sample has a spacecraft axis (else it is one value per instant, e.g. a
        reference attitude).
    coords : tuple of (str, tuple of str)
        Labels of any dimension the dataset does not already know, e.g.
        ``(("thruster", ("+x", "-x", …)),)``.
    """

    dims: tuple
    units: str
    frame: str
    long_name: str
    per_spacecraft: bool = True
    coords: tuple = ()


def per_spacecraft_normal(key, k, n):
    """Standard normal draws, one independent stream per spacecraft.

    Parameters
    ----------
    key : jax.Array
        PRNG key (``jax.random.key`` or ``jax.random.PRNGKey``).
    k : int
        Number of components per spacecraft (static).
    n : int
        Number of spacecraft (static).

    Returns
    -------
    jax.Array, shape (k, n)
        Column i is ``jax.random.normal(jax.random.fold_in(key, i), (k,))``: the same whatever
        ``n`` is, and independent of every other column.
    """
    draw = jax.vmap(lambda i: jax.random.normal(jax.random.fold_in(key, i), (k,)), out_axes=1)
    return draw(jnp.arange(n))
