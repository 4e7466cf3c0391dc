"""Running a kernel's spans of spacecraft on XLA's own CPU thread pool, asynchronously.

XLA:CPU hands an FFI handler its intra-op thread pool (``XLA_FFI_ThreadPool_Schedule``) and
lets it finish later (``XLA_FFI_Future``): the handler schedules one task per span, sets the
call's future and returns; the last task to finish marks the future available, and XLA
keeps every buffer alive until then (``jaxlib/include/xla/ffi/api/c_api.h``). The handler
never waits, so it cannot deadlock on a busy or one-thread pool, and no thread is started
besides XLA's own (numba's ``prange`` would start its own pool, which is slower and cannot be
cached).

The tasks share a record in memory from ``malloc``: word 0 counts the tasks still running,
word 1 holds the future, word 2 XLA's API, word 3 the number of tasks; then one word per task
holding its index k (task k's data is the address of that word); one claim flag per span;
then the kernel's words (its buffers' addresses and sizes). The first span runs on the calling thread while the
others run on the pool; the last task to finish frees the record.

numba caches each compiled function with the code of everything it calls, and checks only the
source file of the function itself: after editing this module or ``ffi.py`` (or a constant
here, such as :data:`PARALLEL_MIN`), delete ``src/coopsat/sim/native/__pycache__`` so the
kernels are rebuilt.

The words of XLA's API table read here (``XLA_FFI_Api``: size, extension, a 3-word version,
the internal API, then the functions in order): 17 ``ThreadPool_Schedule``, 18
``ThreadPool_NumThreads``, 19 ``Future_Create``, 20 ``Future_SetAvailable``. Call frame word
21 is its ``future`` (after the 5-word args and rets and the 6-word attrs).
"""

import ctypes

import llvmlite.binding as llvm
from llvmlite import ir
from numba import carray, cfunc, njit, types
from numba.core import cgutils
from numba.extending import intrinsic

from coopsat.sim.native.ffi import i64_at, stack_array

PARALLEL_MIN = 4096
"""Fewest spacecraft in one kernel call (one run) for the kernel to split its work over XLA's
CPU thread pool: below it the hand-over costs more than a second core saves
(docs/engine-notes.md, "XLA's thread pool for large runs")."""

HEAD = 4
"""Words of the record before the per-task words: tasks running, future, API, tasks."""

_SCHEDULE, _NUM_THREADS, _FUTURE_CREATE, _FUTURE_SET_AVAILABLE = 17, 18, 19, 20
_FRAME_API, _FRAME_CTX, _FRAME_FUTURE = 2, 3, 21


def _pointer_call(returns):
    """An intrinsic ``(function, argument)`` calling the C function at address ``function``
    on one 64-bit ``argument``; ``returns``: True for an ``int64`` result, False for none."""
    result = ir.IntType(64) if returns else ir.VoidType()

    @intrinsic
    def call(typingctx, function, argument):
        def codegen(context, builder, signature, args):
            fnty = ir.FunctionType(result, [ir.IntType(64)])
            value = builder.call(builder.inttoptr(args[0], fnty.as_pointer()), [args[1]])
            return value if returns else context.get_dummy_value()

        return (types.int64 if returns else types.none)(types.int64, types.int64), codegen

    return call


_call = _pointer_call(True)
"""An XLA API function on its argument struct; its error pointer (0: success)."""
_call_task = _pointer_call(False)
"""Run a task (``void (*)(void*)``) here."""
_words = stack_array(types.int64, 5)
"""``int64*`` to 5 words on the stack: an API call's argument struct."""


@intrinsic
def _malloc(typingctx, size):
    def codegen(context, builder, signature, args):
        fnty = ir.FunctionType(ir.IntType(8).as_pointer(), [ir.IntType(64)])
        fn = cgutils.get_or_insert_function(builder.module, fnty, "malloc")
        return builder.ptrtoint(builder.call(fn, [args[0]]), ir.IntType(64))

    return types.int64(types.int64), codegen


@intrinsic
def _free(typingctx, address):
    def codegen(context, builder, signature, args):
        fnty = ir.FunctionType(ir.VoidType(), [ir.IntType(8).as_pointer()])
        fn = cgutils.get_or_insert_function(builder.module, fnty, "free")
        builder.call(fn, [builder.inttoptr(args[0], ir.IntType(8).as_pointer())])
        return context.get_dummy_value()

    return types.none(types.int64), codegen


@intrinsic
def _fetch_sub(typingctx, address):
    """Atomically ``*address -= 1``; the value before."""

    def codegen(context, builder, signature, args):
        ptr = builder.inttoptr(args[0], ir.IntType(64).as_pointer())
        return builder.atomic_rmw("sub", ptr, ir.Constant(ir.IntType(64), 1), "seq_cst")

    return types.int64(types.int64), codegen


@intrinsic
def _claim(typingctx, address):
    """Atomically set ``*address`` from 0 to 1; whether this call did."""

    def codegen(context, builder, signature, args):
        ptr = builder.inttoptr(args[0], ir.IntType(64).as_pointer())
        zero, one = ir.Constant(ir.IntType(64), 0), ir.Constant(ir.IntType(64), 1)
        return builder.extract_value(builder.cmpxchg(ptr, zero, one, "seq_cst", "seq_cst"), 1)

    return types.boolean(types.int64), codegen


@cfunc(types.int32(), nopython=True, cache=True)
def _no_cpu():
    return 0


