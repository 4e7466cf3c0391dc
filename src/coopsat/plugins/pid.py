"""Feedback controllers with state: attitude PID (``attitude-pid``) and LVLH station keeping
(``lvlh-pd``).

Design-time check of each: the loop linearised about its set point and sampled with the
command held over the control period (zero-order hold); the spectral radius of the one-period
map is reported (< 1: stable). The attitude loop is linearised about rest at the target (no
stored wheel momentum; the gains are scalars, so it splits along the principal axes); the
relative-motion loop neglects the orbital (Clohessy–Wiltshire) terms, which are of order n²
against ``k_p/m``.
"""

from typing import Literal

import numpy as np
from pydantic import Field

from coopsat.plugins import DesignCheck, DesignError, Plugin, register
from coopsat.plugins.tables import MAX_GAIN, MAX_TIME_S, Quat, Table, Vec3


class AttitudePid(Table):
    """``kind = "attitude-pid"``: hold a constant attitude with a PID on the error quaternion."""

    kind: Literal["attitude-pid"]
    period_s: float = Field(gt=0, le=1e5, description="Control period (zero-order hold), s.")
    k_p: float = Field(ge=0, le=MAX_GAIN, description="Proportional gain K_p, N·m (per unit of quaternion vector part).")
    k_d: float = Field(ge=0, le=MAX_GAIN, description="Rate gain K_d, N·m·s/rad.")
    k_i: float = Field(0.0, ge=0, le=MAX_GAIN, description="Integral gain K_i, N·m/s.")
    q_target: Quat = Field([1.0, 0.0, 0.0, 0.0], description="Target attitude, body relative to inertial, scalar first.")
    integral_max: float | None = Field(
        None, gt=0, description="Anti-windup: clamp on each component of ∫ vec(q_t*⊗q) dt, s (default none)."
    )


class LvlhPd(Table):
    """``kind = "lvlh-pd"``: every deputy holds an offset from the chief in the chief's LVLH frame."""

    kind: Literal["lvlh-pd"]
    period_s: float = Field(gt=0, le=1e5, description="Control period (zero-order hold), s.")
    k_p: float = Field(gt=0, le=MAX_GAIN, description="Position gain, N/m.")
    k_d: float = Field(ge=0, le=MAX_GAIN, description="Velocity gain, N·s/m.")
    rho_target_lvlh_m: Vec3 | list[Vec3] = Field(
        description="Offset from the chief to hold, LVLH, m: one [x, y, z] for every deputy, or one per spacecraft."
    )
    start_s: float = Field(0.0, ge=0, le=MAX_TIME_S, description="The law commands nothing before this time, s.")


def _build_attitude(table, ctx):
    from coopsat.control.pid import AttitudePid as Part
    from coopsat.sim.system import as_arrays

    if ctx.scenario.sim.attitude != "rigid-body":
        raise DesignError('controller: attitude-pid acts on quaternions; it needs sim.attitude = "rigid-body"')
    q = np.asarray(table.q_target, dtype=float)
    i_max = np.inf if table.integral_max is None else table.integral_max
    return Part(*as_arrays((table.k_p, table.k_d, table.k_i, q / np.linalg.norm(q), table.period_s, i_max)))


def rho_targets(table, n):
    """The offsets as a (3, n) array (the chief's column zero).

    Raises
    ------
    DesignError
        A per-spacecraft list of the wrong length, or a non-zero offset for the chief.
    """
    from coopsat.control.pid import CHIEF

    rho = np.asarray(table.rho_target_lvlh_m, dtype=float)
    if rho.ndim == 1:
        rho = np.repeat(rho[None], n, axis=0)
        rho[CHIEF] = 0.0
    elif rho.shape[0] != n:
        raise DesignError(
            f"controller.rho_target_lvlh_m: {rho.shape[0]} offsets for {n} spacecraft (give one [x, y, z], or one per spacecraft)"
        )
    elif np.any(rho[CHIEF] != 0.0):
        raise DesignError(
            f"controller.rho_target_lvlh_m: the chief (spacecraft {CHIEF + 1}) is the origin of LVLH; its offset must be "
            f"[0, 0, 0], got {rho[CHIEF].tolist()}"
        )
    return rho.T


def _build_lvlh(table, ctx):
    from coopsat.control.pid import LvlhPd as Part
    from coopsat.sim.system import as_arrays

    if ctx.scenario.orbit is None:
        raise DesignError("controller: lvlh-pd needs an [orbit] table (it measures r_eci and v_eci)")
    return Part(*as_arrays((table.k_p, table.k_d, rho_targets(table, ctx.n), table.start_s)))


def _verdict(name, radius, what, period_s, detail):
    stable = radius < 1.0
    return DesignCheck(
        name, stable,
        f"{what} sampled-data loop {'stable' if stable else 'UNSTABLE'} at T = {period_s:g} s: spectral radius "
        f"{radius:.4f} ({detail})",
        {f"{name.replace('-', '_')}_spectral_radius": radius},
    )


def check_attitude(table, ctx):
    """Linearised about rest at the target: per principal moment J, ``J θ̈ = u`` with
    ``vec(q_t*⊗q) ≈ θ/2``, so the gains on θ are ``K_p/2``, ``K_d``, ``K_i/2``."""
    from coopsat.design.sampled_data import sampled_pd_radius

    moments = np.concatenate([np.linalg.eigvalsh(i) for i in ctx.inertia_kgm2])
    radii = [sampled_pd_radius(table.k_p / (2 * j), table.k_d / j, table.k_i / (2 * j), table.period_s) for j in moments]
    worst = int(np.argmax(radii))
    return _verdict(
        "attitude-pid", radii[worst], "attitude PID", table.period_s,
        f"worst on the principal moment {moments[worst]:.4g} kg·m² of {ctx.names[worst // 3]}",
    )


def check_lvlh(table, ctx):
    """Per deputy of mass m and LVLH axis, ``m ρ̈ = f`` (orbital terms neglected)."""
    masses = [sc.mass_kg for sc in ctx.scenario.spacecraft[1:]]
    if not masses or any(m is None for m in masses):
        return None  # one spacecraft, or a missing mass (the build reports it)
    from coopsat.design.sampled_data import sampled_pd_radius

    radii = [sampled_pd_radius(table.k_p / m, table.k_d / m, 0.0, table.period_s) for m in masses]
    worst = int(np.argmax(radii))
    return _verdict(
        "lvlh-pd", radii[worst], "LVLH PD", table.period_s,
        f"worst for {ctx.names[worst + 1]}, {masses[worst]:g} kg; Clohessy–Wiltshire terms neglected",
    )


register(Plugin("controller", "attitude-pid", AttitudePid, _build_attitude, (check_attitude,)))
register(Plugin("controller", "lvlh-pd", LvlhPd, _build_lvlh, (check_lvlh,), analysis="coopsat.analysis.papers.station_keeping"))
