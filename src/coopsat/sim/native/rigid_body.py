"""RK4 of free rigid bodies under held torques, as one CPU pass: the native twin of the
engine's smooth tick for the plant the consensus papers fly (attitude only, principal
inertia, no gravity, no disturbance).

Per spacecraft (one SIMD lane of component-major rows), ``sub`` classical RK4 steps of length
``h`` of ``q̇ = ½ q ⊗ [0, ω]`` and ``I ω̇ = τ − ω × (I ω + h_w)`` (SPEC §0; 2010 consensus paper
eqs. (1)–(2)) with ``τ`` and the wheel momentum ``h_w`` held, then ``q`` renormalised: what
``sim.tick._integrate_tick`` computes for such a plant through ``_rk4``,
``plant_derivative`` and ``quat_normalize``, in the same operation order (products and sums of
``quat_kinematics``, ``omega_dot_b`` and ``cross``; the stage inputs ``z + (h/2)·k``; the
update ``z + (h/6)·(((k1 + 2 k2) + 2 k3) + k4)``). XLA:CPU splits that tick into about nine
passes over memory (its fusion does not emit several outputs from one loop); here it is one,
with every stage in registers. The results agree with XLA's to a few ulps per tick, not
bit for bit: XLA computes ``1/sqrt`` from the hardware estimate and Newton steps and may
contract products and sums into FMAs; numba with ``fastmath=False`` does neither. A
spacecraft's result does not depend on its neighbours in memory (a lane's arithmetic is the
same in the vector body and the scalar remainder), so a run in a batch equals the run alone.
"""

import numpy as np
from numba import carray, cfunc, njit, types
from numba.extending import overload

from coopsat.sim.native import pool
from coopsat.sim.native.pool import PARALLEL_MIN

from coopsat.sim.native.ffi import (
    HANDLER_SIGNATURE, answer_metadata, buffer, f64_at, i64_at, stack_array, vectorise_many_rows,
)

vectorise_many_rows()

TARGET = "coopsat_rigid_body_rk4"
"""Name of the XLA FFI target (CPU)."""

TASK = "coopsat_rigid_body_rk4_task"
"""C name of the kernel's pool task."""

SEGMENTS_TARGET = "coopsat_rigid_body_rk4_segments"
"""Name of the XLA FFI target of the piecewise tick (:func:`segments_handler`)."""


def _lane(h, r):
    """Step length of spacecraft ``r``: ``h`` itself (one for every spacecraft) or ``h[r]``
    (a row, one each: the segments of a pulsed tick end at each spacecraft's own switch
    instants)."""


@overload(_lane, inline="always")
def _lane_overload(h, r):
    if isinstance(h, types.Array):
        return lambda h, r: h[r]
    return lambda h, r: h


@njit(fastmath=False, error_model="numpy", cache=True, inline="always")
def _deriv(q0, q1, q2, q3, w0, w1, w2, t0, t1, t2, i0, i1, i2, j0, j1, j2, hw0, hw1, hw2):
    """``(q̇, ω̇)``, 7 scalars, in the operation order of ``quat_kinematics`` and
    ``omega_dot_b`` (principal moments ``i``, their reciprocals ``j``)."""
    h0 = i0 * w0 + hw0
    h1 = i1 * w1 + hw1
    h2 = i2 * w2 + hw2
    return (
        -0.5 * ((q1 * w0 + q2 * w1) + q3 * w2),
        0.5 * ((q0 * w0 - q3 * w1) + q2 * w2),
        0.5 * ((q3 * w0 + q0 * w1) - q1 * w2),
        0.5 * ((-q2 * w0 + q1 * w1) + q0 * w2),
        j0 * (t0 - (w1 * h2 - w2 * h1)),
        j1 * (t1 - (w2 * h0 - w0 * h2)),
        j2 * (t2 - (w0 * h1 - w1 * h0)),
    )


BLOCK = 128
"""Spacecraft per block: each block's new state is built in stack scratch, then stored."""

_stack_rows = stack_array(types.float64, 7 * BLOCK)


