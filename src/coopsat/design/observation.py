"""Linear steady-state analysis of cooperative Earth observation (SPEC §5, Fang et al. 2019).

Two spacecraft, the reference r and a follower f, stare at one ground target. The image-plane
mismatch of the target is set by the *relative* attitude error ``e = θ_f − θ_r`` (the angle of
the difference of the two attitude errors). The paper reports |e| < 0.01° with cooperation
(law 23) against < 0.04° without (law 8 on both). This module says, from the linearised sampled
loop, what cooperation can and cannot change.

Model (per body axis; the laws' feed-forward cancels the gyroscopic coupling, so the axes
decouple; small angles, ``vec(δq) ≈ θ/2``, hence angle stiffness ``k1/2`` N·m/rad)
----------------------------------------------------------------------------------------------
Double integrator ``I θ̈ = u + d`` sampled at ``t_k = kT`` with the torque held over
``[t_k, t_k + T)`` (exact zero-order hold)::

    θ_{k+1} = θ_k + T θ̇_k + T²/(2I) (u_k + d_k),     θ̇_{k+1} = θ̇_k + T/I (u_k + d_k)

Per sample and spacecraft s ∈ {r, f}, independent and white: star-tracker angle noise
``n_s`` (σ_star rad), gyro rate noise ``g_s`` (σ_gyro rad/s), disturbance torque ``d_s``
(σ_torque N·m, constant over a period). A constant gyro bias ``b_s`` can be added to ``g_s``;
its steady effect is reported separately (``mean_*`` fields). With ``K = [k1/2, k2]`` and the
measurement ``m_s = [θ_s + n_s, θ̇_s + g_s]``:

* Reference, law 8:               ``u_r = −K m_r``.
* Independent follower, law 8:    ``u_f = −K m_f``.
* Cooperative follower, law 23 (law 8 tracking the reference's measured error), fed over the
  link ``D`` periods late (``delay_periods``):
  ``u_f,k = −K (m_f,k − m_r,k−D) + I a_k−D``,
  with the feed-forward ``a`` the reference's angular acceleration as the follower knows it.

The feed-forward ``a`` (argument ``cooperative_feedforward``):

``"commanded"`` (default; law 23 as flown in ``coopsat.control.observation``: the follower
    rebuilds the reference's law-8 command from the reference's message) ``a = u_r/I``.
``"actual"`` the reference's true acceleration over the period, ``a = (u_r + d_r)/I``: an
    idealised bound (a perfect accelerometer or disturbance observer on the reference).
``"estimated"`` a realisable version of ``"actual"``: the reference differences its gyro,
    ``a_{k−1} = (m_ω,k − m_ω,k−1)/T = (u_r,k−1 + d_r,k−1)/I + (g_r,k − g_r,k−1)/T``, so the
    message sent at k carries ``m_r,k−1`` and ``a_{k−1}`` (one period of extra latency on top of
    ``D``, and the differenced gyro noise imported into the follower).
``"none"`` no feed-forward: the follower only tracks ``θ_r + n_r`` with its PD loop.

Write the follower's received term as ``v = K m_r + I a`` so that ``u_f,k = −K m_f,k + v_k−D``.

What cooperation can change
---------------------------
*Law 23 as specified is law 8.* With ``a = u_r/I = −K m_r/I`` the received term is
``v = K m_r + u_r ≡ 0`` identically, for every ``D`` (it is the same identity evaluated D periods
earlier), so the cooperative follower's torque *is* the independent follower's torque, sample by
sample, noise included. In the linear regime, with the same gains on both spacecraft, law 23
changes nothing: not the sensor-noise part, not the disturbance part, not the steady bias
offset. (Differences can only come from what this model leaves out: unequal gains or inertia
models on the two spacecraft, torque saturation, large-angle kinematics, a message that did not
arrive.) The reason: the reference's error ``θ_r`` is caused by inputs its command does not
contain (``d_r``); its command only pushes ``θ_r`` back, and the follower, told "the reference
accelerates by ``u_r/I``" and "the reference sits at ``θ_r``", gets two terms that cancel.

*Sensor noise can never be removed.* Whatever the feed-forward, the follower tracks the
reference's *measured* error ``θ_r + n_r`` (and rate ``θ̇_r + g_r``), so ``n_r``, ``g_r`` reach
``θ_f`` while the reference's own loop puts them into ``θ_r`` too; and ``n_f``, ``g_f`` drive
the follower's loop exactly as in law 8. ``e`` therefore keeps both spacecraft's sensor noise;
``"none"`` even amplifies the reference's (``e ∋ T(1 + S) n_r`` against ``T n_r``, with ``T``,
``S`` the loop's complementary sensitivity and sensitivity).

*What a disturbance-sharing feed-forward removes.* With ``"actual"`` the received term is
``v = d_r``: the follower applies the reference's disturbance torque itself, so the
reference's disturbance response (and any slow deterministic tracking error the reference
has, e.g. a lag behind its desired attitude) leaves ``e`` except for the delay:
``e/ε = z^−D − 1`` (zero for D = 0; ``≈ −j ω D T`` for slow errors, i.e. a ramp error
``ε̇`` leaves ``−ε̇ D T``). ``"estimated"`` does the same with ``D + 1`` and imports the
differenced gyro noise ``I (g_r,k − g_r,k−1)/T`` as a torque on the follower; the double
integrator turns it into the rate step ``g_r,k − g_r,k−1``, high-pass noise that the follower's
loop filters, so the ``g_r`` part of ``e`` grows only moderately (about 25 % in std for the
example below). ``"none"`` removes slow reference errors by the loop's sensitivity,
``|S| ≈ (ω/ω_n)²`` below the bandwidth (plus the delay term), but adds sensor noise.

Outputs
-------
:func:`relative_error_covariance` builds the augmented state
``z = [θ_r, θ̇_r, θ_f, θ̇_f, m_r,k−1 (2), v_k−1 … v_k−D]`` with the noise
``w = [n_r, g_r, d_r, n_f, g_f, d_f]``, ``z_{k+1} = Φ z_k + Γ w_k``, and solves
``P = Φ P Φᵀ + Γ W Γᵀ`` (``scipy.linalg.solve_discrete_lyapunov``) once per source, so the
variance of e splits exactly into the six sources. Sampled values are the main output; the
intersample ("continuous-time average") variance ``(1/T) ∫_0^T E[e(t_k + τ)²] dτ`` follows from
``e(t_k + τ) = e_k + τ ė_k + τ²/(2I)(u_f + d_f − u_r − d_r)_k`` (a quadratic in τ, so 3-point
Gauss–Legendre quadrature of its square is exact). :func:`relative_error_transfer` gives the
deterministic part.

Example (realistic numbers; see the module's tests for the checks)::

    >>> inertia = np.array([0.28, 0.33, 0.35])
    >>> k1, k2 = pd_gains_for_bandwidth(inertia, 0.1, 0.7)   # k1 = 2 I ωn², k2 = 2 ζ ωn I
    >>> st = relative_error_covariance(inertia, k1, k2, 0.1, 4.85e-5, 1e-4, 1e-5, delay_periods=1)
    >>> bool(np.allclose(st.std_relative_cooperative_rad, st.std_relative_independent_rad))
    True
"""

