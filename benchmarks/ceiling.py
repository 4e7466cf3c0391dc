"""The CPU *ceiling* for ``coopsat bench``'s "consensus" case: the same closed loop, hand-fused.

``coopsat bench`` times the JAX engine on a random formation of N spacecraft running law (3)
of the 2010 consensus paper over an undirected unit-weight ring (``bench_system(n,
"consensus-sync")``). This module computes the same arithmetic, in the same float64 operation
order, as the fastest plain CPU loop we know how to write, so that the engine's
throughput can be quoted as a fraction of what the machine can do (``coopsat bench`` prints
that fraction). Per tick of ``dt`` (0.01 s), with every spacecraft commanded from the same
snapshot of the state at the start of the tick:

* law (3): ``u_i = −Σ_j a_ij [α H(q_j* ⊗ q_i) + β (ω_i − ω_j)]`` over the ring neighbours
  ``i − 1`` and ``i + 1`` (mod n, weight 1; n = 2: the one other spacecraft, once; n = 1:
  nobody, u = 0), raw error quaternion (``short_way=False``);
* ideal torque actuator: ``u`` clipped per body axis to ``±torque_max`` and held over the tick;
* one classical RK4 step of ``q̇ = ½ q ⊗ [0, ω]`` (scalar-first Hamilton product) and
  ``I ω̇ = τ − ω × (I ω)`` with principal (diagonal) inertia, ``ω̇ = I⁻¹ (τ − ω × I ω)``
  multiplied by the precomputed reciprocal moments as the engine does;
* ``q`` renormalised (times ``1/sqrt(|q|²)``, which is what XLA makes of the engine's ``q / |q|``).

What makes it fast:

* **Fused tick.** One pass over the spacecraft per tick computes each command from the
  snapshot and immediately integrates that spacecraft: the clip, the four RK4 stages and the
  renormalisation all live in registers; only the new state is stored (7 loads of the
  spacecraft's own state, 14 of its two neighbours', 6 of inertia, 7 stores). The state is
  double buffered (read the old rows, write the new ones, swap), so a spacecraft's update never
  sees a neighbour's new state, and no per-tick temporary is allocated.
* **Component-major rows.** ``q`` is four contiguous rows (4, n), ``ω`` three (3, n), the
  principal moments and their reciprocals three each; each spacecraft is one SIMD lane.
* **SIMD over spacecraft, no branch.** The inner loop (:func:`_span`) runs over a contiguous
  spacecraft index with the ring neighbours at ``i ± 1`` (shifted unit-stride loads, no
  gather) and no branch: the wrap-around spacecraft ``0`` and ``n − 1`` are done apart, as
  scalars. LLVM vectorises it (4 doubles per AVX2/AVX-512 register, sqrt and division
  included). Three things would silently keep it scalar, and are avoided: numba's
  ``error_model="python"`` (a division-by-zero check is an early exit: ``"numpy"`` here);
  array arguments to inlined helpers (reference-counting calls: the helpers take scalars);
  and LLVM's budget of 8 run-time alias checks (13 input rows against 7 output rows need
  about 150, once per block: raised below, as numba cannot mark arguments ``noalias``).
* **Small rings** (n < :data:`SMALL`) run one scalar loop with no call per tick instead: too
  few spacecraft to fill SIMD lanes.
* **Blocks.** The vectorised pass goes through the spacecraft in blocks of :data:`BLOCK`
  (the alias checks are paid once per block); the parallel variant hands blocks to numba's
  threads (``prange``, one parallel region per tick), from :data:`PARALLEL_MIN` spacecraft
  (below it, starting a parallel region every tick costs more than the second thread saves).

The engine's arithmetic is followed operation for operation (the products and sums of
``quat_multiply``, ``quat_kinematics`` and ``omega_dot_b`` in their order, ``h/6`` as
``h·(1/6)`` and the renormalisation as a product by ``1/sqrt`` as XLA rewrites them), with
``fastmath=False``: the final states agree with the engine's to a few 1e-15 after 300 ticks
(``tests/unit/test_ceiling_kernel.py``). They are not bit-identical: XLA:CPU computes that
``rsqrt`` from the hardware's 14-bit estimate and two Newton steps (not correctly rounded; see
its LLVM IR under ``XLA_FLAGS=--xla_dump_to``), and its backend may contract products and sums
into FMAs; neither is reproduced here (ulp-level differences per tick).

Needs numba (a dependency of coopsat since its native kernels). Run as a script for a
table of rates: ``python benchmarks/ceiling.py``.
"""

