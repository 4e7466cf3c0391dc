"""Relative-position consensus in low orbit (``lvlh-consensus``) as a controller plug-in.

The law is :mod:`coopsat.control.lvlh_consensus`. Design-time check: per axis, with the
orbital (Clohessy–Wiltshire) terms neglected against ``k_p/m``, the formation is
``M ρ̈ = −k_p L ρ − k_d L ρ̇`` with L the graph's Laplacian; each nonzero eigenvalue μ of
``M⁻¹ L`` is one sampled PD loop (:func:`coopsat.design.sampled_data.sampled_pd_radius` with the
gains ``μ k_p``, ``μ k_d``), and the worst spectral radius over every graph of the run is
reported. The zero eigenvalue is the formation's common motion, which no relative law holds;
more than one zero eigenvalue means groups that never hear each other and drift apart.

One gain pair serves every mode, so the spread of the modes matters: the slowest mode's damping
ratio ``ζ = k_d |μ| / (2 √(k_p |μ|))`` is reported beside the radius. A ring of 100 has
``λ_max/λ_2 ≈ 1000``: gains that keep its fastest mode stable leave the slowest one ringing
(ζ ≈ 0.02 at k_p = 5e-3 N/m, k_d = 0.1 N·s/m), where a complete graph has every mode at λ = n.
"""

from typing import Literal

import numpy as np
from pydantic import Field

from coopsat.plugins import DesignCheck, DesignError, Plugin, register
from coopsat.plugins.tables import MAX_GAIN, MAX_TIME_S, Table, Vec3

ANALYSIS = "coopsat.analysis.papers.station_keeping"


class LvlhConsensusTable(Table):
    """``kind = "lvlh-consensus"``: each spacecraft keeps its slot relative to the ones it hears."""

    kind: Literal["lvlh-consensus"]
    period_s: float = Field(gt=0, le=1e5, description="Control period (zero-order hold), s.")
    k_p: float = Field(gt=0, le=MAX_GAIN, description="Position gain per unit of link weight, N/m.")
    k_d: float = Field(ge=0, le=MAX_GAIN, description="Velocity gain per unit of link weight, N·s/m.")
    slot_lvlh_m: list[Vec3] = Field(
        description="Each spacecraft's slot [x, y, z], m, in the LVLH frame of the first spacecraft at t = 0 "
        "(only differences matter), one per spacecraft."
    )
    start_s: float = Field(0.0, ge=0, le=MAX_TIME_S, description="The law commands nothing before this time, s.")


def _build(table, ctx):
    from coopsat.control.lvlh_consensus import LvlhConsensus, slot_frame_turns
    from coopsat.sim.system import as_arrays

    if ctx.scenario.orbit is None:
        raise DesignError("controller: lvlh-consensus needs an [orbit] table (it measures r_eci and v_eci)")
    if not any(g.n_links for g in ctx.graphs):
        raise DesignError("controller: lvlh-consensus keeps slots relative to the spacecraft heard; give a [network] graph")
    slots = np.asarray(table.slot_lvlh_m, dtype=float)
    if slots.shape[0] != ctx.n:
        raise DesignError(f"controller.slot_lvlh_m: {slots.shape[0]} slots for {ctx.n} spacecraft (one per spacecraft)")
    turn = slot_frame_turns(ctx.r_eci_m[0], ctx.v_eci_m_s[0], slots)
    return LvlhConsensus(*as_arrays((table.k_p, table.k_d, slots.T, np.moveaxis(turn, 0, -1), table.start_s)))


def laplacian_modes(adjacency, masses_kg):
    """Eigenvalues μ of ``M⁻¹ L`` (1/kg), L = diag(A 1) − A, sorted by modulus.

    Parameters
    ----------
    adjacency : (n, n)
        ``A[i, j]``: the weight with which i hears j.
    masses_kg : (n,)
    """
    from coopsat.network.topology import laplacian

    mu = np.linalg.eigvals(laplacian(adjacency) / np.asarray(masses_kg, dtype=float)[:, None])
    return mu[np.argsort(np.abs(mu))]


def check_consensus(table, ctx):
    """The worst sampled-data spectral radius over the nonzero Laplacian modes of every graph."""
    masses = [sc.mass_kg for sc in ctx.scenario.spacecraft]
    if any(m is None for m in masses) or ctx.n < 2:
        return None  # a missing mass is the build's message
    from coopsat.design.sampled_data import sampled_pd_radius

    worst, where, groups, zeta = 0.0, ctx.graph_places[0], 1, np.inf
    for place, adjacency in zip(ctx.graph_places, ctx.adjacencies):
        mu = laplacian_modes(adjacency, masses)
        free = np.abs(mu) <= 1e-9 * max(np.abs(mu).max(), 1e-300)
        groups = max(groups, int(free.sum()))
        if np.any(~free):
            slowest = np.abs(mu[~free][0])
            zeta = min(zeta, table.k_d * slowest / (2.0 * np.sqrt(table.k_p * slowest)))
        for m in mu[~free]:
            radius = sampled_pd_radius(table.k_p * m, table.k_d * m, 0.0, table.period_s)
            if radius > worst:
                worst, where = radius, place
    stable = worst < 1.0 and groups == 1
    split = "" if groups == 1 else f"; the graph falls into {groups} groups that do not hear each other and drift apart"
    note = (
        f"relative-position consensus sampled-data loop {'stable' if worst < 1.0 else 'UNSTABLE'} at T = "
        f"{table.period_s:g} s: spectral radius {worst:.4f} over the nonzero Laplacian modes (worst in {where}), "
        f"slowest mode damping ratio {zeta:.3g} (Clohessy–Wiltshire terms neglected){split}"
    )
    metrics = {"lvlh_consensus_spectral_radius": worst, "lvlh_consensus_slowest_damping": float(zeta)}
    return DesignCheck("lvlh-consensus", stable, note, metrics)


register(Plugin("controller", "lvlh-consensus", LvlhConsensusTable, _build, (check_consensus,), analysis=ANALYSIS))