from dataclasses import dataclass
from types import MappingProxyType
from typing import Mapping

import numpy as np
from scipy.linalg import solve_discrete_lyapunov

from coopsat.design.sampled_data import sampled_pd_radius

#: Noise sources, in the order of the noise vector ``w``.
SOURCES = ("n_r", "g_r", "d_r", "n_f", "g_f", "d_f")
#: Feed-forward variants of the cooperative follower (module notes).
FEEDFORWARDS = ("commanded", "actual", "estimated", "none")

_TH_R, _W_R, _TH_F, _W_F, _P_TH, _P_W = range(6)
_N_STATE_FIXED = 6
_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(3)


@dataclass(frozen=True, eq=False)
class RelativeErrorStats:
    """Steady-state statistics of the sampled loop, per axis (shape of the broadcast inputs).

    Angles in rad, variances in rad². ``contributions_*`` map each source of :data:`SOURCES`
    to its variance of ``e`` (they sum to the total). ``*_intersample`` are the averages over a
    period of the continuous-time variance. ``mean_*`` are the steady offsets from the gyro
    biases (zero without them).
    """

    std_reference_rad: object
    std_follower_independent_rad: object
    std_follower_cooperative_rad: object
    std_relative_independent_rad: object
    std_relative_cooperative_rad: object
    contributions_independent: Mapping[str, object]
    contributions_cooperative: Mapping[str, object]
    std_relative_independent_intersample_rad: object
    std_relative_cooperative_intersample_rad: object
    contributions_independent_intersample: Mapping[str, object]
    contributions_cooperative_intersample: Mapping[str, object]
    mean_reference_rad: object
    mean_follower_independent_rad: object
    mean_follower_cooperative_rad: object
    mean_relative_independent_rad: object
    mean_relative_cooperative_rad: object
    closed_loop_spectral_radius: object
    delay_periods: int
    cooperative_feedforward: str


