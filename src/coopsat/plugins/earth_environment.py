"""The Earth-orbit environment (SPEC §5): aerodynamic, solar-pressure and residual-dipole
torques (``[[disturbances]]``) and magnetorquers (``[[actuators]]``).

The surface that the air and the light push on is a list of flat facets, the same on every
spacecraft; the Sun, the air and the field depend on ``[orbit] epoch_utc`` and on the Earth
being the central body.
"""

import functools
from typing import Annotated, Literal, NamedTuple

from pydantic import Field

from coopsat.astro.constants import AU_M, MU_EARTH_M3_S2, SOLAR_PRESSURE_1AU_N_M2
from coopsat.plugins import DesignError, Plugin, register
from coopsat.plugins.tables import Bounded3, Facets, Table

Fraction = Annotated[float, Field(ge=0, le=1)]


class AerodynamicTorqueTable(Facets):
    """``kind = "aerodynamic-torque"``: free-molecular drag on the facets in an exponential
    atmosphere that turns with the Earth."""

    kind: Literal["aerodynamic-torque"]
    cd: float = Field(2.2, gt=0, le=10, description="Drag coefficient of every facet (2.2: flat plate, free molecular flow).")


class SolarPressureTorqueTable(Facets):
    """``kind = "solar-pressure-torque"``: radiation pressure on the facets, none in the Earth's shadow."""

    kind: Literal["solar-pressure-torque"]
    specular: Fraction | list[Fraction] = Field(0.1, description="Fraction of light reflected specularly: one value, or one per facet.")
    diffuse: Fraction | list[Fraction] = Field(0.2, description="Fraction reflected diffusely: one value, or one per facet.")
    pressure_1au_n_m2: float = Field(
        SOLAR_PRESSURE_1AU_N_M2, gt=0, le=1.0, description="Pressure on an absorber at 1 AU, N/m² (default 4.54e-6)."
    )


class ResidualDipoleTable(Table):
    """``kind = "residual-dipole"``: a constant magnetic dipole of the spacecraft, ``L = m × B``."""

    kind: Literal["residual-dipole"]
    dipole_am2: Bounded3(1e4, "A·m²") = Field(description="Residual dipole, body axes, A·m² (every spacecraft).")


class MagnetorquersTable(Table):
    """``kind = "magnetorquers"``: three coils on the body axes, ``L = m × B``."""

    kind: Literal["magnetorquers"]
    dipole_max_am2: float = Field(gt=0, le=1e4, description="Largest dipole of each coil, A·m².")
    command: str = Field("dipole_b", description="Controller command executed (the dipole wanted, A·m², body axes).")


def require_earth_orbit(ctx, where):
    """The scenario's ``[orbit]`` has the Earth as central body; else a DesignError naming ``where``."""
    orbit = ctx.scenario.orbit
    if orbit is None:
        raise DesignError(f"{where} needs an [orbit] table (it depends on the position about the Earth)")
    if abs(orbit.mu_m3_s2 / MU_EARTH_M3_S2 - 1.0) > 0.01:
        raise DesignError(
            f"{where} models the Earth's environment; [orbit] mu_m3_s2 = {orbit.mu_m3_s2:.6g} is not the Earth's "
            f"({MU_EARTH_M3_S2:.6g})"
        )
    if ctx.scenario.sim.attitude != "rigid-body":
        raise DesignError(f'{where} acts on the attitude; it needs sim.attitude = "rigid-body"')


class RunClock(NamedTuple):
    """When a run flies and how the Earth turns meanwhile (design time).

    Attributes
    ----------
    epoch : coopsat.astro.timescales.RunEpoch
    oriented : coopsat.astro.earth_orientation.Oriented
        The Earth's orientation table over the run (NumPy) and where it came from.
    """

    epoch: object
    oriented: object

    @property
    def jd_tt(self):
        """Julian date (TT) of t = 0, one float (for the ephemerides)."""
        return self.epoch.jd_tt

    @property
    def earth(self):
        """The orientation table (NumPy arrays; ``as_arrays`` makes them a part's)."""
        return self.oriented.table


@functools.lru_cache(maxsize=32)
def _epoch(iso, scale):
    from coopsat.astro.timescales import TimeScaleError, run_epoch

    try:
        return run_epoch(iso, scale)
    except TimeScaleError as err:
        raise DesignError(f"orbit.epoch_{scale}: {err}") from None


def run_epoch_of(orbit):
    """The :class:`~coopsat.astro.timescales.RunEpoch` of an ``[orbit]`` table (a DesignError
    naming the field for an epoch that cannot be placed on TT)."""
    return _epoch(*orbit.epoch)


@functools.lru_cache(maxsize=32)
def _clock(iso, scale, model, span_s):
    from coopsat.astro.earth_orientation import EARTH_ORIENTATION_MODELS

    when = _epoch(iso, scale)
    return RunClock(when, EARTH_ORIENTATION_MODELS[model](when, span_s))


def run_clock(orbit, t_final_s):
    """The :class:`RunClock` of an ``[orbit]`` table over a run of ``t_final_s`` (at least a day,
    so that the design checks that look ahead — the target's first rise — stay inside it)."""
    return _clock(*orbit.epoch, orbit.earth_orientation, float(max(t_final_s, 86400.0)))


