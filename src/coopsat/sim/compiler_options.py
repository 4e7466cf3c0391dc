"""XLA options of the engine's compiled programs (per program, never the process's flags).

On the CPU, jaxlib 0.10 hands reductions to YNNPACK by default
(``xla_cpu_experimental_ynn_fusion_type`` includes ``LIBRARY_FUSION_TYPE_REDUCE``). The loop's
reductions are small and over a middle axis: the sum over a consensus law's padded neighbour
slots, (B, 3, d, n) → (B, 3, n) for a batch of B runs of n spacecraft. YNNPACK took 35 µs a
tick for the 6000 terms of 200 runs of 5 spacecraft, behind two layout copies of 13 and 9 µs
that feed it; XLA's own loop reduction of the same terms takes 20 µs with no copies
(docs/engine-notes.md, "Reductions outside YNNPACK"). Only this option is set: YNNPACK keeps
the dots and convolutions it takes by default.

A jaxlib that does not know the option or these names refuses it when the program is
compiled; the program is then compiled with the defaults (the same results, at that version's
speed), and the process does not ask again.
"""

import threading

import jax

CPU_OPTIONS = {
    "xla_cpu_experimental_ynn_fusion_type": "LIBRARY_FUSION_TYPE_INDIVIDUAL_DOT,LIBRARY_FUSION_TYPE_INDIVIDUAL_CONVOLUTION",
}
"""Compiler options of every engine program on the CPU: jaxlib 0.10's YNNPACK fusion types
without ``LIBRARY_FUSION_TYPE_REDUCE``."""

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