@njit(fastmath=False, error_model="numpy", cache=True, inline="always")
def _step_one(q, w, hw, tq, inertia, inv, r, h, last):
    """One RK4 step of length ``h`` of spacecraft ``r`` (an unsigned index): its new q (4, q
    renormalised when ``last``) and ω (3), 7 scalars."""
    hh = 0.5 * h
    h6 = h * (1.0 / 6.0)  # the engine's h / 6.0, as XLA rewrites it
    q0, q1, q2, q3 = q[0, r], q[1, r], q[2, r], q[3, r]
    w0, w1, w2 = w[0, r], w[1, r], w[2, r]
    t0, t1, t2 = tq[0, r], tq[1, r], tq[2, r]
    i0, i1, i2 = inertia[0, r], inertia[1, r], inertia[2, r]
    j0, j1, j2 = inv[0, r], inv[1, r], inv[2, r]
    g0, g1, g2 = hw[0, r], hw[1, r], hw[2, r]
    a0, a1, a2, a3, a4, a5, a6 = _deriv(
        q0, q1, q2, q3, w0, w1, w2, t0, t1, t2, i0, i1, i2, j0, j1, j2, g0, g1, g2,
    )
    b0, b1, b2, b3, b4, b5, b6 = _deriv(
        q0 + hh * a0, q1 + hh * a1, q2 + hh * a2, q3 + hh * a3, w0 + hh * a4, w1 + hh * a5, w2 + hh * a6,
        t0, t1, t2, i0, i1, i2, j0, j1, j2, g0, g1, g2,
    )
    c0, c1, c2, c3, c4, c5, c6 = _deriv(
        q0 + hh * b0, q1 + hh * b1, q2 + hh * b2, q3 + hh * b3, w0 + hh * b4, w1 + hh * b5, w2 + hh * b6,
        t0, t1, t2, i0, i1, i2, j0, j1, j2, g0, g1, g2,
    )
    d0, d1, d2, d3, d4, d5, d6 = _deriv(
        q0 + h * c0, q1 + h * c1, q2 + h * c2, q3 + h * c3, w0 + h * c4, w1 + h * c5, w2 + h * c6,
        t0, t1, t2, i0, i1, i2, j0, j1, j2, g0, g1, g2,
    )
    q0 = q0 + h6 * (((a0 + 2.0 * b0) + 2.0 * c0) + d0)
    q1 = q1 + h6 * (((a1 + 2.0 * b1) + 2.0 * c1) + d1)
    q2 = q2 + h6 * (((a2 + 2.0 * b2) + 2.0 * c2) + d2)
    q3 = q3 + h6 * (((a3 + 2.0 * b3) + 2.0 * c3) + d3)
    # quat_normalize's q / sqrt(|q|²), which XLA makes q · (1 / sqrt(|q|²)); × 1 is exact.
    scale = 1.0 / np.sqrt(((q0 * q0 + q1 * q1) + q2 * q2) + q3 * q3) if last else 1.0
    return (q0 * scale, q1 * scale, q2 * scale, q3 * scale, w0 + h6 * (((a4 + 2.0 * b4) + 2.0 * c4) + d4),
            w1 + h6 * (((a5 + 2.0 * b5) + 2.0 * c5) + d5), w2 + h6 * (((a6 + 2.0 * b6) + 2.0 * c6) + d6))