import sys
import time
import types

import numpy as np

try:
    import llvmlite.binding as _llvm
    import numba
    from numba import njit, prange
except ImportError as err:  # pragma: no cover - depends on the environment
    raise ImportError(
        "benchmarks/ceiling.py needs numba: pip install numba"
    ) from err


# The vectorised loop reads 13 rows and writes 7 (``_span``): proving at run time that no output
# row overlaps an input takes about 150 pointer comparisons (once per block, nothing per
# spacecraft), past LLVM's default budget of 8, beyond which it silently leaves the loop scalar
# (3-4x slower). numba cannot mark plain function arguments ``noalias``, so raise the budget.
# These are process-wide options of llvmlite's LLVM (numba's, not XLA's); they change only
# whether a loop may be vectorised behind run-time checks, never the arithmetic.
_llvm.set_option("ceiling", "-runtime-memory-check-threshold=1024")
_llvm.set_option("ceiling", "-vectorize-memory-check-threshold=1024")


# numba's cache (``cache=True``) records each kernel's module by name and imports it again when
# it loads the kernel in a later process. This file is loaded by path under various names
# (``coopsat.workflows.bench`` and the tests use importlib, often without registering the module), so
# its functions take one fixed module name, registered in ``sys.modules`` (the module itself
# when run as a script, else a namespace with its globals, completed at the end of the file).
MODULE_NAME = "coopsat_ceiling"
if __name__ != "__main__":
    __name__ = MODULE_NAME  # noqa: A001  (functions defined below take their __module__ from it)
_registry = sys.modules.get(MODULE_NAME)
if _registry is None:
    _registry = sys.modules[__name__] if __name__ == "__main__" else types.ModuleType(MODULE_NAME)
    sys.modules[MODULE_NAME] = _registry


BLOCK = 512
"""Spacecraft per block of the tick's pass (and per work item of the parallel variant)."""

SMALL = 16
"""Rings smaller than this run the scalar kernel (:func:`_run_small`)."""

PARALLEL_MIN = 2048
"""Rings smaller than this run on one thread even when more are offered."""


# --- one spacecraft ---------------------------------------------------------------------------


@njit(fastmath=False, error_model="numpy", cache=True, inline="always")
def _link(qi0, qi1, qi2, qi3, wi0, wi1, wi2, qj0, qj1, qj2, qj3, wj0, wj1, wj2, alpha, beta):
    """One link's term of law (3), ``α H(q_j* ⊗ q_i) + β (ω_i − ω_j)``, N·m (3 scalars).

    The Hamilton product of ``[qj0, −qj1, −qj2, −qj3]`` and ``q_i`` in the order of
    ``coopsat.geometry.quaternion.quat_multiply`` (negations folded in: exact)."""
    e1 = ((qj0 * qi1 - qj1 * qi0) - qj2 * qi3) + qj3 * qi2
    e2 = ((qj0 * qi2 + qj1 * qi3) - qj2 * qi0) - qj3 * qi1
    e3 = ((qj0 * qi3 - qj1 * qi2) + qj2 * qi1) - qj3 * qi0
    return (alpha * e1 + beta * (wi0 - wj0), alpha * e2 + beta * (wi1 - wj1), alpha * e3 + beta * (wi2 - wj2))


@njit(fastmath=False, error_model="numpy", cache=True, inline="always")
def _clip(u, m):
    """``min(max(u, −m), m)``, as ``jnp.clip``."""
    return min(max(u, -m), m)