def _sched_getcpu_address(load_c_library=ctypes.CDLL):
    """glibc's ``sched_getcpu``, or a stand-in that says core 0 where the C library has none.

    ``load_c_library(None)`` opens the process's C library on Linux and macOS; on Windows it
    raises ``TypeError`` (a name is required), and macOS's library has no ``sched_getcpu``
    (``AttributeError``): both take the stand-in."""
    try:
        return ctypes.cast(load_c_library(None).sched_getcpu, ctypes.c_void_p).value
    except (AttributeError, OSError, TypeError):
        return _no_cpu.address


llvm.add_symbol("coopsat_sched_getcpu", _sched_getcpu_address())


@intrinsic
def _cpu(typingctx):
    """``sched_getcpu()``: the core this thread runs on now."""

    def codegen(context, builder, signature, args):
        fnty = ir.FunctionType(ir.IntType(32), [])
        fn = cgutils.get_or_insert_function(builder.module, fnty, "coopsat_sched_getcpu")
        return builder.sext(builder.call(fn, []), ir.IntType(64))

    return types.int64(), codegen


def register_task(name, task):
    """Make the numba ``cfunc`` ``task`` callable from compiled code by the C name ``name``, and
    return an intrinsic ``() -> int64`` giving its address there. The address is known only
    in this process, so cached code finds the task by name when it is loaded, not as a
    constant."""
    llvm.add_symbol(name, task.address)

    @intrinsic
    def address(typingctx):
        def codegen(context, builder, signature, args):
            fnty = ir.FunctionType(ir.VoidType(), [ir.IntType(64)])
            return builder.ptrtoint(cgutils.get_or_insert_function(builder.module, fnty, name), ir.IntType(64))

        return types.int64(), codegen

    return address


@njit(cache=True)
def span(k, tasks, m, align):
    """Spacecraft ``lo`` to ``hi`` − 1 of task ``k`` of ``tasks`` over ``m``, in whole
    multiples of ``align`` (the last takes the rest)."""
    per = -(-m // (tasks * align)) * align
    return min(m, k * per), min(m, (k + 1) * per)


@njit(cache=True)
def threads(frame):
    """Threads in XLA's pool for this call (1 when it offers none)."""
    api = carray(i64_at(frame[_FRAME_API]), 22)
    args = carray(_words(), 5)
    count = carray(_words(), 1)
    count[0] = 1
    args[0], args[1], args[2], args[3] = 32, 0, frame[_FRAME_CTX], count.ctypes.data
    if _call(api[_NUM_THREADS], args.ctypes.data) != 0:
        return 1
    return max(count[0], 1)


@njit(cache=True)
def record(tasks, shared):
    """A zeroed record for ``tasks`` tasks with ``shared`` words for the kernel (returned as
    the second value, to fill before :func:`start`)."""
    words = HEAD + 2 * tasks + shared
    r = carray(i64_at(_malloc(8 * words)), words)
    r[:] = 0
    r[3] = tasks
    return r, r[HEAD + 2 * tasks:]


@njit(cache=True)
def start(frame, r, task_address):
    """Run the tasks of record ``r`` (its kernel words filled) on XLA's pool and make XLA wait
    for them (the call's future); the handler then returns at once. False when XLA gives no
    future: nothing started, ``r`` freed; the caller does the work itself. A task XLA
    refuses to schedule runs here, before the handler returns."""
    api = carray(i64_at(frame[_FRAME_API]), 22)
    args = carray(_words(), 5)
    args[0], args[1], args[2] = 24, 0, 0
    if _call(api[_FUTURE_CREATE], args.ctypes.data) != 0 or args[2] == 0:
        _free(r.ctypes.data)
        return False
    tasks = r[3]
    r[0], r[1], r[2] = tasks, args[2], frame[_FRAME_API]
    frame[_FRAME_FUTURE] = args[2]
    for k in range(tasks):
        r[HEAD + k] = k
    for k in range(1, tasks):
        data = r.ctypes.data + 8 * (HEAD + k)
        args[0], args[1], args[2], args[3], args[4] = 40, 0, frame[_FRAME_CTX], task_address, data
        if _call(api[_SCHEDULE], args.ctypes.data) != 0:
            _call_task(task_address, data)
    # The first span runs on this thread meanwhile (the pool may be this thread alone).
    _call_task(task_address, r.ctypes.data + 8 * HEAD)
    return True


@njit(cache=True)
def task_words(data, shared):
    """In a task given ``data``: (the span it does, the number of tasks, the ``shared`` kernel
    words).

    Spans are claimed, not assigned: each task takes the span of the core it runs on
    (``sched_getcpu() mod tasks``) when no other task has, else the first one left, so a
    span's spacecraft tend to stay in one core's cache from tick to tick although the
    thread that goes on with XLA's work changes from call to call (docs/engine-notes.md).
    Each of the T tasks claims exactly one of the T spans."""
    k = carray(i64_at(data), 1)[0]
    head = data - 8 * (HEAD + k)
    tasks = carray(i64_at(head), HEAD)[3]
    claims = head + 8 * (HEAD + tasks)
    span = _cpu() % tasks
    if span < 0 or not _claim(claims + 8 * span):
        span = 0
        while not _claim(claims + 8 * span):
            span += 1
    return span, tasks, carray(i64_at(claims + 8 * tasks), shared)


@njit(cache=True)
def finish(data):
    """At the end of a task: the last one marks XLA's future available and frees the record."""
    k = carray(i64_at(data), 1)[0]
    address = data - 8 * (HEAD + k)
    if _fetch_sub(address) == 1:
        head = carray(i64_at(address), HEAD)
        api = carray(i64_at(head[2]), 22)
        args = carray(_words(), 5)
        args[0], args[1], args[2] = 24, 0, head[1]
        _call(api[_FUTURE_SET_AVAILABLE], args.ctypes.data)
        _free(address)