def pd_gains_for_bandwidth(inertia_kgm2, natural_frequency_rad_s, damping_ratio=0.7):
    """Law-8 gains for a continuous-time natural frequency ``ωn`` and damping ``ζ`` per axis.

    ``I θ̈ = −(k1/2) θ − k2 θ̇`` gives ``k1 = 2 I ωn²`` (N·m) and ``k2 = 2 ζ ωn I`` (N·m·s/rad).
    """
    inertia = np.asarray(inertia_kgm2, dtype=float)
    wn = float(natural_frequency_rad_s)
    return 2.0 * inertia * wn**2, 2.0 * float(damping_ratio) * wn * inertia


def _check_law(feedforward, delay_periods):
    if feedforward not in FEEDFORWARDS:
        raise ValueError(f"cooperative_feedforward must be one of {FEEDFORWARDS}, got {feedforward!r}")
    if int(delay_periods) != delay_periods or delay_periods < 0:
        raise ValueError(f"delay_periods must be an integer >= 0, got {delay_periods!r}")
    return int(delay_periods)


def _stable_radius(inertia, k1, k2, period):
    """Spectral radius per axis of law 8 linearised and sampled (:func:`sampled_pd_radius`
    with the gains ``k1/2I``, ``k2/I`` on the angle); arrays of one shape. Raises ValueError
    when an axis is unstable."""
    radius = np.array([
        sampled_pd_radius(k1[ix] / (2.0 * inertia[ix]), k2[ix] / inertia[ix], 0.0, period) for ix in np.ndindex(inertia.shape)
    ]).reshape(inertia.shape)
    worst = float(np.max(radius))
    if not worst < 1.0:
        axis = int(np.argmax(np.ravel(radius)))
        where = f" on axis {axis}" if np.ndim(radius) else ""
        raise ValueError(f"k1, k2 and period_s give an unstable sampled loop (spectral radius {worst:.6g} >= 1{where})")
    return radius


def _axis_model(inertia, k1, k2, period, delay, law):
    """One axis: ``Φ``, ``Γ`` and the rows (over ``[z, w]``) of both accelerations.

    ``law`` is ``"independent"`` or one of :data:`FEEDFORWARDS` (the cooperative follower).
    """
    nz = _N_STATE_FIXED + delay
    ny = nz + len(SOURCES)
    n_r, g_r, d_r, n_f, g_f, d_f = nz + np.arange(len(SOURCES))

    def unit(j):
        row = np.zeros(ny)
        row[j] = 1.0
        return row

    half = 0.5 * k1
    m_th, m_w = unit(_TH_R) + unit(n_r), unit(_W_R) + unit(g_r)
    u_r = -half * m_th - k2 * m_w
    if law == "independent":
        v = np.zeros(ny)
    elif law == "commanded":
        v = half * m_th + k2 * m_w + u_r
    elif law == "actual":
        v = half * m_th + k2 * m_w + u_r + unit(d_r)
    elif law == "estimated":
        v = half * unit(_P_TH) + k2 * unit(_P_W) + inertia * (m_w - unit(_P_W)) / period
    else:  # "none"
        v = half * m_th + k2 * m_w
    received = v if delay == 0 else unit(nz - 1)
    u_f = -half * (unit(_TH_F) + unit(n_f)) - k2 * (unit(_W_F) + unit(g_f)) + received
    acc_r = (u_r + unit(d_r)) / inertia
    acc_f = (u_f + unit(d_f)) / inertia

    rows = np.zeros((nz, ny))
    rows[_TH_R] = unit(_TH_R) + period * unit(_W_R) + 0.5 * period**2 * acc_r
    rows[_W_R] = unit(_W_R) + period * acc_r
    rows[_TH_F] = unit(_TH_F) + period * unit(_W_F) + 0.5 * period**2 * acc_f
    rows[_W_F] = unit(_W_F) + period * acc_f
    rows[_P_TH], rows[_P_W] = m_th, m_w
    if delay:
        rows[_N_STATE_FIXED] = v
        for j in range(1, delay):
            rows[_N_STATE_FIXED + j] = unit(_N_STATE_FIXED + j - 1)
    return rows[:, :nz], rows[:, nz:], acc_r, acc_f