def epoch(ctx):
    """The run's :class:`RunClock` (``[orbit]``'s epoch and Earth orientation)."""
    return run_clock(ctx.scenario.orbit, ctx.scenario.sim.t_final_s)


def _per_facet(value, count, field):
    import numpy as np

    v = np.asarray(value, dtype=float)
    if v.ndim == 1 and v.shape[0] != count:
        raise DesignError(f"disturbances.{field}: {v.shape[0]} values given for {count} facets (give one, or one each)")
    return np.broadcast_to(v, (count,)).copy()


def facet_arrays(table):
    """normals (3, F) unit, areas (F,), centres (3, F)."""
    import numpy as np

    f = np.asarray(table.facets, dtype=float)
    scaled = f[:, :3] / np.abs(f[:, :3]).max(axis=1, keepdims=True)  # no square overflows (1e308) or underflows
    normals = scaled / np.linalg.norm(scaled, axis=1, keepdims=True)
    return normals.T, f[:, 3], f[:, 4:].T


def _build_aero(table, ctx):
    from coopsat.environment.earth_torques import AerodynamicTorque
    from coopsat.sim.system import as_arrays

    require_earth_orbit(ctx, "disturbances: aerodynamic-torque")
    return AerodynamicTorque(*as_arrays((*facet_arrays(table), table.cd)))


def facet_optics(table, kind):
    """specular, diffuse (F,) of a table with ``facets``, ``specular`` and ``diffuse`` (one
    value each, or one per facet); a DesignError naming ``kind`` where a facet would reflect
    more than all its light."""
    count = len(table.facets)
    specular = _per_facet(table.specular, count, "specular")
    diffuse = _per_facet(table.diffuse, count, "diffuse")
    if (specular + diffuse > 1.0).any():
        k = int((specular + diffuse > 1.0).argmax())
        raise DesignError(f"disturbances: {kind} facet {k} reflects more than all its light (specular + diffuse > 1)")
    return specular, diffuse


def _build_srp(table, ctx):
    from coopsat.environment.earth_torques import SolarPressureTorque
    from coopsat.sim.system import as_arrays

    require_earth_orbit(ctx, "disturbances: solar-pressure-torque")
    normals, areas, centres = facet_arrays(table)
    specular, diffuse = facet_optics(table, "solar-pressure-torque")
    arrays = (normals, areas, centres, specular, diffuse, table.pressure_1au_n_m2, AU_M, epoch(ctx).jd_tt)
    return SolarPressureTorque(*as_arrays(arrays))


def _build_dipole(table, ctx):
    import numpy as np

    from coopsat.environment.earth_torques import ResidualDipoleTorque
    from coopsat.sim.system import as_arrays

    require_earth_orbit(ctx, "disturbances: residual-dipole")
    return ResidualDipoleTorque(*as_arrays((np.asarray(table.dipole_am2, dtype=float).reshape(3, 1), epoch(ctx).earth)))


def _build_magnetorquers(table, ctx):
    from coopsat.actuators.magnetorquers import Magnetorquers
    from coopsat.sim.system import as_arrays

    require_earth_orbit(ctx, "actuators: magnetorquers")
    return Magnetorquers(*as_arrays((table.dipole_max_am2, epoch(ctx).earth)), command=table.command)


register(Plugin("disturbance", "aerodynamic-torque", AerodynamicTorqueTable, _build_aero))
register(Plugin("disturbance", "solar-pressure-torque", SolarPressureTorqueTable, _build_srp))
register(Plugin("disturbance", "residual-dipole", ResidualDipoleTable, _build_dipole))
register(Plugin("actuator", "magnetorquers", MagnetorquersTable, _build_magnetorquers))


def time_attributes(scenario, system):
    """What a run's clock and frames are, for ``result.nc``'s global attributes (str values).

    ``time_scale`` always; with an ``[orbit]``, the epoch on TT and UTC and the inertial frame;
    when a part of ``system`` turns with the Earth (it carries an
    :class:`~coopsat.astro.earth_orientation.EarthOrientation`), the orientation model and where
    UT1 − UTC and the pole came from.
    """
    import jax

    from coopsat.astro.earth_orientation import INERTIAL_FRAMES, EarthOrientation

    if scenario.orbit is None:
        return {"time_scale": "elapsed seconds (no [orbit]: the run has no date)"}
    when = run_epoch_of(scenario.orbit)
    iso, scale = scenario.orbit.epoch
    attrs = {
        "time_scale": "TT (time is SI seconds of Terrestrial Time since epoch_tt)",
        "epoch_tt": when.tt_iso,
        "epoch_utc": when.utc_iso or "beyond the leap-second table",
        "epoch_given": f"{iso} ({scale.upper()})",
        "inertial_frame": INERTIAL_FRAMES[scenario.orbit.earth_orientation],
        "earth_orientation": scenario.orbit.earth_orientation,
    }
    turns = jax.tree_util.tree_leaves(system, is_leaf=lambda x: isinstance(x, EarthOrientation))
    if any(isinstance(leaf, EarthOrientation) for leaf in turns):
        attrs["earth_orientation_parameters"] = run_clock(scenario.orbit, scenario.sim.t_final_s).oriented.eop_source
    return attrs
