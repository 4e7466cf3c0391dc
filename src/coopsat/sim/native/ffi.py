"""numba kernels called by XLA:CPU as FFI custom calls: reading XLA's call frame.

An XLA FFI handler is a C function ``XLA_FFI_Error* handler(XLA_FFI_CallFrame*)``
(``jaxlib/include/xla/ffi/api/c_api.h``). A kernel module writes its handler as a numba
``cfunc`` of signature :data:`HANDLER_SIGNATURE` and reads its buffers with the helpers here;
it returns 0 (no error). The call frame is read as 64-bit words; on the 64-bit targets JAX
supports every field used sits on a word boundary (pointers, ``size_t`` and ``int64_t``; the
32-bit enums are followed by padding and read from the low half of their word):

* call frame: word 1 ``extension_start``, word 4 ``stage``, words 5–9 ``args`` (word 7 its
  size, word 9 the array of buffer pointers), words 10–14 ``rets`` (word 14 its pointers);
* buffer: word 3 ``data``, word 4 ``rank``, word 5 ``dims``;
* metadata extension: word 1 its type, word 3 the ``XLA_FFI_Metadata`` to fill, whose
  ``api_version.major_version``/``minor_version`` are its 32-bit words 6 and 7.

XLA may call a handler with a metadata extension (it then asks for the FFI version the
handler was built against, and its traits) and at other stages than ``execute``; the
handler answers the first with :func:`answer_metadata` and ignores the others.
"""

import functools

import llvmlite.binding as llvm
from numba import carray, njit, types
from numba.core import cgutils
from numba.extending import intrinsic

from coopsat.core.errors import InputError

HANDLER_SIGNATURE = types.int64(types.CPointer(types.int64))
"""``XLA_FFI_Error* (XLA_FFI_CallFrame*)``: the frame read as 64-bit words, the error pointer
returned as an integer (0: success)."""

API_VERSION = (0, 3)
"""XLA_FFI_API_MAJOR/MINOR of the headers these offsets were read from (jaxlib 0.10)."""

_EXECUTE = 3
_METADATA = 1


class KernelArgumentError(InputError):
    """A native kernel was handed a buffer of another shape or dtype than it reads."""


def check_arguments(target, spec, args):
    """Check every argument of a kernel call against the layout its handler reads, before
    XLA is asked to call it: a mismatch is a Python error at trace time, never a read past the
    end of a buffer.

    Parameters
    ----------
    target : str
        The kernel's FFI target (for the message).
    spec : sequence of (name, dtype, shape)
        Per argument, in order: its name, numpy dtype and shape, each dimension an int or a
        letter; a letter stands for one size, the same wherever it appears.
    args : sequence of array_like
        The arguments, without vmap's leading dimensions (``vmap_method="broadcast_all"``
        adds them, and the handlers read them as leading rows).

    Raises
    ------
    KernelArgumentError
        The number of arguments, a dtype or a dimension differs from ``spec``.
    """
    import numpy as np

    if len(args) != len(spec):
        raise KernelArgumentError(f"native kernel {target}: {len(args)} arguments, its handler reads {len(spec)}")
    sizes = {}
    for (name, dtype, pattern), a in zip(spec, args):
        shape, got = tuple(np.shape(a)), np.dtype(a.dtype) if hasattr(a, "dtype") else np.result_type(a)
        expected = tuple(sizes.setdefault(d, n) if isinstance(d, str) else d for d, n in zip(pattern, shape))
        if got != np.dtype(dtype) or len(shape) != len(pattern) or shape != expected:
            raise KernelArgumentError(
                f"native kernel {target}: argument {name} is {got.name} {shape}, its handler reads "
                f"{np.dtype(dtype).name} ({', '.join(map(str, pattern))})"
            )


def call(target, spec, results, args, **options):
    """``jax.ffi.ffi_call(target, results, **options)(*args)`` after :func:`check_arguments`."""
    import jax

    check_arguments(target, spec, args)
    return jax.ffi.ffi_call(target, results, **options)(*args)


def _pointer_cast(ty):
    @intrinsic
    def cast(typingctx, address):
        def codegen(context, builder, signature, args):
            return builder.inttoptr(args[0], context.get_value_type(types.CPointer(ty)))

        return types.CPointer(ty)(types.int64), codegen

    return cast


f64_at = _pointer_cast(types.float64)
"""``(double*) address``."""
i64_at = _pointer_cast(types.int64)
"""``(int64_t*) address``."""
i32_at = _pointer_cast(types.int32)
"""``(int32_t*) address``."""


def stack_array(ty, size):
    """An intrinsic ``() -> ty*`` to ``size`` values of numba type ``ty`` on the stack (an
    ``alloca`` in the entry block of the function it is inlined into): scratch that LLVM
    knows no argument aliases, so a loop that loads from arguments and stores there (or the
    reverse) is vectorised with no run-time overlap check, even when a kernel's output
    buffer is its input (XLA's in-place aliasing); also an API call's argument struct."""

    @intrinsic
    def stack(typingctx):
        def codegen(context, builder, signature, args):
            return cgutils.alloca_once(builder, context.get_value_type(ty), size=size)

        return types.CPointer(ty)(), codegen

    return stack


@njit(cache=True)
def answer_metadata(frame):
    """True when ``frame`` is a metadata query (then answered) or a stage other than execute:
    the handler returns 0 without touching any buffer."""
    extension = frame[1]
    if extension != 0:
        ext = carray(i64_at(extension), 4)
        if (ext[1] & 0xFFFFFFFF) == _METADATA:
            meta = carray(i32_at(ext[3]), 9)
            meta[6] = API_VERSION[0]
            meta[7] = API_VERSION[1]
            meta[8] = 0  # traits: none
        return True
    return (frame[4] & 0xFFFFFFFF) != _EXECUTE


@njit(cache=True)
def buffer(frame, k, is_result):
    """(data address, leading size L, last size M) of argument (or result) ``k``: the buffer
    read as ``(L, …, M)`` with L the product of every dimension before the last two (1 when
    rank ≤ 2; vmap adds them), M its last (1 for a scalar)."""
    pointers = carray(i64_at(frame[14] if is_result else frame[9]), k + 1)
    buf = carray(i64_at(pointers[k]), 6)
    rank = buf[4]
    dims = carray(i64_at(buf[5]), max(rank, 1))
    lead = 1
    for d in range(rank - 2):
        lead *= dims[d]
    return buf[3], lead, dims[rank - 1] if rank > 0 else 1


@functools.cache
def vectorise_many_rows():
    """Once per process (each kernel module asks; LLVM 14, numba 0.60's, rejects a second
    setting of an option with a message on stderr), let LLVM vectorise loops over many rows: a kernel reading 8 rows and writing 2 needs
    more run-time overlap checks than LLVM's budget of 8, beyond which it silently leaves the
    loop scalar (the rigid-body kernel: 31 µs instead of 8.6 µs for 1000 spacecraft). numba
    cannot mark arguments ``noalias``, so the budget is raised. These are options of numba's
    LLVM (llvmlite), process-wide, not XLA's; they decide only whether a loop may be
    vectorised behind run-time checks, never its arithmetic."""
    llvm.set_option("coopsat", "-runtime-memory-check-threshold=1024")
    llvm.set_option("coopsat", "-vectorize-memory-check-threshold=1024")
