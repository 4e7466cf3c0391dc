"""Consensus laws (3) and (4) of the 2010 consensus paper as one CPU pass: the native twin of
:func:`coopsat.control.consensus.consensus_sync_torque` / ``consensus_track_torque`` with the
network's gather done in the same loop.

XLA:CPU emits that law (gather each link's message, error quaternion, per-receiver sum) as a
loop fusion that recomputes the gather for every output component and is not vectorised,
and costs more than the whole RK4 tick of the native plant kernel (docs/engine-notes.md,
"Native kernels"). Here each link's
message is read from the network's table once (``table[:, index[e]]``: the transmitters'
current outboxes, or a delay line), its term computed in registers and added to its
receiver's sum.

Per link e from j = transmitter to i = receiver, in the operation order of ``quat_multiply``,
``quat_conjugate``, ``quat_positive`` and ``quat_vector``::

    e_q = H(q_j* ⊗ q_i)      (on the q0 ≥ 0 hemisphere when short_way)
    u_i += a_ij (α e_q + β (ω_i − ω_j))

then ``u = −u`` and, for law (4), ``u − K H(q_r* ⊗ q_i) − D (ω_i − ω_r)``. Results agree with
XLA's to a few ulps (XLA may contract into FMAs; numba with ``fastmath=False`` does not). A
run's result depends only on its own rows, so a run in a batch equals the run alone.
"""

import numpy as np
from numba import carray, cfunc, njit, types

from coopsat.sim.native import pool
from coopsat.sim.native.pool import PARALLEL_MIN

from coopsat.sim.native.ffi import (
    HANDLER_SIGNATURE, answer_metadata, buffer, f64_at, i32_at, i64_at, stack_array, vectorise_many_rows,
)

vectorise_many_rows()

TARGET = "coopsat_consensus_law"
"""Name of the XLA FFI target (CPU)."""

TASK = "coopsat_consensus_law_task"
"""C name of the kernel's pool task."""



N_PARAMS = 11
"""Per-run scalars, in order: α, β, K, D, q_r (4), ω_r (3)."""


@njit(fastmath=False, error_model="numpy", cache=True, inline="always")
def _error_vector(p0, p1, p2, p3, q0, q1, q2, q3, short_way):
    """``H(p* ⊗ q)`` (3 scalars), flipped to the ``(p* ⊗ q)0 ≥ 0`` hemisphere when
    ``short_way``; ``quat_multiply(quat_conjugate(p), q)`` term by term."""
    c1, c2, c3 = -p1, -p2, -p3
    e0 = p0 * q0 - c1 * q1 - c2 * q2 - c3 * q3
    e1 = p0 * q1 + c1 * q0 + c2 * q3 - c3 * q2
    e2 = p0 * q2 - c1 * q3 + c2 * q0 + c3 * q1
    e3 = p0 * q3 + c1 * q2 - c2 * q1 + c3 * q0
    # Arithmetic, not a branch: a conditional here keeps the loops around it scalar.
    sign = 1.0 - 2.0 * (short_way & (e0 < 0.0))
    return sign * e1, sign * e2, sign * e3


@njit(fastmath=False, error_model="numpy", cache=True, inline="always")
def _message(q_tab, w_tab, j):
    """Column ``j`` of the message table (q then ω, 7 scalars); NaN for a column outside it,
    as ``jnp.take`` fills (the engine then stops on the non-finite state; no stray read)."""
    inside = np.uint64(j) < q_tab.shape[1]
    c = np.uint64(j) if inside else np.uint64(0)
    f = 1.0 if inside else np.nan  # × 1 is exact; a branch here keeps the loops around it scalar
    return (f * q_tab[0, c], f * q_tab[1, c], f * q_tab[2, c], f * q_tab[3, c],
            f * w_tab[0, c], f * w_tab[1, c], f * w_tab[2, c])


BLOCK = 128
"""Receivers per block of the padded-table loop (its scratch lives on the stack)."""


_stack_rows = stack_array(types.float64, 10 * BLOCK)
"""10 rows of :data:`BLOCK` doubles of stack scratch: messages (7) and sums (3)."""