@njit(fastmath=False, error_model="numpy", cache=True, inline="always")
def _deriv(q0, q1, q2, q3, w0, w1, w2, t0, t1, t2, i0, i1, i2, j0, j1, j2):
    """``(q̇, ω̇)``: ``½ q ⊗ [0, ω]`` (1/s) and ``I⁻¹ (τ − ω × I ω)`` (rad/s²), 7 scalars,
    in the operation order of ``quat_kinematics`` and ``omega_dot_b``."""
    h0 = i0 * w0
    h1 = i1 * w1
    h2 = i2 * w2
    return (
        -0.5 * ((q1 * w0 + q2 * w1) + q3 * w2),
        0.5 * ((q0 * w0 - q3 * w1) + q2 * w2),
        0.5 * ((q3 * w0 + q0 * w1) - q1 * w2),
        0.5 * ((q1 * w1 - q2 * w0) + q0 * w2),
        j0 * (t0 - (w1 * h2 - w2 * h1)),
        j1 * (t1 - (w2 * h0 - w0 * h2)),
        j2 * (t2 - (w0 * h1 - w1 * h0)),
    )


@njit(fastmath=False, error_model="numpy", cache=True, inline="always")
def _rk4(q0, q1, q2, q3, w0, w1, w2, t0, t1, t2, i0, i1, i2, j0, j1, j2, h):
    """One RK4 step of length ``h`` (s) under the held torque ``t`` (N·m), then ``q``
    renormalised; 7 scalars (q, ω)."""
    hh = 0.5 * h
    h6 = h * (1.0 / 6.0)  # the engine's h / 6, as XLA rewrites it (a product by the reciprocal)
    a0, a1, a2, a3, a4, a5, a6 = _deriv(q0, q1, q2, q3, w0, w1, w2, t0, t1, t2, i0, i1, i2, j0, j1, j2)
    b0, b1, b2, b3, b4, b5, b6 = _deriv(
        q0 + hh * a0, q1 + hh * a1, q2 + hh * a2, q3 + hh * a3, w0 + hh * a4, w1 + hh * a5, w2 + hh * a6,
        t0, t1, t2, i0, i1, i2, j0, j1, j2,
    )
    c0, c1, c2, c3, c4, c5, c6 = _deriv(
        q0 + hh * b0, q1 + hh * b1, q2 + hh * b2, q3 + hh * b3, w0 + hh * b4, w1 + hh * b5, w2 + hh * b6,
        t0, t1, t2, i0, i1, i2, j0, j1, j2,
    )
    d0, d1, d2, d3, d4, d5, d6 = _deriv(
        q0 + h * c0, q1 + h * c1, q2 + h * c2, q3 + h * c3, w0 + h * c4, w1 + h * c5, w2 + h * c6,
        t0, t1, t2, i0, i1, i2, j0, j1, j2,
    )
    n0 = q0 + h6 * (((a0 + 2.0 * b0) + 2.0 * c0) + d0)
    n1 = q1 + h6 * (((a1 + 2.0 * b1) + 2.0 * c1) + d1)
    n2 = q2 + h6 * (((a2 + 2.0 * b2) + 2.0 * c2) + d2)
    n3 = q3 + h6 * (((a3 + 2.0 * b3) + 2.0 * c3) + d3)
    # XLA rewrites the engine's q / sqrt(|q|²) as q · rsqrt(|q|²), rsqrt = 1 / sqrt: the same here.
    inv_norm = 1.0 / np.sqrt(((n0 * n0 + n1 * n1) + n2 * n2) + n3 * n3)
    return (
        n0 * inv_norm, n1 * inv_norm, n2 * inv_norm, n3 * inv_norm,
        w0 + h6 * (((a4 + 2.0 * b4) + 2.0 * c4) + d4),
        w1 + h6 * (((a5 + 2.0 * b5) + 2.0 * c5) + d5),
        w2 + h6 * (((a6 + 2.0 * b6) + 2.0 * c6) + d6),
    )