def _axis_stats(inertia, k1, k2, period, sigmas, biases, delay, law):
    """Variances per source of θ_r, θ_f, e (sampled and intersample) and the bias offsets."""
    phi, gam, acc_r, acc_f = _axis_model(inertia, k1, k2, period, delay, law)
    nz = phi.shape[0]
    ny = nz + len(SOURCES)
    sel = {"r": np.zeros(nz), "f": np.zeros(nz)}
    sel["r"][_TH_R], sel["f"][_TH_F] = 1.0, 1.0
    sel["e"] = sel["f"] - sel["r"]

    # Intersample rows of e(t_k + τ) over [z, w] at the Gauss–Legendre nodes on [0, T).
    taus = 0.5 * period * (_GL_NODES + 1.0)
    weights = 0.5 * _GL_WEIGHTS  # mean over the period
    e_rows = []
    for tau in taus:
        row = np.zeros(ny)
        row[_TH_F], row[_TH_R] = 1.0, -1.0
        row[_W_F], row[_W_R] = tau, -tau
        e_rows.append(row + 0.5 * tau**2 * (acc_f - acc_r))

    out = {k: {} for k in ("r", "f", "e", "e_inter")}
    for i, (name, sigma) in enumerate(zip(SOURCES, sigmas)):
        if sigma == 0.0:
            for k in out:
                out[k][name] = 0.0
            continue
        col = gam[:, i] * sigma
        p = solve_discrete_lyapunov(phi, np.outer(col, col))
        p = 0.5 * (p + p.T)
        for k in ("r", "f", "e"):
            out[k][name] = max(float(sel[k] @ p @ sel[k]), 0.0)
        joint = np.zeros((ny, ny))
        joint[:nz, :nz] = p
        joint[nz + i, nz + i] = sigma**2
        out["e_inter"][name] = max(float(sum(w * (r @ joint @ r) for w, r in zip(weights, e_rows))), 0.0)

    bias_in = np.zeros(len(SOURCES))
    bias_in[SOURCES.index("g_r")], bias_in[SOURCES.index("g_f")] = biases
    z_ss = np.linalg.solve(np.eye(nz) - phi, gam @ bias_in)
    out["mean"] = {"r": z_ss[_TH_R], "f": z_ss[_TH_F], "e": z_ss[_TH_F] - z_ss[_TH_R]}
    return out


def _pack(values, shape):
    arr = np.asarray(values, dtype=float).reshape(shape)
    return float(arr) if arr.ndim == 0 else arr


def _broadcast_inputs(inertia_kgm2, k1, k2, biases, sig_r, follower_sigmas):
    """Inputs of :func:`relative_error_covariance` broadcast and checked: ``(inertia, k1, k2,
    reference bias, follower bias, sigmas)``, the sigmas stacked in the order of SOURCES."""
    sig_f = sig_r if follower_sigmas is None else tuple(follower_sigmas)
    if len(sig_f) != 3:
        raise ValueError("follower_sigmas must be (sigma_star_rad, sigma_gyro_rad_s, sigma_torque_nm)")
    args = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (inertia_kgm2, k1, k2, *biases, *sig_r, *sig_f)))
    inertia, g1, g2, b_r, b_f = args[:5]
    sigmas = np.stack(args[5:])  # in the order of SOURCES
    if np.any(inertia <= 0.0) or np.any(g1 <= 0.0) or np.any(g2 <= 0.0):
        raise ValueError("inertia_kgm2, k1 and k2 must be > 0")
    if np.any(sigmas < 0.0):
        raise ValueError("noise standard deviations must be >= 0")
    return inertia, g1, g2, b_r, b_f, sigmas