@njit(fastmath=False, error_model="numpy", cache=True, inline="always")
def _add_terms(mq, mw, off, q, w, r0, weight, base, m, alpha, beta, short_way, acc):
    """``acc[:, i] += a (α e_q + β (ω_r − ω_j))`` for receivers ``r = r0 + i``, i < m, whose
    messages are columns ``off + i`` of ``mq`` (4, ·) and ``mw`` (3, ·), weights
    ``weight[base + i]``. Indices are unsigned: numba then emits no negative-index wrap-around
    select, which would slow this loop down."""
    for i in range(m):
        k = np.uint64(i)
        r = np.uint64(r0) + k
        j = np.uint64(off) + k
        a = weight[np.uint64(base) + k]
        e1, e2, e3 = _error_vector(mq[0, j], mq[1, j], mq[2, j], mq[3, j],
                                   q[0, r], q[1, r], q[2, r], q[3, r], short_way)
        acc[0, k] += a * (alpha * e1 + beta * (w[0, r] - mw[0, j]))
        acc[1, k] += a * (alpha * e2 + beta * (w[1, r] - mw[1, j]))
        acc[2, k] += a * (alpha * e3 + beta * (w[2, r] - mw[2, j]))


@njit(fastmath=False, error_model="numpy", cache=True)
def _padded(q_tab, w_tab, q, w, index, weight, p, short_way, track, u, lo, hi):
    """Law (3) or (4) (``p``: :data:`N_PARAMS`) over a padded in-neighbour table:
    ``index``/``weight`` (d·n,), slot k of receiver i at ``k·n + i``; writes ``u`` (3, n) of
    receivers ``lo`` to ``hi`` − 1.

    Receivers go in blocks of :data:`BLOCK`, one per SIMD lane. Within a block a slot's
    transmitters are often consecutive table columns (rings, chains, circulant graphs, a delay
    line of such): those messages are read in place with unit stride; otherwise they are
    first copied to stack scratch one by one (no hardware gather: with the "Downfall"
    mitigation of current Intel microcode, vector gathers are slower than scalar loads)."""
    n, t = q.shape[1], q_tab.shape[1]
    scratch = carray(_stack_rows(), (10, BLOCK))
    mq, mw, acc = scratch[:4], scratch[4:7], scratch[7:]
    alpha, beta = p[0], p[1]
    for r0 in range(lo, hi, BLOCK):
        m = min(BLOCK, hi - r0)
        for i in range(m):
            acc[0, i] = 0.0
            acc[1, i] = 0.0
            acc[2, i] = 0.0
        for k in range(index.shape[0] // n):
            base = k * n + r0
            j0 = index[base]
            breaks = 0
            for i in range(m):
                breaks += index[base + i] != j0 + i
            if breaks == 0 and j0 + m <= t:
                _add_terms(q_tab, w_tab, j0, q, w, r0, weight, base, m, alpha, beta, short_way, acc)
            else:
                for i in range(m):
                    mq[0, i], mq[1, i], mq[2, i], mq[3, i], mw[0, i], mw[1, i], mw[2, i] = _message(
                        q_tab, w_tab, index[base + i])
                _add_terms(mq, mw, 0, q, w, r0, weight, base, m, alpha, beta, short_way, acc)
        _finish(q, w, p, short_way, track, r0, m, acc, u)


@njit(fastmath=False, error_model="numpy", cache=True)
def _edges(q_tab, w_tab, q, w, index, dst, weight, p, short_way, track, u):
    """As :func:`_padded` for an edge list (E,) sorted by receiver ``dst`` (a scatter: scalar)."""
    alpha, beta = p[0], p[1]
    n = q.shape[1]
    u[:] = 0.0
    for e in range(index.shape[0]):
        i, a = np.uint64(dst[e]), weight[e]
        if i >= n:  # as segment_sum: a link to nobody adds nothing
            continue
        p0, p1, p2, p3, v0, v1, v2 = _message(q_tab, w_tab, index[e])
        e1, e2, e3 = _error_vector(p0, p1, p2, p3, q[0, i], q[1, i], q[2, i], q[3, i], short_way)
        u[0, i] += a * (alpha * e1 + beta * (w[0, i] - v0))
        u[1, i] += a * (alpha * e2 + beta * (w[1, i] - v1))
        u[2, i] += a * (alpha * e3 + beta * (w[2, i] - v2))
    _finish(q, w, p, short_way, track, 0, q.shape[1], u, u)


@njit(fastmath=False, error_model="numpy", cache=True, inline="always")
def _finish(q, w, p, short_way, track, r0, m, acc, u):
    """``u[:, r0 + i] = −acc[:, i]`` for i < m, less law (4)'s reference terms
    ``K H(q_r* ⊗ q_i) + D (ω_i − ω_r)`` when ``track`` (``p``: :data:`N_PARAMS`)."""
    k_p, k_d = p[2], p[3]
    for i in range(m):
        k = np.uint64(i)
        r = np.uint64(r0) + k
        u0, u1, u2 = -acc[0, k], -acc[1, k], -acc[2, k]
        if track:
            e1, e2, e3 = _error_vector(p[4], p[5], p[6], p[7], q[0, r], q[1, r], q[2, r], q[3, r], short_way)
            u0, u1, u2 = u0 - k_p * e1 - k_d * (w[0, r] - p[8]), u1 - k_p * e2 - k_d * (w[1, r] - p[9]), \
                u2 - k_p * e3 - k_d * (w[2, r] - p[10])
        u[0, r], u[1, r], u[2, r] = u0, u1, u2


_WORDS = 13
"""Kernel words of a pool record: the addresses of the q and ω table, q, ω, index, weight,
params and u; T, n, E; short way, tracking."""


@cfunc(types.void(types.int64), nopython=True, error_model="numpy", cache=True)
def _task(data):
    """One span of receivers (whole blocks) on XLA's pool (:mod:`coopsat.sim.native.pool`)."""
    k, tasks, words = pool.task_words(data, _WORDS)
    t, n, links = words[8], words[9], words[10]
    lo, hi = pool.span(k, tasks, n, BLOCK)
    _padded(carray(f64_at(words[0]), (4, t)), carray(f64_at(words[1]), (3, t)), carray(f64_at(words[2]), (4, n)),
            carray(f64_at(words[3]), (3, n)), carray(i32_at(words[4]), links), carray(f64_at(words[5]), links),
            carray(f64_at(words[6]), N_PARAMS), words[11] != 0, words[12] != 0, carray(f64_at(words[7]), (3, n)),
            lo, hi)
    pool.finish(data)


_task_address = pool.register_task(TASK, _task)


@cfunc(HANDLER_SIGNATURE, nopython=True, error_model="numpy", cache=True)
def handler(frame):
    """XLA FFI handler of :data:`TARGET`. Arguments: the message table q (…, 4, T) and
    ω (…, 3, T); the receivers' own q (…, 4, n) and ω (…, 3, n); per link (…, 1, E) the
    table column ``index`` (int32), the receiver ``dst`` (int32) and the weight; the
    per-run scalars (…, 1, :data:`N_PARAMS`); flags (…, 1, 4) int64: padded table, short way,
    tracking, cores it may use. Result: u (…, 3, n) N·m. Leading dimensions (…) are vmap's, done in turn. One
    run of at least :data:`PARALLEL_MIN` spacecraft over a padded table is cut into spans of
    receivers run on XLA's thread pool (the handler returns before they finish; XLA waits)."""
    if answer_metadata(frame):
        return 0
    tab_at, lead, t = buffer(frame, 0, False)
    q_at, _, n = buffer(frame, 2, False)
    index_at, _, links = buffer(frame, 4, False)
    addresses = (tab_at, buffer(frame, 1, False)[0], q_at, buffer(frame, 3, False)[0], index_at,
                 buffer(frame, 6, False)[0], buffer(frame, 7, False)[0], buffer(frame, 0, True)[0])
    flags = carray(i64_at(buffer(frame, 8, False)[0]), (lead, 4))
    if lead == 1 and n >= PARALLEL_MIN and flags[0, 0] != 0:
        tasks = min(pool.threads(frame), flags[0, 3], n // (PARALLEL_MIN // 2))
        if tasks > 1:
            r, words = pool.record(tasks, _WORDS)
            for i in range(8):
                words[i] = addresses[i]
            words[8], words[9], words[10], words[11], words[12] = t, n, links, flags[0, 1], flags[0, 2]
            if pool.start(frame, r, _task_address()):
                return 0
    q_tab = carray(f64_at(addresses[0]), (lead, 4, t))
    w_tab = carray(f64_at(addresses[1]), (lead, 3, t))
    q = carray(f64_at(addresses[2]), (lead, 4, n))
    w = carray(f64_at(addresses[3]), (lead, 3, n))
    index = carray(i32_at(addresses[4]), (lead, links))
    dst = carray(i32_at(buffer(frame, 5, False)[0]), (lead, links))
    weight = carray(f64_at(addresses[5]), (lead, links))
    params = carray(f64_at(addresses[6]), (lead, N_PARAMS))
    u = carray(f64_at(addresses[7]), (lead, 3, n))
    for b in range(lead):
        short_way, track = flags[b, 1] != 0, flags[b, 2] != 0
        if flags[b, 0] != 0:
            _padded(q_tab[b], w_tab[b], q[b], w[b], index[b], weight[b], params[b], short_way, track, u[b], 0, n)
        else:
            _edges(q_tab[b], w_tab[b], q[b], w[b], index[b], dst[b], weight[b], params[b], short_way, track, u[b])
    return 0
