"""Absolute orbit navigation (``[navigation] kind = "orbit-ekf"``): each spacecraft's flight
software estimates its own ECI position and velocity from its GNSS fixes
(:mod:`coopsat.control.orbit_ekf`), and a law that reads ``r_eci`` and ``v_eci`` (the
observation law) reads the estimate. Measurement noise from the ``gnss`` sensor's table (its
whole error), process noise from this table.
"""

from typing import Literal

import numpy as np
from pydantic import Field

from coopsat.plugins import DesignError, Plugin, register
from coopsat.plugins.navigation import FilterTable, filter_noise, sensor_every, sensor_table


class OrbitEkf(FilterTable):
    """``kind = "orbit-ekf"``: each spacecraft estimates its own orbit from its GNSS fixes (EKF;
    the process noise and initial σ per ECI axis)."""

    kind: Literal["orbit-ekf"]
    substeps: int = Field(4, ge=1, le=64, description="RK4 steps per control period of the filter's propagation.")


_DOUBLE_INTEGRATOR = np.block([[np.zeros((3, 3)), np.eye(3)], [np.zeros((3, 3)), np.zeros((3, 3))]])
"""``d/dt [r, v] = [v, a]``: the filter's process noise drives the velocity of a double integrator
per ECI axis (the orbit's own dynamics are left out of Q, as usual over a short period)."""


def _fix_noise(table):
    """Variance of one receiver's whole error per ECI axis (6,): white, own and common."""
    def var(*names):
        return sum(np.square(np.broadcast_to(np.asarray(getattr(table, n), dtype=float), 3)) for n in names)

    r = np.concatenate([var("sigma_m", "own_sigma_m", "common_sigma_m"), var("sigma_m_s", "own_sigma_m_s", "common_sigma_m_s")])
    if np.any(r <= 0.0):
        raise DesignError('navigation: the "gnss" sensor has no noise on an axis, so a fix\'s covariance is not positive definite')
    return r


def _build(table, ctx):
    from coopsat.control.orbit_ekf import OrbitEkf as Part
    from coopsat.design.riccati import sampled_noise
    from coopsat.sim.system import as_arrays

    orbit = ctx.scenario.orbit
    if orbit is None:
        raise DesignError("navigation: orbit-ekf estimates orbits; it needs an [orbit] table")
    masses = [sc.mass_kg if sc.mass_kg is not None else 1.0 for sc in ctx.scenario.spacecraft]
    q, sigma0 = filter_noise(table)
    from coopsat.astro.constants import J2_EARTH, R_EARTH_M

    x0 = np.concatenate([ctx.r_eci_m, ctx.v_eci_m_s], axis=1).T
    arrays = (sampled_noise(_DOUBLE_INTEGRATOR, np.diag(np.concatenate([np.zeros(3), q])), ctx.period_s), x0, sigma0, _fix_noise(sensor_table(ctx, "gnss")), np.asarray(masses, dtype=float),
              orbit.mu_m3_s2, J2_EARTH, R_EARTH_M, ctx.period_s)
    return Part(*as_arrays(arrays), substeps=table.substeps, gnss_every=sensor_every(ctx, "gnss"),
                draw_initial=table.draw_initial_error)


register(Plugin("navigation", "orbit-ekf", OrbitEkf, _build, analysis="coopsat.analysis.papers.navigation"))
