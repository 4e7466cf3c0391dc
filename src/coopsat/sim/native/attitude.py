"""The rigid-body kernels (:mod:`coopsat.sim.native.rigid_body`) as JAX functions: the smooth
tick and the piecewise tick of a pulsed actuator."""

import threading
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from coopsat.sim.native import ffi, with_xla_derivatives

_registered = False
_register_lock = threading.Lock()


def _register():
    """Register the kernels' FFI targets with XLA, once per process (also when threads trace
    the engine at the same time)."""
    global _registered
    with _register_lock:
        if not _registered:
            from coopsat.sim.native.rigid_body import SEGMENTS_TARGET, TARGET, handler, segments_handler

            jax.ffi.register_ffi_target(TARGET, jax.ffi.pycapsule(handler.ctypes), platform="cpu")
            jax.ffi.register_ffi_target(SEGMENTS_TARGET, jax.ffi.pycapsule(segments_handler.ctypes), platform="cpu")
            _registered = True


def _spec(n_seg=None):
    """What the handlers of :mod:`coopsat.sim.native.rigid_body` read (:func:`~coopsat.sim.
    native.ffi.check_arguments`): the smooth tick's, or with ``n_seg`` segments the piecewise
    tick's. M: every spacecraft of the call."""
    f8, i8 = np.float64, np.int64
    state = [("q_bi", f8, (4, "M")), ("omega_b", f8, (3, "M")), ("h_wheels_b", f8, (3, "M"))]
    plant = [("inertia_kgm2", f8, (3, "M")), ("inertia_inv", f8, (3, "M"))]
    if n_seg is None:
        return (*state, ("torque_b", f8, (3, "M")), *plant, ("h_s", f8, ()), ("substeps", i8, ()), ("cores", i8, ()))
    return (*state, ("torque_b", f8, (3 * n_seg, "M")), *plant, ("step_s", f8, (n_seg, "M")), ("substeps", i8, ()),
            ("segments", i8, ()))


def _rows(a, shape):
    """``a`` broadcast to the state's trailing shape and reshaped (free) to rows (k, M)."""
    return jnp.broadcast_to(a, a.shape[:1] + shape[1:]).reshape(a.shape[0], int(np.prod(shape[1:])))


def _native(system, x, torque_b, t_s):
    """The tick by the FFI kernel: every field reshaped (free) to component-major rows
    (k, M), M = every spacecraft of the call."""
    from coopsat.sim.native.rigid_body import TARGET

    shape = x.omega_b.shape
    m = int(np.prod(shape[1:]))
    sub = np.int64(system.structure.substeps)
    # The cores the kernel may split a large run over: XLA's CPU devices (a campaign's
    # worker has one, and its neighbour the other core).
    cores = np.int64(len(jax.devices("cpu")))

    results = (jax.ShapeDtypeStruct((4, m), x.q_bi.dtype), jax.ShapeDtypeStruct((3, m), x.omega_b.dtype))
    call = partial(
        ffi.call, TARGET, _spec(), results, vmap_method="broadcast_all",
        # One run, (k, n): the new state overwrites the old, and XLA keeps no copy of it a tick.
        # A batch-inner state (k, B, n) reaches the call through a reshape, and aliasing that
        # makes XLA copy the state both into and out of the call: not aliased
        # (docs/engine-notes.md, "Native kernels").
        input_output_aliases={0: 0, 1: 1} if x.q_bi.ndim == 2 else {},
    )
    p = system.plant
    q, w = call((*(_rows(a, shape) for a in (x.q_bi, x.omega_b, x.h_wheels_b, torque_b, p.inertia_kgm2, p.inertia_inv)),
                 system.dt_s / sub, sub, cores))
    return x._replace(q_bi=q.reshape(x.q_bi.shape), omega_b=w.reshape(shape))


