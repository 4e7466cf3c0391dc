"""The rigid-body kernel (:mod:`coopsat.sim.native.rigid_body`) as a JAX function."""

from coopsat import _jax  # noqa: F401

import jax
import jax.numpy as jnp
import numpy as np

from coopsat.sim.native import with_xla_derivatives

_registered = False


def _register():
    global _registered
    if not _registered:
        from coopsat.sim.native.rigid_body import TARGET, handler

        jax.ffi.register_ffi_target(TARGET, jax.ffi.pycapsule(handler.ctypes), platform="cpu")
        _registered = True


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

    def rows(a):
        return jnp.broadcast_to(a, a.shape[:1] + shape[1:]).reshape(a.shape[0], m)

    call = jax.ffi.ffi_call(
        TARGET, (jax.ShapeDtypeStruct((4, m), x.q_bi.dtype), jax.ShapeDtypeStruct((3, m), x.omega_b.dtype)),
        vmap_method="broadcast_all",
        # One run, (k, n): the new state overwrites the old, and XLA keeps no copy of it a tick
        # (consensus N = 5: 11.1 -> 13.1 M spacecraft-steps/s). A batch-inner state (k, B, n)
        # reaches the call through a reshape, and aliasing that made XLA copy the state both
        # into and out of the call (a batch of 1000 runs of N = 5: 2x slower): not aliased.
        input_output_aliases={0: 0, 1: 1} if x.q_bi.ndim == 2 else {},
    )
    p = system.plant
    q, w = call(rows(x.q_bi), rows(x.omega_b), rows(x.h_wheels_b), rows(torque_b), rows(p.inertia_kgm2),
                rows(p.inertia_inv), system.dt_s / sub, sub, cores)
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