def _collect_stats(per_law, shape, radius, delay, cooperative_feedforward):
    """The :class:`RelativeErrorStats` of the per-axis results of both laws (flat, C order)."""

    def field(key, part, source=None):
        if source is None:
            return _pack([sum(o[part].values()) for o in per_law[key]], shape)
        return _pack([o[part][source] for o in per_law[key]], shape)

    def contributions(key, part):
        return MappingProxyType({s: field(key, part, s) for s in SOURCES})

    def mean(key, which):
        return _pack([o["mean"][which] for o in per_law[key]], shape)

    return RelativeErrorStats(
        std_reference_rad=np.sqrt(field("independent", "r")),
        std_follower_independent_rad=np.sqrt(field("independent", "f")),
        std_follower_cooperative_rad=np.sqrt(field("cooperative", "f")),
        std_relative_independent_rad=np.sqrt(field("independent", "e")),
        std_relative_cooperative_rad=np.sqrt(field("cooperative", "e")),
        contributions_independent=contributions("independent", "e"),
        contributions_cooperative=contributions("cooperative", "e"),
        std_relative_independent_intersample_rad=np.sqrt(field("independent", "e_inter")),
        std_relative_cooperative_intersample_rad=np.sqrt(field("cooperative", "e_inter")),
        contributions_independent_intersample=contributions("independent", "e_inter"),
        contributions_cooperative_intersample=contributions("cooperative", "e_inter"),
        mean_reference_rad=mean("independent", "r"),
        mean_follower_independent_rad=mean("independent", "f"),
        mean_follower_cooperative_rad=mean("cooperative", "f"),
        mean_relative_independent_rad=mean("independent", "e"),
        mean_relative_cooperative_rad=mean("cooperative", "e"),
        closed_loop_spectral_radius=_pack(radius, shape),
        delay_periods=delay,
        cooperative_feedforward=cooperative_feedforward,
    )


def relative_error_covariance(
    inertia_kgm2,
    k1,
    k2,
    period_s,
    sigma_star_rad,
    sigma_gyro_rad_s,
    sigma_torque_nm,
    delay_periods=0,
    *,
    cooperative_feedforward="commanded",
    gyro_bias_reference_rad_s=0.0,
    gyro_bias_follower_rad_s=0.0,
    follower_sigmas=None,
):
    """Steady-state errors of reference, follower and relative error, law 8 against law 23.

    Parameters
    ----------
    inertia_kgm2 : float or array_like, shape (3,)
        Principal inertia per axis, kg·m².
    k1 : float or array_like
        N·m per unit of ``vec(δq)`` (angle stiffness ``k1/2`` N·m/rad).
    k2 : float or array_like
        N·m·s/rad.
    period_s : float
        Control period T (zero-order hold), s.
    sigma_star_rad, sigma_gyro_rad_s, sigma_torque_nm : float or array_like
        Per-sample standard deviations of the star-tracker angle noise, the gyro rate noise
        and the per-period disturbance torque; independent between the spacecraft, and the
        same on both unless ``follower_sigmas`` says otherwise.
    delay_periods : int
        Link delay D ≥ 0 of the reference's message, in control periods.
    cooperative_feedforward : str
        The cooperative follower's feed-forward: ``"commanded"`` (law 23 as specified),
        ``"actual"``, ``"estimated"`` or ``"none"`` (module notes).
    gyro_bias_reference_rad_s, gyro_bias_follower_rad_s : float or array_like
        Constant gyro biases; only the ``mean_*`` fields depend on them.
    follower_sigmas : tuple of 3 (float or array_like), optional
        The follower's ``(sigma_star_rad, sigma_gyro_rad_s, sigma_torque_nm)`` when they differ
        from the reference's (e.g. all zero to isolate the reference's sources).

    Returns
    -------
    RelativeErrorStats
        Arrays of the broadcast shape of the inputs (floats when all are scalars).

    Raises
    ------
    ValueError
        If the sampled law-8 loop is not strictly stable on some axis, or on bad arguments.

    Notes
    -----
    ``std_reference_rad`` is the same for both laws (the reference flies law 8 either way).
    For ``"commanded"`` every cooperative field equals its independent one (module notes).
    """
    delay = _check_law(cooperative_feedforward, delay_periods)
    period = float(period_s)
    if not period > 0.0:
        raise ValueError(f"period_s must be > 0, got {period_s!r}")
    sig_r = (sigma_star_rad, sigma_gyro_rad_s, sigma_torque_nm)
    biases = (gyro_bias_reference_rad_s, gyro_bias_follower_rad_s)
    inertia, g1, g2, b_r, b_f, sigmas = _broadcast_inputs(inertia_kgm2, k1, k2, biases, sig_r, follower_sigmas)
    radius = _stable_radius(inertia, g1, g2, period)
    per_law = {"independent": [], "cooperative": []}
    for ix in np.ndindex(inertia.shape):
        sig = tuple(float(x) for x in sigmas[(slice(None), *ix)])
        bias = (b_r[ix], b_f[ix])
        for key, law in (("independent", "independent"), ("cooperative", cooperative_feedforward)):
            per_law[key].append(_axis_stats(inertia[ix], g1[ix], g2[ix], period, sig, bias, delay, law))
    return _collect_stats(per_law, inertia.shape, radius, delay, cooperative_feedforward)


