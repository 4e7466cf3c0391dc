"""Native CPU kernels for the parts of a tick XLA:CPU cannot fuse into one pass.

XLA:CPU emits every fusion as its own loop over memory and has no multi-output loop fusion
(its experimental pass, ``--xla_backend_extra_options=xla_cpu_use_multi_output_fusion``,
made the consensus loop 5–8× slower when tried), so an RK4 tick of N spacecraft is about nine
passes over the state. A native kernel does the whole tick of a plant in one pass, with every
stage in registers (docs/architecture.md, "Engine speed"). Each kernel is an XLA FFI custom
call on the CPU (numba-compiled, :mod:`coopsat.sim.native.ffi`) and the engine's own XLA code
everywhere else:

* on another platform (a GPU) the XLA code runs (``jax.lax.platform_dependent``);
* its derivatives are the XLA code's (``jax.custom_jvp``), so gradient tuning goes through it;
* under ``vmap`` the kernel receives the batch as leading dimensions.

:data:`KERNELS` lists them; :func:`smooth_tick` picks the first whose ``applies(system)`` holds
for a run's static structure, and the engine falls back to XLA when none does. A kernel
applies whatever the number of spacecraft (at N = 1 and 5 it runs as fast as XLA's tick,
measured; from N = 20 faster), so on the CPU a run takes the same path alone, in any batch
and on any number of devices, and its result does not depend on them.
"""

from typing import Callable, NamedTuple

class Kernel(NamedTuple):
    """A native smooth tick. ``applies(system, x, fields)``: whether it computes this run's
    tick (a static test on the structure, the moving state fields and the shapes);
    ``tick(system, x, wrench, t_s, reference)``: the tick from time ``t_s``, with
    ``reference(system, x, wrench, t_s)`` the engine's XLA code for it (the fallback and the
    derivative)."""

    applies: Callable
    tick: Callable


def _rigid_body_applies(system, x, fields):
    s = system.structure
    return (
        s.attitude == "rigid-body" and s.gravity == "none" and tuple(fields) == ("q_bi", "omega_b")
        and not system.disturbances and all(a.channel == "torque_b" for a in system.actuators)
        and system.plant.inertia_kgm2.ndim == x.omega_b.ndim  # principal moments (matvec3's diagonal form)
    )


def _rigid_body_tick(system, x, wrench, t_s, reference):
    from coopsat.sim.native.attitude import rigid_body_tick

    return rigid_body_tick(system, x, wrench, t_s, reference)


KERNELS = (Kernel(_rigid_body_applies, _rigid_body_tick),)


def smooth_tick(system, x, wrench, t_s, fields, reference):
    """One smooth tick of the plant from time ``t_s`` (RK4 sub-steps under a held wrench,
    then ``q`` renormalised): by the first kernel of :data:`KERNELS` that applies, else (or
    when ``system.structure.native`` is False) by ``reference(system, x, wrench, t_s)``.
    ``x``: component-major, fields (k, n), or (k, B, n) for a batch; ``fields``: its moving
    fields."""
    if system.structure.native:
        for kernel in KERNELS:
            if kernel.applies(system, x, fields):
                return kernel.tick(system, x, wrench, t_s, reference)
    return reference(system, x, wrench, t_s)