def rigid_body_tick(system, x, wrench, t_s, reference):
    """One smooth tick of free rigid bodies under the held ``wrench["torque_b"]``: by the
    native kernel on the CPU, by ``reference`` elsewhere and for derivatives.

    Parameters
    ----------
    system : System
        The run (engine view: component-major plant, principal inertia).
    x : PlantState
        Component-major, fields (k, n), or (k, B, n) for a batch in the batch-inner layout.
    wrench : dict
        ``torque_b`` (3, …) N·m, or nothing (no torque).
    t_s : scalar
        Time at the start of the tick, s (for ``reference``).
    reference : callable
        ``reference(system, x, wrench, t_s) -> PlantState``: the engine's XLA tick.

    Returns
    -------
    PlantState

    Notes
    -----
    Everything the tick reads is an argument of the ``custom_jvp`` function (the run, the
    state, the torque, the time), none a closure: derivatives with respect to any of them
    (a gain upstream of the torque, an inertia) are the reference's.
    """
    _register()

    tick = with_xla_derivatives(_native, lambda s, xx, torque_b, t: reference(s, xx, {"torque_b": torque_b}, t))
    torque_b = jnp.broadcast_to(wrench.get("torque_b", jnp.zeros((), x.omega_b.dtype)), x.omega_b.shape)
    return tick(system, x, torque_b, t_s)


def _native_segments(system, x, torque_b, starts_s, lengths_s, t_s):
    """The piecewise tick by the FFI kernel: τ (S, 3, …) as rows (3·S, M), the sub-step lengths
    (S, …) as rows (S, M)."""
    from coopsat.sim.native.rigid_body import SEGMENTS_TARGET

    shape = x.omega_b.shape
    m = int(np.prod(shape[1:]))
    n_seg, sub = lengths_s.shape[0], system.structure.substeps
    results = (jax.ShapeDtypeStruct((4, m), x.q_bi.dtype), jax.ShapeDtypeStruct((3, m), x.omega_b.dtype))
    call = partial(
        ffi.call, SEGMENTS_TARGET, _spec(n_seg), results, vmap_method="broadcast_all",
        input_output_aliases={0: 0, 1: 1} if x.q_bi.ndim == 2 else {},  # as the smooth tick (_native)
    )
    p = system.plant
    torque_rows = jnp.broadcast_to(torque_b, (n_seg, *shape)).reshape(3 * n_seg, m)
    q, w = call((_rows(x.q_bi, shape), _rows(x.omega_b, shape), _rows(x.h_wheels_b, shape), torque_rows,
                 _rows(p.inertia_kgm2, shape), _rows(p.inertia_inv, shape), _rows(lengths_s / sub, (n_seg, *shape[1:])),
                 np.int64(sub), np.int64(n_seg)))
    return x._replace(q_bi=q.reshape(x.q_bi.shape), omega_b=w.reshape(shape))


def rigid_body_segments(system, x, wrenches, starts_s, lengths_s, t_s, reference):
    """A tick of free rigid bodies as consecutive segments, each under its own held torque
    (a pulsed actuator's tick cut at its switch instants): by the native kernel on the CPU,
    by ``reference`` elsewhere and for derivatives.

    Parameters
    ----------
    system, x
        As :func:`rigid_body_tick`.
    wrenches : dict
        ``torque_b`` (S, 3, …) N·m: segment s's torque; or nothing (no torque).
    starts_s, lengths_s : array (S, …)
        Each segment's start (from the tick's start) and length, s, per spacecraft.
    t_s : scalar
        Time at the start of the tick, s.
    reference : callable
        ``reference(system, x, wrenches, starts_s, lengths_s, t_s) -> PlantState``.

    Returns
    -------
    PlantState
    """
    _register()

    tick = with_xla_derivatives(
        _native_segments, lambda s, xx, tq, a, ln, t: reference(s, xx, {"torque_b": tq}, a, ln, t),
    )
    torque_b = wrenches.get("torque_b", jnp.zeros((), x.omega_b.dtype))
    torque_b = jnp.broadcast_to(torque_b, (lengths_s.shape[0], *x.omega_b.shape))
    return tick(system, x, torque_b, starts_s, lengths_s, t_s)