def relative_error_transfer(inertia_kgm2, k1, k2, period_s, omega_rad_s, delay_periods=0, *, cooperative_feedforward="commanded"):
    """How much of a deterministic reference tracking error reaches the relative error.

    Definition: the reference's tracking error ``ε(t)`` (e.g. a lag behind its desired attitude,
    a slow ramp or sinusoid) is produced by an extra torque ``w`` acting on the reference that
    its own command does not contain (it enters exactly where ``d_r`` does, so it is part of the
    reference's *actual* acceleration but not of ``u_r``); the follower has no such torque.
    With ``H_ε(z)`` and ``H_e(z)`` the sampled transfers from ``w`` to ``θ_r`` and to
    ``e = θ_f − θ_r``, the gain is ``|H_e / H_ε|`` at ``z = exp(j ω T)``: the amplitude of
    ``e`` per unit amplitude of the reference's own error ``ε`` at frequency ω, independent of
    how large ``w`` is.

    * Independent (law 8): ``e = −ε`` exactly, gain 1 at every ω.
    * Law 23 with ``"commanded"`` feed-forward: identical to law 8, gain 1 (module notes).
    * ``"actual"``: ``|z^−D − 1| = 2 |sin(ω D T / 2)|`` (0 for D = 0; ≈ ω D T when slow).
    * ``"estimated"``: as ``"actual"`` with D + 1.
    * ``"none"``: ``|z^−D T(z) − 1|`` with T(z) the loop's complementary sensitivity;
      ``≈ (ω/ωn)²`` below the bandwidth when D = 0.

    Parameters
    ----------
    inertia_kgm2, k1, k2 : float or array_like
        As :func:`relative_error_covariance`.
    period_s : float
    omega_rad_s : float or array_like
        Frequency, rad/s, ``0 ≤ ω < π/T`` (at Nyquist the ZOH double integrator has a zero).
    delay_periods : int
    cooperative_feedforward : str

    Returns
    -------
    gain_independent, gain_cooperative : float or ndarray
        Broadcast shape of the inputs.
    """
    delay = _check_law(cooperative_feedforward, delay_periods)
    period = float(period_s)
    if not period > 0.0:
        raise ValueError(f"period_s must be > 0, got {period_s!r}")
    inertia, g1, g2, omega = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (inertia_kgm2, k1, k2, omega_rad_s)))
    shape = inertia.shape
    if np.any(omega < 0.0) or np.any(omega * period >= np.pi):
        raise ValueError("omega_rad_s must satisfy 0 <= omega < pi/period_s")
    _stable_radius(inertia, g1, g2, period)  # raises when unstable

    gains = {"independent": [], "cooperative": []}
    w_col = SOURCES.index("d_r")
    for ix in np.ndindex(shape):
        z = np.exp(1j * omega[ix] * period)
        for key, law in (("independent", "independent"), ("cooperative", cooperative_feedforward)):
            phi, gam, _, _ = _axis_model(inertia[ix], g1[ix], g2[ix], period, delay, law)
            x = np.linalg.solve(z * np.eye(phi.shape[0]) - phi, gam[:, w_col])
            gains[key].append(abs((x[_TH_F] - x[_TH_R]) / x[_TH_R]))
    return _pack(gains["independent"], shape), _pack(gains["cooperative"], shape)