@njit(fastmath=False, error_model="numpy", cache=True)
def _edge(sq, sw, dq, dw, inertia, inv, i, jp, jn, links, h, alpha, beta, tmax):
    """Scalar update of spacecraft ``i`` hearing ``links`` (0, 1: ``jp``, or 2: ``jp`` and
    ``jn``) of its ring neighbours: the wrap-around ends, and the rings of n = 1 and 2."""
    qi0, qi1, qi2, qi3 = sq[0, i], sq[1, i], sq[2, i], sq[3, i]
    wi0, wi1, wi2 = sw[0, i], sw[1, i], sw[2, i]
    u0 = u1 = u2 = 0.0
    if links >= 1:
        u0, u1, u2 = _link(qi0, qi1, qi2, qi3, wi0, wi1, wi2,
                           sq[0, jp], sq[1, jp], sq[2, jp], sq[3, jp], sw[0, jp], sw[1, jp], sw[2, jp], alpha, beta)
    if links == 2:
        v0, v1, v2 = _link(qi0, qi1, qi2, qi3, wi0, wi1, wi2,
                           sq[0, jn], sq[1, jn], sq[2, jn], sq[3, jn], sw[0, jn], sw[1, jn], sw[2, jn], alpha, beta)
        u0, u1, u2 = u0 + v0, u1 + v1, u2 + v2
    r = _rk4(qi0, qi1, qi2, qi3, wi0, wi1, wi2,
             _clip(-u0, tmax), _clip(-u1, tmax), _clip(-u2, tmax),
             inertia[0, i], inertia[1, i], inertia[2, i], inv[0, i], inv[1, i], inv[2, i], h)
    dq[0, i], dq[1, i], dq[2, i], dq[3, i], dw[0, i], dw[1, i], dw[2, i] = r


# --- one tick ---------------------------------------------------------------------------------


@njit(fastmath=False, error_model="numpy", cache=True)
def _ends(sq, sw, dq, dw, inertia, inv, h, alpha, beta, tmax):
    """The ring's wrap-around spacecraft 0 and n − 1 (and the small rings n = 1, 2)."""
    n = sq.shape[1]
    if n == 1:
        _edge(sq, sw, dq, dw, inertia, inv, 0, 0, 0, 0, h, alpha, beta, tmax)
    elif n == 2:  # ring_adjacency(2): each hears the other once
        _edge(sq, sw, dq, dw, inertia, inv, 0, 1, 1, 1, h, alpha, beta, tmax)
        _edge(sq, sw, dq, dw, inertia, inv, 1, 0, 0, 1, h, alpha, beta, tmax)
    else:
        _edge(sq, sw, dq, dw, inertia, inv, 0, n - 1, 1, 2, h, alpha, beta, tmax)
        _edge(sq, sw, dq, dw, inertia, inv, n - 1, n - 2, 0, 2, h, alpha, beta, tmax)


@njit(fastmath=False, error_model="numpy", cache=True)
def _span(sq, sw, dq, dw, inertia, inv, lo, hi, h, alpha, beta, tmax):
    """Spacecraft ``lo`` to ``hi − 1`` (1 ≤ lo, hi ≤ n − 1: both ring neighbours inside): the
    loop LLVM vectorises. Only scalars cross the inlined helpers (arrays would bring reference
    counting calls into the loop, which stop vectorisation); at most 30 arguments each (more,
    and CPython compiles the call as ``f(*args)``, which numba cannot inline)."""
    # Row views, so that the loop index k starts at 0: numba then drops its negative-index
    # wrap-around selects (which LLVM would otherwise treat as indirect addressing).
    p0, p1, p2, p3 = sq[0, lo - 1:hi + 1], sq[1, lo - 1:hi + 1], sq[2, lo - 1:hi + 1], sq[3, lo - 1:hi + 1]
    v0, v1, v2 = sw[0, lo - 1:hi + 1], sw[1, lo - 1:hi + 1], sw[2, lo - 1:hi + 1]
    i0, i1, i2 = inertia[0, lo:hi], inertia[1, lo:hi], inertia[2, lo:hi]
    j0, j1, j2 = inv[0, lo:hi], inv[1, lo:hi], inv[2, lo:hi]
    o0, o1, o2, o3 = dq[0, lo:hi], dq[1, lo:hi], dq[2, lo:hi], dq[3, lo:hi]
    x0, x1, x2 = dw[0, lo:hi], dw[1, lo:hi], dw[2, lo:hi]
    for k in range(hi - lo):
        qi0, qi1, qi2, qi3, wi0, wi1, wi2 = p0[k + 1], p1[k + 1], p2[k + 1], p3[k + 1], v0[k + 1], v1[k + 1], v2[k + 1]
        a0, a1, a2 = _link(qi0, qi1, qi2, qi3, wi0, wi1, wi2, p0[k], p1[k], p2[k], p3[k], v0[k], v1[k], v2[k],
                           alpha, beta)
        b0, b1, b2 = _link(qi0, qi1, qi2, qi3, wi0, wi1, wi2, p0[k + 2], p1[k + 2], p2[k + 2], p3[k + 2],
                           v0[k + 2], v1[k + 2], v2[k + 2], alpha, beta)
        r = _rk4(qi0, qi1, qi2, qi3, wi0, wi1, wi2,
                 _clip(-(a0 + b0), tmax), _clip(-(a1 + b1), tmax), _clip(-(a2 + b2), tmax),
                 i0[k], i1[k], i2[k], j0[k], j1[k], j2[k], h)
        o0[k], o1[k], o2[k], o3[k], x0[k], x1[k], x2[k] = r


