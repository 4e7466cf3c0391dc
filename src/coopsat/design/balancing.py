"""Balanced units for the formation's Riccati-type LMIs (SPEC §4).

The physical problem mixes 10¹ m, 10⁻² m/s, 10⁻¹ N, B = 1/700 and time constants of
10²–10³ s. Every LMI of :mod:`coopsat.design.formation_synthesis` is solved in balanced units:
states and inputs scaled by the square roots of the weights' diagonals (Bryson's x_max,
u_max), then by the symplectic diagonal scaling that balances the Hamiltonian matrix; time by
1/√(‖Â‖‖B̂‖) (the bandwidth of a unit-weight double integrator) and cost by the same factor;
the answer is mapped back. The scaling is a congruence of the LMI, so the set of solutions is
the same; only the solver's view of it changes.
"""

import math

import numpy as np
from scipy.linalg import matrix_balance


def _weight_scales(diagonal):
    """1/√w for each positive weight; the geometric mean of those for zero weights."""
    diagonal = np.asarray(diagonal, dtype=float)
    positive = diagonal > 0.0
    if not positive.any():
        return np.ones_like(diagonal)
    scales = np.empty_like(diagonal)
    scales[positive] = 1.0 / np.sqrt(diagonal[positive])
    scales[~positive] = math.exp(np.mean(np.log(scales[positive])))
    return scales


def _time_scale(a, b, s, s_u):
    """τ = 1/√(‖S⁻¹AS‖‖S⁻¹BS_u‖) (s): Ã = τ S⁻¹AS and B̃ = τ S⁻¹BS_u both of order one."""
    norm_a = np.linalg.norm(a * (s[None, :] / s[:, None]), 2)
    norm_b = np.linalg.norm(b * (s_u[None, :] / s[:, None]), 2)
    if norm_a > 0.0 and norm_b > 0.0:
        return 1.0 / math.sqrt(norm_a * norm_b)
    return 1.0 / max(norm_a, norm_b, np.finfo(float).tiny)


def balanced_scales(a, b, q, r):
    """State scales s, input scales s_u and time scale τ (s): x = S x̃, u = S_u ũ, t = τ t̃.

    First states and inputs in units of Bryson's x_max and u_max (1/√ of the weights'
    diagonals) and τ from :func:`_time_scale` (the bandwidth of a unit-weight double
    integrator); then a symplectic diagonal scaling diag(D, D⁻¹) of the Hamiltonian matrix
    [[Ã, −B̃ r̃⁻¹ B̃ᵀ], [−q̃, −Ãᵀ]], D = √(d_x/d_λ) from its diagonal balancing (as scipy's
    Riccati solver does), which also covers weights whose diagonal says little about the
    dynamics (an observer's noise intensities), and τ again.
    """
    n = a.shape[0]
    s, s_u = _weight_scales(np.diag(q)), _weight_scales(np.diag(r))
    tau = _time_scale(a, b, s, s_u)
    a_t = tau * a * (s[None, :] / s[:, None])
    b_t = tau * b * (s_u[None, :] / s[:, None])
    r_t = r * np.outer(s_u, s_u)
    ham = np.block([[a_t, -b_t @ np.linalg.solve(r_t, b_t.T)], [-q * np.outer(s, s), -a_t.T]])
    _, (scale, _) = matrix_balance(ham, permute=False, separate=True)
    s = s * np.sqrt(scale[:n] / scale[n:])
    return s, s_u, _time_scale(a, b, s, s_u)
