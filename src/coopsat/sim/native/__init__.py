"""Native CPU kernels for the parts of a tick XLA:CPU cannot make one pass.

XLA:CPU emits every fusion as its own loop over memory and has no multi-output loop fusion
(its experimental pass made the consensus loop slower: docs/engine-notes.md, "Native
kernels"), so an RK4 tick of N spacecraft is about nine passes over the state. A native
kernel does the whole tick of a plant in one pass, with every stage in registers
(docs/architecture.md, "Engine speed"). Each kernel is an XLA FFI custom
call on the CPU (numba-compiled, :mod:`coopsat.sim.native.ffi`) and the engine's own XLA code
everywhere else:

* on another platform (a GPU) the XLA code runs (``jax.lax.platform_dependent``);
* its derivatives are the XLA code's (``jax.custom_jvp``), so gradient tuning goes through it;
* under ``vmap`` the kernel receives the batch as leading dimensions.

:data:`KERNELS` lists the plants' ticks, :data:`LAW_KERNELS` the control laws';
:func:`smooth_tick` and :func:`control_step` pick the first whose ``applies`` holds for a
run's static structure, and the engine falls back to XLA when none does. The plant kernel
applies whatever the number of spacecraft (it is about as fast as XLA's tick for a handful
and faster beyond): the plant of a batch is integrated as one array of every run's
spacecraft, so a size threshold there would send a run through different code alone and in
a batch. The law kernel applies from :data:`LAW_MIN_SPACECRAFT` spacecraft per run,
a test that is the same alone and in a batch. So on the CPU a run takes the same path alone,
in any batch and on any number of devices, and its result does not depend on them.
"""

from typing import Callable, NamedTuple

import numpy as np


def with_xla_derivatives(native, xla):
    """``f(*args)``: ``native(*args)`` on the CPU and ``xla(*args)`` on any other platform
    (``jax.lax.platform_dependent``), with the derivatives of ``xla`` everywhere
    (``jax.custom_jvp``). Every input must be an argument, none a closure over a tracer (a
    closure broke ``jax.grad`` through the engine)."""
    import jax

    @jax.custom_jvp
    def f(*args):
        return jax.lax.platform_dependent(*args, cpu=native, default=xla)

    @f.defjvp
    def _jvp(primals, tangents):
        return f(*primals), jax.jvp(xla, primals, tangents)[1]

    return f


class Kernel(NamedTuple):
    """A plant's native ticks. ``applies(system, x, fields)``: whether it computes this run's
    ticks (a static test on the structure, the moving state fields and the shapes);
    ``tick(system, x, wrench, t_s, reference)``: the smooth tick from time ``t_s``, with
    ``reference(system, x, wrench, t_s)`` the engine's XLA code for it (the fallback and the
    derivative); ``segments(system, x, wrenches, starts_s, lengths_s, t_s, reference)``: the
    piecewise tick of :func:`piecewise_tick`, ``reference`` taking the same arguments but
    ``system``'s place first."""

    applies: Callable
    tick: Callable
    segments: Callable


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


def _rigid_body_segments(system, x, wrenches, starts_s, lengths_s, t_s, reference):
    from coopsat.sim.native.attitude import rigid_body_segments

    return rigid_body_segments(system, x, wrenches, starts_s, lengths_s, t_s, reference)


KERNELS = (Kernel(_rigid_body_applies, _rigid_body_tick, _rigid_body_segments),)


class LawKernel(NamedTuple):
    """A native control law. ``applies(controller, y, inbox)``: whether it computes this
    controller's step (a static test on its type, the measurements' dtypes and the inbox's
    form); ``step(controller, t, y, inbox, state, key)``: what ``controller.step`` returns."""

    applies: Callable
    step: Callable


LAW_MIN_SPACECRAFT = 128
"""Smallest formation whose law runs natively: the law kernel's call costs more than XLA's
fusion of the law, which it beats from about 100 spacecraft (docs/engine-notes.md, "Native
kernels"). The test is on a run's own number of spacecraft, which is the same alone and in
a batch (the parts run per run under ``vmap``), so a run's result still does not depend on
its batch."""


def _consensus_applies(controller, y, inbox):
    from coopsat.control.consensus import ConsensusLaw

    if type(controller) is not ConsensusLaw or inbox.source is None or y["q"].shape[-1] < LAW_MIN_SPACECRAFT:
        return False
    table = inbox.source[0]
    return set(table) == {"q", "omega"} and all(
        a.dtype == np.float64 for a in (y["q"], y["omega"], table["q"], table["omega"])
    )


def _consensus_step(controller, t, y, inbox, state, key):
    from coopsat.sim.native.laws import consensus_step

    return consensus_step(controller, t, y, inbox, state, key)


LAW_KERNELS = (LawKernel(_consensus_applies, _consensus_step),)


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


def piecewise_tick(system, x, wrenches, starts_s, lengths_s, t_s, fields, reference):
    """One tick of the plant from time ``t_s`` as S consecutive segments, each under its own
    held wrench and each in RK4 sub-steps, then ``q`` renormalised: a pulsed actuator's tick
    cut at its switch instants. By the first kernel of :data:`KERNELS` that applies, else by
    ``reference(system, x, wrenches, starts_s, lengths_s, t_s)``.

    ``wrenches``: channel -> (S, 3, …); ``starts_s``, ``lengths_s`` (S, …): each segment's
    start from ``t_s`` and length, s, per spacecraft (a zero length is a no-op step)."""
    if system.structure.native:
        for kernel in KERNELS:
            if kernel.applies(system, x, fields):
                return kernel.segments(system, x, wrenches, starts_s, lengths_s, t_s, reference)
    return reference(system, x, wrenches, starts_s, lengths_s, t_s)


def control_step(system, controller, t, y, inbox, state, key):
    """``controller.step(t, y, inbox, state, key)``, by the first kernel of
    :data:`LAW_KERNELS` that applies (unless ``system.structure.native`` is False)."""
    if system.structure.native:
        for kernel in LAW_KERNELS:
            if kernel.applies(controller, y, inbox):
                return kernel.step(controller, t, y, inbox, state, key)
    return controller.step(t, y, inbox, state, key)