@njit(fastmath=False, error_model="numpy", cache=True, inline="always")
def _rows(q, w, hw, tq, inertia, inv, h, last, q_out, w_out, lo, hi):
    """One RK4 step of length ``h`` (s; a scalar, or a row (M,): one per spacecraft) for
    spacecraft ``lo`` to ``hi`` − 1 of component-major rows: q (4, M), ω (3, M), h_w, τ, I,
    I⁻¹ (3, M); writes q_out (4, M), w_out (3, M), with q renormalised when ``last`` (the
    tick's last sub-step). ``q_out``/``w_out`` may be ``q``/``w`` (XLA updates one run's
    state in place).

    One spacecraft per SIMD lane. In place, a direct store would overlap the rows being read,
    and LLVM would take its scalar fallback: spacecraft then go in blocks of :data:`BLOCK`,
    each block's new state built in stack scratch (which aliases nothing) and then stored,
    both loops vectorised. Into other buffers (a batch) the new state is stored directly:
    the scratch pass would only cost time there. Indices are unsigned, so numba emits no
    negative-index wrap-around select."""
    if q_out.ctypes.data != q.ctypes.data:
        for i in range(lo, hi):
            r = np.uint64(i)
            (q_out[0, r], q_out[1, r], q_out[2, r], q_out[3, r],
             w_out[0, r], w_out[1, r], w_out[2, r]) = _step_one(q, w, hw, tq, inertia, inv, r, _lane(h, r), last)
        return
    new = carray(_stack_rows(), (7, BLOCK))
    for r0 in range(lo, hi, BLOCK):
        m = min(BLOCK, hi - r0)
        for i in range(m):
            k = np.uint64(i)
            new[0, k], new[1, k], new[2, k], new[3, k], new[4, k], new[5, k], new[6, k] = _step_one(
                q, w, hw, tq, inertia, inv, np.uint64(r0) + k, _lane(h, np.uint64(r0) + k), last)
        for i in range(m):
            k = np.uint64(i)
            r = np.uint64(r0) + k
            q_out[0, r], q_out[1, r], q_out[2, r], q_out[3, r] = new[0, k], new[1, k], new[2, k], new[3, k]
            w_out[0, r], w_out[1, r], w_out[2, r] = new[4, k], new[5, k], new[6, k]


@njit(fastmath=False, error_model="numpy", cache=True)
def _rows_at(q_at, w_at, hw_at, tq_at, inertia_at, inv_at, h, last, q_out_at, w_out_at, m, lo, hi):
    """:func:`_rows` on the rows (4 or 3, M) at these addresses. Kernels call this rather than
    :func:`_rows` itself: a numba call passes each array as a 9-word struct, and ten of them
    cost a noticeable part of a small call (docs/engine-notes.md), while the rows built here,
    with :func:`_rows` inlined, vectorise as before."""
    _rows(carray(f64_at(q_at), (4, m)), carray(f64_at(w_at), (3, m)), carray(f64_at(hw_at), (3, m)),
          carray(f64_at(tq_at), (3, m)), carray(f64_at(inertia_at), (3, m)), carray(f64_at(inv_at), (3, m)), h, last,
          carray(f64_at(q_out_at), (4, m)), carray(f64_at(w_out_at), (3, m)), lo, hi)


@njit(fastmath=False, error_model="numpy", cache=True)
def _steps(q_at, w_at, hw_at, tq_at, inertia_at, inv_at, h, sub, q_out_at, w_out_at, m, lo, hi):
    """``sub`` RK4 steps of spacecraft ``lo`` to ``hi`` − 1 of the rows at these addresses
    (:func:`_rows_at`); later ones from the previous one's result, in place."""
    for s in range(sub):
        first = s == 0
        _rows_at(q_at if first else q_out_at, w_at if first else w_out_at, hw_at, tq_at, inertia_at, inv_at, h,
                 s == sub - 1, q_out_at, w_out_at, m, lo, hi)


_WORDS = 11
"""Kernel words of a pool record: the addresses of q, ω, h_w, τ, I, I⁻¹, q_out, ω_out; M; the
sub-steps; h (float64 bits)."""


@cfunc(types.void(types.int64), nopython=True, error_model="numpy", cache=True)
def _task(data):
    """One span of the spacecraft on XLA's pool (:mod:`coopsat.sim.native.pool`)."""
    k, tasks, words = pool.task_words(data, _WORDS)
    m = words[8]
    h = carray(f64_at(words.ctypes.data + 8 * 10), 1)[0]
    lo, hi = pool.span(k, tasks, m, BLOCK)
    _steps(words[0], words[1], words[2], words[3], words[4], words[5], h, words[9], words[6], words[7], m, lo, hi)
    pool.finish(data)


_task_address = pool.register_task(TASK, _task)


