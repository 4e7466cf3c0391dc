"""Array layouts of the compiled loop: component-major for one run, batch-inner for a batch.

The interface (``System``, ``RunOutput``) keeps per-spacecraft arrays spacecraft-first,
``(n, k)``. Inside the loop they are component-major, ``(k, n)``: each component is a
contiguous row, so XLA vectorises the arithmetic over spacecraft (docs/engine-notes.md,
"Component-major arrays").

A batch is not the one-run loop under ``vmap``: ``vmap`` keeps every array batch-first,
``(B, k, n)``, where a component row is only ``n`` long and strided, so the RK4 arithmetic
would vectorise over one run's spacecraft at a time. The plant state and plant parameters of a
batch are *batch-inner*, ``(k, B, n)``: each component is one contiguous row of ``B·n``
values, and RK4 runs on all runs at once, outside ``vmap`` (so the switch test of pulsed
actuation stays a real branch). Only the parts (sense, deliver, control, plan, account,
disturbances) run per run under ``vmap``, once per control period, with the plant state
handed over in place (``in_axes`` = the run axis). Everything else in the carry stays
batch-first (docs/engine-notes.md, "Batch-inner plant").
"""

from dataclasses import replace

import jax
import jax.numpy as jnp

AXIS = 0
"""Component axis inside the compiled loop (component-major arrays, spacecraft last)."""


def _cm(a):
    """(n, ...) -> (..., n): spacecraft axis last."""
    return jnp.moveaxis(a, 0, -1)


def _engine_view(system):
    """The system with per-spacecraft plant arrays moved to the loop's component-major layout."""
    p = system.plant
    return replace(system, plant=p._replace(inertia_kgm2=_cm(p.inertia_kgm2), inertia_inv=_cm(p.inertia_inv)))


def _run_axis(ndim):
    """Position of the run axis of a batch-inner array of rank ``ndim``: just before the last
    (spacecraft) axis; 0 for per-run scalars."""
    return max(ndim - 2, 0)


def _inner_axes(tree):
    """``vmap`` axes of a batch-inner tree."""
    return jax.tree_util.tree_map(lambda a: _run_axis(jnp.ndim(a)), tree)


def _to_inner(a):
    """Batch-first (B, …, n) -> batch-inner (…, B, n); a per-run scalar (B,) -> (B, 1)."""
    return a[:, None] if jnp.ndim(a) == 1 else jnp.moveaxis(a, 0, -2)


def _from_inner(a):
    """Inverse of :func:`_to_inner` for arrays of rank ≥ 2."""
    return jnp.moveaxis(a, -2, 0)


def _inner_plant(plant):
    """Batch-first plant parameters in the batch-inner layout: per-spacecraft leaves
    (B, n, k…) -> (k…, B, n) (the one-run loop's component-major layout, runs inserted),
    masses (B, n) unchanged, scalars (B,) -> (B, 1) (they broadcast against (…, B, n))."""
    return plant._replace(
        inertia_kgm2=jnp.moveaxis(plant.inertia_kgm2, (0, 1), (-2, -1)),
        inertia_inv=jnp.moveaxis(plant.inertia_inv, (0, 1), (-2, -1)),
        mu_m3_s2=plant.mu_m3_s2[:, None], j2=plant.j2[:, None], r_body_m=plant.r_body_m[:, None],
        chief=plant.chief[:, None],
    )


def _flat_rows(runs_sc):
    """``(flat, unflat)`` for a batch of ``runs_sc`` = (B, n) runs and spacecraft: ``flat``
    makes a batch-inner (…, B, n) array one (…, B·n) row per component (a reshape of
    contiguous memory) and passes anything else (a scalar) unchanged; ``unflat`` is its
    inverse for an array ``flat`` made, a scalar passing unchanged.

    XLA:CPU emits an elementwise loop over the array's own dimensions and vectorises the
    innermost: over a run's n spacecraft only (five, at N = 5) in the (…, B, n) layout, over
    all B·n of them in the flat one (docs/engine-notes.md, "Flat rows for a batch's RK4")."""
    b, n = runs_sc

    def flat(a):
        return jnp.reshape(a, (*jnp.shape(a)[:-2], b * n)) if jnp.shape(a)[-2:] == (b, n) else a

    def unflat(a):
        return a if jnp.ndim(a) == 0 else jnp.reshape(a, (*jnp.shape(a)[:-1], b, n))

    return flat, unflat


def _flat_plant(plant, runs_sc):
    """Batch-inner plant parameters (:func:`_inner_plant`) for the flat rows of
    :func:`_flat_rows`: per-spacecraft leaves (…, B, n) -> (…, B·n); the per-run scalars
    (B, 1) repeated for every spacecraft, (B·n,); the chief an index into the flat row,
    ``b·n + chief_b`` for every spacecraft of run b (what ``plant._chief`` gathers)."""
    b, n = runs_sc
    flat, _ = _flat_rows(runs_sc)

    def per_spacecraft(a):
        return jnp.reshape(jnp.broadcast_to(a, (b, n)), (b * n,))

    return plant._replace(
        inertia_kgm2=flat(plant.inertia_kgm2), inertia_inv=flat(plant.inertia_inv), mass_kg=flat(plant.mass_kg),
        mu_m3_s2=per_spacecraft(plant.mu_m3_s2), j2=per_spacecraft(plant.j2), r_body_m=per_spacecraft(plant.r_body_m),
        chief=per_spacecraft(jnp.arange(b)[:, None] * n + plant.chief),
    )