@njit(fastmath=False, error_model="numpy", cache=True)
def _tick_serial(sq, sw, dq, dw, inertia, inv, h, alpha, beta, tmax):
    """One tick on one thread: old state ``sq`` (4, n), ``sw`` (3, n) -> new ``dq``, ``dw``."""
    n = sq.shape[1]
    for lo in range(1, n - 1, BLOCK):
        _span(sq, sw, dq, dw, inertia, inv, lo, min(lo + BLOCK, n - 1), h, alpha, beta, tmax)
    _ends(sq, sw, dq, dw, inertia, inv, h, alpha, beta, tmax)


@njit(fastmath=False, error_model="numpy", cache=True, parallel=True)
def _tick_parallel(sq, sw, dq, dw, inertia, inv, h, alpha, beta, tmax, per):
    """One tick with blocks of ``per`` spacecraft spread over numba's threads; otherwise as
    :func:`_tick_serial`."""
    n = sq.shape[1]
    for b in prange(-(-max(n - 2, 0) // per)):
        lo = 1 + b * per
        _span(sq, sw, dq, dw, inertia, inv, lo, min(lo + per, n - 1), h, alpha, beta, tmax)
    _ends(sq, sw, dq, dw, inertia, inv, h, alpha, beta, tmax)


@njit(fastmath=False, error_model="numpy", cache=True)
def _run_small(q, w, inertia, inv, ticks, h, alpha, beta, tmax):
    """``ticks`` ticks of a small ring (n < :data:`SMALL`), as scalars: too few spacecraft to
    fill SIMD lanes, so one loop with the neighbours' indices computed, no run-time alias
    checks and no calls per tick. Arguments and result as :func:`_run_serial`."""
    n = q.shape[1]
    sq, sw = q.copy(), w.copy()
    dq, dw = np.empty_like(q), np.empty_like(w)
    for _ in range(ticks):
        for i in range(n):
            qi0, qi1, qi2, qi3, wi0, wi1, wi2 = sq[0, i], sq[1, i], sq[2, i], sq[3, i], sw[0, i], sw[1, i], sw[2, i]
            u0 = u1 = u2 = 0.0
            if n >= 2:  # ring_adjacency(2): each hears the other once; n ≥ 3: i − 1 and i + 1
                jp = i - 1 if i > 0 else n - 1
                u0, u1, u2 = _link(qi0, qi1, qi2, qi3, wi0, wi1, wi2, sq[0, jp], sq[1, jp], sq[2, jp], sq[3, jp],
                                   sw[0, jp], sw[1, jp], sw[2, jp], alpha, beta)
            if n >= 3:
                jn = i + 1 if i < n - 1 else 0
                v0, v1, v2 = _link(qi0, qi1, qi2, qi3, wi0, wi1, wi2, sq[0, jn], sq[1, jn], sq[2, jn], sq[3, jn],
                                   sw[0, jn], sw[1, jn], sw[2, jn], alpha, beta)
                u0, u1, u2 = u0 + v0, u1 + v1, u2 + v2
            r = _rk4(qi0, qi1, qi2, qi3, wi0, wi1, wi2, _clip(-u0, tmax), _clip(-u1, tmax), _clip(-u2, tmax),
                     inertia[0, i], inertia[1, i], inertia[2, i], inv[0, i], inv[1, i], inv[2, i], h)
            dq[0, i], dq[1, i], dq[2, i], dq[3, i], dw[0, i], dw[1, i], dw[2, i] = r
        sq, dq = dq, sq
        sw, dw = dw, sw
    return sq, sw


@njit(fastmath=False, error_model="numpy", cache=True)
def _run_serial(q, w, inertia, inv, ticks, h, alpha, beta, tmax):
    """``ticks`` ticks on one thread from ``q`` (4, n), ``w`` (3, n) (left unchanged); returns
    the final (q, ω), component-major."""
    sq, sw = q.copy(), w.copy()
    dq, dw = np.empty_like(q), np.empty_like(w)
    for _ in range(ticks):
        _tick_serial(sq, sw, dq, dw, inertia, inv, h, alpha, beta, tmax)
        sq, dq = dq, sq
        sw, dw = dw, sw
    return sq, sw


@njit(fastmath=False, error_model="numpy", cache=True)
def _run_parallel(q, w, inertia, inv, ticks, h, alpha, beta, tmax, per):
    """As :func:`_run_serial` on numba's threads (one parallel region per tick), in blocks of
    ``per`` spacecraft."""
    sq, sw = q.copy(), w.copy()
    dq, dw = np.empty_like(q), np.empty_like(w)
    for _ in range(ticks):
        _tick_parallel(sq, sw, dq, dw, inertia, inv, h, alpha, beta, tmax, per)
        sq, dq = dq, sq
        sw, dw = dw, sw
    return sq, sw


# --- interface ----------------------------------------------------------------------------------


def _component_major(q0, omega0, inertia_diag):
    """Interface (n, k) arrays -> the kernels' contiguous float64 rows: q (4, n) renormalised
    as the engine's initial state is, ω (3, n), principal moments (3, n) and reciprocals."""
    q = np.ascontiguousarray(np.asarray(q0, dtype=np.float64).T)
    q = q * (1.0 / np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]))  # as XLA does
    w = np.ascontiguousarray(np.asarray(omega0, dtype=np.float64).T)
    inertia = np.ascontiguousarray(np.asarray(inertia_diag, dtype=np.float64).T)
    if q.shape[0] != 4 or w.shape != (3, q.shape[1]) or inertia.shape != w.shape:
        raise ValueError(f"ceiling: need q0 (n, 4), omega0 and inertia_diag (n, 3); got {np.shape(q0)}, "
                         f"{np.shape(omega0)}, {np.shape(inertia_diag)}")
    return q, w, inertia, 1.0 / inertia


