"""The consensus-law kernel (:mod:`coopsat.sim.native.consensus`) as a JAX function."""


import jax
import jax.numpy as jnp
import numpy as np

from coopsat.control.consensus import reference_attitude
from coopsat.sim.native import ffi, with_xla_derivatives
from coopsat.sim.native.consensus import N_PARAMS, TARGET, handler

jax.ffi.register_ffi_target(TARGET, jax.ffi.pycapsule(handler.ctypes), platform="cpu")

SPEC = (
    ("table_q", np.float64, (4, "T")), ("table_omega", np.float64, (3, "T")), ("q", np.float64, (4, "N")),
    ("omega", np.float64, (3, "N")), ("index", np.int32, (1, "E")), ("dst", np.int32, (1, "E")),
    ("weight", np.float64, (1, "E")), ("params", np.float64, (1, N_PARAMS)), ("flags", np.int64, (1, 4)),
)
"""What the handler of :data:`~coopsat.sim.native.consensus.TARGET` reads
(:func:`~coopsat.sim.native.ffi.check_arguments`): T messages in the table, N spacecraft, E links."""


def _native(law, t, y, inbox):
    """The command by the FFI kernel: every link array as one row (1, E) and the per-run
    scalars as (1, N_PARAMS), so that vmap's dimensions lead every argument."""
    table, index = inbox.source
    padded = inbox.dst.ndim == 2
    zero = jnp.zeros((), y["q"].dtype)
    q_ref = reference_attitude(law.q_ref0, law.omega_ref_b, t) if law.track else jnp.zeros(4, y["q"].dtype)
    params = jnp.concatenate([
        jnp.stack([law.alpha + zero, law.beta + zero, law.k_p + zero, law.k_d + zero]), q_ref, law.omega_ref_b + zero,
    ]).reshape(1, N_PARAMS)
    # The last flag: the cores a large run may be split over (XLA's CPU devices; one in a
    # campaign's worker).
    flags = np.array([[padded, law.short_way, law.track, len(jax.devices("cpu"))]], np.int64)
    row = lambda a: a.reshape(1, -1)  # noqa: E731
    args = (table["q"], table["omega"], y["q"], y["omega"], row(index.astype(jnp.int32)), row(inbox.dst.astype(jnp.int32)),
            row(jnp.broadcast_to(inbox.weight, index.shape) + zero), params, flags)
    return ffi.call(TARGET, SPEC, jax.ShapeDtypeStruct(y["omega"].shape, y["omega"].dtype), args, vmap_method="broadcast_all")


def consensus_step(controller, t, y, inbox, state, key):
    """:meth:`ConsensusLaw.step <coopsat.control.consensus.ConsensusLaw.step>` with the command
    by the native kernel on the CPU, by the law's JAX code elsewhere and for derivatives.

    Parameters
    ----------
    controller : ConsensusLaw
    t : scalar
        Time, s.
    y : dict
        ``q`` (4, n) and ``omega`` (3, n), component-major: what each spacecraft measures.
    inbox : Inbox
        With ``source``: the messages as a gather.
    state, key
        As ``step``.

    Returns
    -------
    (commands, state, record), as ``step``.

    Notes
    -----
    Everything the command reads is an argument of the ``custom_jvp`` function (the law, the
    time, the measurements, the inbox), none a closure: a derivative with respect to a gain,
    an initial state or a weight is the JAX law's.
    """

    torque = with_xla_derivatives(_native, lambda law, tt, yy, box: law.torque(tt, yy, box))
    u = torque(controller, t, {"q": y["q"], "omega": y["omega"]}, inbox)
    return controller.outputs(t, u, state)
