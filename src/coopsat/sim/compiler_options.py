"""XLA options of the engine's compiled programs (per program, never the process's flags).

On the CPU, jaxlib 0.10 hands reductions, dots and convolutions to YNNPACK by default
(``xla_cpu_experimental_ynn_fusion_type``). The processes coopsat owns (the command line, its
workers) turn that off in ``XLA_FLAGS`` (:data:`coopsat.core.runtime.YNN_FUSION_TYPES`), but a
library user's process keeps JAX's defaults, and there the loop's small reductions over a
middle axis went to YNNPACK: the sum over a consensus law's padded neighbour slots,
(B, 3, d, n) → (B, 3, n) for a batch of B runs of n spacecraft, took 35 µs a tick for 200 runs
of 5 spacecraft, behind two layout copies of 13 and 9 µs that feed it; XLA's own loop
reduction of the same terms takes 20 µs with no copies (docs/engine-notes.md, "Reductions
outside YNNPACK"). So the engine's programs are compiled with the owned processes' choice in
any process; a per-program option wins over ``XLA_FLAGS``, so it is that same value, not a
second choice.

A jaxlib that does not know the option refuses it when the program is compiled; the program
is then compiled with the defaults (the same results, at that version's speed), and the
process does not ask again.
"""

import threading

import jax

from coopsat.core.runtime import YNN_FUSION_TYPES

CPU_OPTIONS = {"xla_cpu_experimental_ynn_fusion_type": YNN_FUSION_TYPES}
"""Compiler options of every engine program on the CPU: no fusion handed to YNNPACK, as in the
processes coopsat owns."""

_lock = threading.Lock()
_refused = []  # the reason, once a jaxlib refused CPU_OPTIONS in this process


def options_refused():
    """Why this process compiles with XLA's defaults (jaxlib refused :data:`CPU_OPTIONS`), or
    None while the options are used or not yet tried."""
    return _refused[0] if _refused else None


def compile_program(lowered, backend=None):
    """``lowered.compile()`` with :data:`CPU_OPTIONS` when the program runs on the CPU.

    Parameters
    ----------
    lowered : jax.stages.Lowered
    backend : str, optional
        The platform the program runs on; ``jax.default_backend()`` unless given.

    Returns
    -------
    jax.stages.Compiled
    """
    if (backend or jax.default_backend()) != "cpu" or _refused:
        return lowered.compile()
    try:
        return lowered.compile(dict(CPU_OPTIONS))
    except Exception as err:  # jaxlib's error type differs between versions; the message names the option
        if not any(name in str(err) for name in CPU_OPTIONS):
            raise
        with _lock:
            if not _refused:
                _refused.append(str(err).strip().splitlines()[0][:300])
    return lowered.compile()