class _threads:
    """Context: numba's thread count set to ``n`` (at most the cores numba started with)."""

    def __init__(self, n):
        if not 1 <= n <= numba.config.NUMBA_NUM_THREADS:
            raise ValueError(f"ceiling: threads must be 1 to {numba.config.NUMBA_NUM_THREADS}, got {n}")
        self.n = n

    def __enter__(self):
        self.before = numba.get_num_threads()
        numba.set_num_threads(self.n)

    def __exit__(self, *exc):
        numba.set_num_threads(self.before)


def _runner(n, threads):
    """The fastest kernel for ``n`` spacecraft on at most ``threads`` threads: scalar below
    :data:`SMALL`, vectorised, and parallel only from :data:`PARALLEL_MIN` (below it one
    parallel region per tick costs more than it saves)."""
    if n < SMALL:
        return _run_small
    if threads == 1 or n < PARALLEL_MIN:
        return _run_serial
    per = max(1, min(BLOCK, -(-(n - 2) // threads)))  # at least one block per thread
    return lambda *args: _run_parallel(*args, per)


def ceiling_run(q0, omega0, inertia_diag, ticks, dt=0.01, alpha=1.0, beta=2.0, torque_max=0.05, threads=1):
    """Run the benchmark's closed loop (law (3) on the ring, clip, RK4, renormalisation).

    Parameters
    ----------
    q0 : (n, 4)
        Initial attitudes ``q_bi``, scalar first (renormalised first, as the engine does).
    omega0 : (n, 3)
        Initial body rates, rad/s.
    inertia_diag : (n, 3)
        Principal moments of inertia, kg·m² (body axes = principal axes).
    ticks : int
        Ticks of ``dt`` to run.
    dt : float
        Tick (control period and RK4 step), s.
    alpha, beta : float
        Gains of law (3): α in N·m, β in N·m·s/rad.
    torque_max : float
        Saturation of the ideal torque actuator per body axis, N·m.
    threads : int
        1: the serial kernel; more: the parallel one on that many of numba's threads.

    Returns
    -------
    q : ndarray (n, 4)
    omega : ndarray (n, 3)
        The state after ``ticks`` ticks, rad/s.
    """
    q, w, inertia, inv = _component_major(q0, omega0, inertia_diag)
    with _threads(threads):
        q, w = _runner(q.shape[1], threads)(q, w, inertia, inv, int(ticks), float(dt), float(alpha), float(beta), float(torque_max))
    return np.ascontiguousarray(q.T), np.ascontiguousarray(w.T)


def bench_formation(n, seed=0):
    """The random formation of ``bench_system(n, ..., seed=seed)`` (same draws in the same
    order): q (n, 4) unit, principal moments (n, 3) kg·m², ω (n, 3) rad/s."""
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    principal = rng.uniform(0.5, 1.5, size=(n, 3))
    omega = rng.normal(scale=0.1, size=(n, 3))
    return q, principal, omega


def ceiling_rate(n, ticks, threads=1, repeats=3, seed=0):
    """Time the ceiling on the benchmark's formation of ``n`` spacecraft for ``ticks`` ticks.

    Compiles (or loads numba's cache) and runs once before timing; the timings cover the
    kernel only (the state already component-major).

    Returns
    -------
    best_run_s : float
        Best wall time of ``repeats`` runs, s.
    rate : float
        Spacecraft-steps per second (``n · ticks / best_run_s``).
    """
    q0, principal, omega0 = bench_formation(n, seed)
    q, w, inertia, inv = _component_major(q0, omega0, principal)
    run = _runner(n, threads)
    args = (0.01, 1.0, 2.0, 0.05)
    with _threads(threads):
        run(q, w, inertia, inv, 1, *args)  # compile / warm up
        best = float("inf")
        for _ in range(repeats):
            t0 = time.perf_counter()
            run(q, w, inertia, inv, int(ticks), *args)
            best = min(best, time.perf_counter() - t0)
    return best, n * ticks / best


def _main():
    """Print M spacecraft-steps/s for a few formation sizes on 1 and 2 threads."""
    print(f"ceiling kernel of coopsat bench's consensus case (numba {numba.__version__}, float64, RK4)")
    print(f"{'N':>7}{'ticks':>9}{'1 thread':>11}{'2 threads':>11}   M spacecraft-steps/s")
    for n in (5, 1000, 10000):
        ticks = int(np.clip(2e7 / n, 2_000, 1_000_000) // 1000 * 1000)
        one = ceiling_rate(n, ticks, threads=1)[1]
        two = ceiling_rate(n, ticks, threads=min(2, numba.config.NUMBA_NUM_THREADS))[1]
        print(f"{n:>7}{ticks:>9}{one / 1e6:>11.1f}{two / 1e6:>11.1f}", flush=True)
    print(f"threading layer: {numba.threading_layer()}")


if _registry.__dict__ is not globals() and not hasattr(_registry, "ceiling_run"):
    _registry.__dict__.update(globals())

if __name__ == "__main__":
    _main()