@cfunc(HANDLER_SIGNATURE, nopython=True, error_model="numpy", cache=True)
def handler(frame):
    """XLA FFI handler of :data:`TARGET`. Arguments q (…, 4, M), ω, h_w, τ, I, I⁻¹ (…, 3, M),
    the sub-step h (…) s, the number of sub-steps (…) int64 and the cores it may use (…)
    int64; results q (…, 4, M), ω (…, 3,
    M). The leading dimensions (…, L in all) are vmap's: each of the L problems is done in
    turn. One problem of at least :data:`PARALLEL_MIN` spacecraft is cut into spans run on
    XLA's thread pool (the handler returns before they finish; XLA waits)."""
    if answer_metadata(frame):
        return 0
    q_at, lead, m = buffer(frame, 0, False)
    addresses = (q_at, buffer(frame, 1, False)[0], buffer(frame, 2, False)[0], buffer(frame, 3, False)[0],
                 buffer(frame, 4, False)[0], buffer(frame, 5, False)[0], buffer(frame, 0, True)[0],
                 buffer(frame, 1, True)[0])
    h = carray(f64_at(buffer(frame, 6, False)[0]), lead)
    sub = carray(i64_at(buffer(frame, 7, False)[0]), lead)
    cores = carray(i64_at(buffer(frame, 8, False)[0]), lead)
    if lead == 1 and m >= PARALLEL_MIN:
        tasks = min(pool.threads(frame), cores[0], m // (PARALLEL_MIN // 2))
        if tasks > 1:
            r, words = pool.record(tasks, _WORDS)
            for i in range(8):
                words[i] = addresses[i]
            words[8], words[9] = m, sub[0]
            carray(f64_at(words.ctypes.data + 8 * 10), 1)[0] = h[0]
            if pool.start(frame, r, _task_address()):
                return 0
    for k in range(lead):  # vmap's problems in turn: rows of 4 or 3 × M doubles each
        a4, a3 = 32 * m * k, 24 * m * k
        _steps(addresses[0] + a4, addresses[1] + a3, addresses[2] + a3, addresses[3] + a3, addresses[4] + a3,
               addresses[5] + a3, h[k], sub[k], addresses[6] + a4, addresses[7] + a3, m, 0, m)
    return 0


@cfunc(HANDLER_SIGNATURE, nopython=True, error_model="numpy", cache=True)
def segments_handler(frame):
    """XLA FFI handler of :data:`SEGMENTS_TARGET`: the tick as S consecutive segments, each
    with its own held torque and, per spacecraft, its own length (a pulsed actuator's tick cut
    at every switch instant), each in ``sub`` RK4 steps, then q renormalised. Arguments q
    (…, 4, M), ω, h_w (…, 3, M), τ (…, 3·S, M: segment s in rows 3s to 3s + 2), I, I⁻¹
    (…, 3, M), the step lengths h (…, S, M) s, the sub-steps and S (…) int64; results q
    (…, 4, M), ω (…, 3, M). The leading dimensions (…, L in all) are vmap's. One thread."""
    if answer_metadata(frame):
        return 0
    q_at, lead, m = buffer(frame, 0, False)
    sub = carray(i64_at(buffer(frame, 7, False)[0]), lead)
    n_seg = carray(i64_at(buffer(frame, 8, False)[0]), lead)[0]
    w_at, hw_at, tq_at = buffer(frame, 1, False)[0], buffer(frame, 2, False)[0], buffer(frame, 3, False)[0]
    inertia_at, inv_at = buffer(frame, 4, False)[0], buffer(frame, 5, False)[0]
    h = carray(f64_at(buffer(frame, 6, False)[0]), (lead, n_seg, m))
    q_out_at, w_out_at = buffer(frame, 0, True)[0], buffer(frame, 1, True)[0]
    for k in range(lead):
        a4, a3 = 32 * m * k, 24 * m * k
        for g in range(n_seg):
            for s in range(sub[k]):
                first = g == 0 and s == 0
                _rows_at(q_at + a4 if first else q_out_at + a4, w_at + a3 if first else w_out_at + a3, hw_at + a3,
                         tq_at + 24 * m * (k * n_seg + g), inertia_at + a3, inv_at + a3, h[k, g],
                         g == n_seg - 1 and s == sub[k] - 1, q_out_at + a4, w_out_at + a3, m, 0, m)
    return 0
