"""Hand-written references shared by the Earth-environment tests: the tilted dipole written
out, inertial vectors in body axes by SciPy, and random attitudes (independent of coopsat's
own quaternion and field code)."""

import numpy as np
from scipy.spatial.transform import Rotation

from coopsat.astro.magnetic import IGRF2020_DIPOLE_T, IGRF_RADIUS_M


def hand_dipole_eci(r_eci, theta):
    """Tilted dipole B = a³ (3 (g·r̂) r̂ − g)/r³ in ECEF, ECEF = R3(θ) ECI, written out here."""
    c, s = np.cos(theta), np.sin(theta)
    to_ecef = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    r = to_ecef @ r_eci
    g = np.asarray(IGRF2020_DIPOLE_T)
    rn = np.linalg.norm(r)
    rh = r / rn
    return to_ecef.T @ ((IGRF_RADIUS_M / rn) ** 3 * (3.0 * (g @ rh) * rh - g))


def to_body(q, v_i):
    """Body components of an inertial vector: v_b = C_biᵀ v_i (SciPy, scalar first)."""
    return Rotation.from_quat(q, scalar_first=True).inv().apply(v_i)


def random_quats(n, seed):
    """n random unit quaternions (n, 4)."""
    q = np.random.default_rng(seed).normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)
