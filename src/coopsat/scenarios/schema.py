"""Scenario file schema: pydantic models with ``extra="forbid"``.

The core tables (``[sim]``, ``[[spacecraft]]``, ``[orbit]``, ``[network]``, ``[analysis]``,
``[[published]]``) are defined here; the tables of controllers, actuators, sensors, network
models and disturbances belong to their plug-ins (:mod:`coopsat.plugins`) and are composed
into :class:`Scenario` from the registry, each selected by its ``kind``.

Every field is SI; only fields whose name ends in ``_deg`` are in degrees (converted when the
scenario is built). docs/scenarios.md documents each field; keep the two in step.
"""

import math
from typing import Annotated, Literal, Union

import numpy as np
from pydantic import AfterValidator, Field, field_validator, model_validator

from coopsat.astro.constants import J2_EARTH, MU_EARTH_M3_S2, R_EARTH_M
from coopsat.network.graphs import GRAPH_KINDS
from coopsat.plugins import plugins
from coopsat.plugins.tables import (
    MAX_DISTANCE_M,
    MAX_GAIN,
    MAX_RATE_RAD_S,
    MAX_SPEED_M_S,
    MAX_TIME_S,
    Bounded3,
    Quat,
    Record,
    Table,
    Vec3,
    whole_ratio,
)

MAX_TICKS = 1e10
"""Longest run in base ticks (about 10 hours of compute at the engine's speed for N = 5)."""

MAX_SAMPLES = 1e7
"""Most spacecraft-samples a run may record (about 250 bytes each with PWM: 2.5 GB)."""

def _whole_multiple(a, b, name_a, name_b):
    if whole_ratio(a, b) is None:
        raise ValueError(f"{name_a} ({a:g} s) must be a whole multiple of {name_b} ({b:g} s)")


NAME_PATTERN = r"^[A-Za-z0-9_.\-]{1,64}$"
"""Scenario and spacecraft names: they become file, folder and metric names."""


MAX_INERTIA_KGM2 = 1e9
MIN_INERTIA_KGM2 = 1e-9
"""Range of a principal moment of inertia, kg·m² (a 1 g, 1 mm body is about 1e-10... a space
station about 1e8)."""


def _check_inertia(inertia):
    """A physical inertia: [Ixx, Iyy, Izz] or symmetric 3×3, positive definite, triangle inequality.

    Principal moments given as three floats are checked in plain Python (they are their own
    eigenvalues; NumPy's per-call cost was most of a big formation's validation)."""
    if len(inertia) == 3 and all(isinstance(v, float) for v in inertia):
        _check_entries(inertia)
        _check_moments(sorted(inertia))
        return inertia
    try:
        m = np.diag(inertia) if np.ndim(inertia) == 1 else np.asarray(inertia, dtype=float)
    except ValueError:  # ragged nested lists
        raise ValueError("must be [Ixx, Iyy, Izz] or a 3×3 matrix, kg·m²") from None
    if m.shape != (3, 3):
        raise ValueError("must be [Ixx, Iyy, Izz] or a 3×3 matrix, kg·m²")
    _check_entries(m.ravel().tolist())
    if not np.allclose(m, m.T, rtol=1e-12, atol=0.0):
        raise ValueError("must be symmetric, kg·m²")
    _check_moments(np.linalg.eigvalsh(m).tolist())
    return inertia


def _check_entries(entries):
    if not all(math.isfinite(v) for v in entries) or max(abs(v) for v in entries) > MAX_INERTIA_KGM2:
        raise ValueError(f"entries must be finite and at most {MAX_INERTIA_KGM2:g} kg·m² (the ISS is about 1e8)")


def _check_moments(eig):
    """Principal moments, ascending: positive, not below :data:`MIN_INERTIA_KGM2`, triangle inequality."""
    if eig[0] <= 0.0:
        raise ValueError(f"must be positive definite (principal moments {np.round(eig, 6).tolist()} kg·m²)")
    if eig[0] < MIN_INERTIA_KGM2:
        raise ValueError(f"smallest principal moment {eig[0]:.3g} kg·m² is below {MIN_INERTIA_KGM2:g} kg·m²")
    if eig[0] + eig[1] < eig[2] * (1.0 - 1e-9):
        raise ValueError(
            f"principal moments {np.round(eig, 6).tolist()} kg·m² break the triangle inequality "
            "(I1 + I2 >= I3): no rigid body has them"
        )


Inertia = Annotated[list[float] | list[list[float]], AfterValidator(_check_inertia)]
"""[Ixx, Iyy, Izz] or a symmetric 3×3, kg·m², physically possible."""


def _union(role):
    """The scenario type of one role: the registered tables, told apart by ``kind``."""
    tables = tuple(p.table for p in plugins(role).values())
    if not tables:
        def _none_registered(v):
            raise ValueError(f"no {role} kinds are installed")

        return Annotated[dict, AfterValidator(_none_registered)]
    if len(tables) == 1:
        return tables[0]
    return Annotated[Union[tables], Field(discriminator="kind")]


Controller = _union("controller")
Actuator = _union("actuator")
Delivery = _union("network")
Sensor = _union("sensor")
Disturbance = _union("disturbance")
Navigation = _union("navigation")


class Sim(Table):
    """``[sim]``: time base of the run."""

    t_final_s: float = Field(gt=0, le=MAX_TIME_S, description="Run length, s.")
    dt_s: float = Field(ge=1e-9, le=1e5, description="Base tick, s: integration step and time quantum.")
    substeps: int = Field(1, ge=1, le=64, description="RK4 steps per tick (per switch-free segment).")
    attitude: Literal["rigid-body", "small-angle"] = Field(
        "rigid-body",
        description="Attitude model: the full rigid body (quaternion, Euler's equation), or small angles "
        "about rest (θ̇ = ω, I ω̇ = τ per axis; SPEC §3).",
    )
    record_interval_s: float | None = Field(
        None, gt=0, le=MAX_TIME_S, description="Time between recorded samples, s; default one control period."
    )


class Elements(Table):
    """Classical orbital elements of one spacecraft (``[spacecraft.elements]``)."""

    a_m: float = Field(gt=0, le=MAX_DISTANCE_M)
    e: float = Field(0.0, ge=0, lt=1)
    i_deg: float = 0.0
    raan_deg: float = 0.0
    argp_deg: float = 0.0
    mean_anomaly_deg: float = 0.0


class Relative(Table):
    """``[spacecraft.relative]``: the initial state given relative to another spacecraft, in its LVLH frame."""

    to: str = Field(description="The reference spacecraft (its own state given by r_eci_m/v_eci_m_s or elements).")
    rho_lvlh_m: Bounded3(MAX_DISTANCE_M, "m") = Field(description="Position relative to it, its LVLH axes, m.")
    rho_dot_lvlh_m_s: Bounded3(MAX_SPEED_M_S, "m/s") = Field(
        [0.0, 0.0, 0.0], description="Velocity relative to it as seen in its rotating LVLH frame, m/s."
    )


class Tle(Table):
    """``[spacecraft.tle]``: the initial state from a two-line element set (SGP4 at the run's
    epoch, TEME turned into the inertial frame; docs/time-and-frames.md)."""

    line1: str = Field(description="Line 1, 69 columns as published (checksum in column 69).")
    line2: str = Field(description="Line 2, 69 columns.")
    source: str = Field("", description="Where the set comes from (catalogue, date fetched): kept with the run.")


class OemState(Table):
    """``[spacecraft.oem]``: the initial state read from a CCSDS OEM file (as ``coopsat export``
    writes), interpolated to the run's epoch."""

    file: str = Field(description="The OEM file (KVN); a relative path is relative to the scenario file's folder.")
    object: str | None = Field(None, description="OBJECT_NAME of the segment to read (default: the file's only object).")


class Roe(Table):
    """``[spacecraft.roe]``: the initial state as quasi-nonsingular relative orbital elements
    about another spacecraft (osculating; coopsat.astro.roe)."""

    to: str = Field(description="The chief (its own state given absolutely: r_eci_m/v_eci_m_s, elements, tle or oem).")
    a_droe_m: Record(float, float, float, float, float, float) = Field(
        description="[a δa, a δλ, a δex, a δey, a δix, a δiy], m: the ROE times the chief's semi-major axis."
    )


class SpacecraftDefaults(Table):
    """``[spacecraft_defaults]``: fields every ``[[spacecraft]]`` inherits unless it sets them."""

    inertia_kgm2: Inertia | None = None
    q_bi: Quat | None = None
    omega_b_rad_s: Vec3 | None = None
    h_wheels_b_nms: Vec3 | None = None
    mass_kg: float | None = Field(None, gt=0, le=1e7)
    angle_rad: Vec3 | None = None


class Spacecraft(Table):
    """One ``[[spacecraft]]`` entry (after defaults are merged)."""

    name: str | None = Field(
        None, pattern=NAME_PATTERN, description="Unique name (letters, digits, _ . -); default sat1, sat2, … by position."
    )
    inertia_kgm2: Inertia = Field(
        description="Diagonal [Ixx, Iyy, Izz] or full 3×3 inertia about the centre of mass, body frame, kg·m²."
    )
    q_bi: Quat = Field([1.0, 0.0, 0.0, 0.0], description="Initial attitude, body relative to inertial, scalar first.")
    omega_b_rad_s: Bounded3(MAX_RATE_RAD_S, "rad/s") = Field([0.0, 0.0, 0.0], description="Initial body rate, body frame, rad/s.")
    angle_rad: Bounded3(1e3, "rad") = Field([0.0, 0.0, 0.0], description="Initial small attitude angles (small-angle model), rad.")
    h_wheels_b_nms: Bounded3(1e6, "N·m·s") = Field([0.0, 0.0, 0.0], description="Wheel angular momentum, body frame, N·m·s.")
    mass_kg: float | None = Field(None, gt=0, le=1e7, description="Mass, kg (needed when a force acts).")
    r_eci_m: Bounded3(MAX_DISTANCE_M, "m") | None = None
    v_eci_m_s: Bounded3(MAX_SPEED_M_S, "m/s") | None = None
    elements: Elements | None = None
    relative: Relative | None = None
    tle: Tle | None = None
    oem: OemState | None = None
    roe: Roe | None = None

    @property
    def reference(self):
        """The spacecraft this one's initial state is given relative to (``relative`` or ``roe``), or None."""
        table = self.relative or self.roe
        return None if table is None else table.to

    @property
    def has_state(self):
        """Whether the file gives this spacecraft's translational state in any form."""
        return any(v is not None for v in (self.r_eci_m, self.elements, self.relative, self.tle, self.oem, self.roe))

    @model_validator(mode="after")
    def _one_translational_source(self):
        sources = (("elements", self.elements), ("r_eci_m/v_eci_m_s", self.r_eci_m), ("relative", self.relative),
                   ("tle", self.tle), ("oem", self.oem), ("roe", self.roe))
        given = [k for k, v in sources if v is not None]
        if len(given) > 1:
            raise ValueError(f"give one of elements, r_eci_m/v_eci_m_s, tle, oem, relative or roe, not {' and '.join(given)}")
        if (self.r_eci_m is None) != (self.v_eci_m_s is None):
            raise ValueError("r_eci_m and v_eci_m_s go together")
        return self


class Orbit(Table):
    """``[orbit]``: translational truth model (omit for attitude-only runs)."""

    gravity: Literal["two-body", "j2"] = "two-body"
    mu_m3_s2: float = Field(MU_EARTH_M3_S2, gt=0, le=1e21, description="Central body's gravitational parameter, m³/s².")
    j2: float = Field(J2_EARTH, ge=-1.0, le=1.0, description="Central body's J2.")
    r_body_m: float = Field(R_EARTH_M, gt=0, le=1e9, description="Central body's equatorial radius, m.")
    epoch_utc: str = Field(
        "2000-01-01T12:00:00",
        description="UTC date-time of t = 0 (ISO 8601): the Earth's orientation, the Sun's and Moon's places. "
        "The run's clock counts TT seconds from it (docs/time-and-frames.md).",
    )
    epoch_tt: str | None = Field(None, description="t = 0 in TT instead (ISO 8601); give one of epoch_utc, epoch_tt, epoch_tai.")
    epoch_tai: str | None = Field(None, description="t = 0 in TAI instead (ISO 8601).")
    # The names of coopsat.astro.earth_orientation.EARTH_ORIENTATION_MODELS (a test keeps them equal;
    # that module imports JAX, which validating a file does not need).
    earth_orientation: Literal["iau2006", "gmst82"] = Field(
        "iau2006",
        description="The Earth's orientation: IAU 2006/2000A with IERS UT1 and polar motion (GCRF ↔ ITRF), or the "
        "papers' turn about z by GMST (gmst82, SPEC §0).",
    )

    @field_validator("epoch_utc", "epoch_tt", "epoch_tai", mode="before")
    @classmethod
    def _toml_date(cls, v):
        """A TOML date-time written without quotes (``epoch_utc = 2018-07-12T03:00:00``) is the
        same instant as the quoted string; one with an offset is left for ``_iso_date``."""
        from datetime import datetime

        return v.isoformat() if isinstance(v, datetime) else v

    @field_validator("epoch_utc", "epoch_tt", "epoch_tai")
    @classmethod
    def _iso_date(cls, v):
        from datetime import datetime

        try:
            datetime.fromisoformat(v) if v is not None else None
        except ValueError:
            raise ValueError(f"'{v}' is not an ISO 8601 date-time (e.g. 2018-06-21T04:00:00)") from None
        return v

    @model_validator(mode="after")
    def _one_epoch(self):
        given = [f for f in ("epoch_utc", "epoch_tt", "epoch_tai") if f in self.model_fields_set and getattr(self, f)]
        if len(given) > 1:
            raise ValueError(f"give one of epoch_utc, epoch_tt, epoch_tai, not {' and '.join(given)}")
        return self

    @property
    def epoch(self):
        """(ISO string, scale) of t = 0: ``("…", "tt")`` when ``epoch_tt`` is given, and so on."""
        for scale in ("tt", "tai"):
            if getattr(self, f"epoch_{scale}") is not None:
                return getattr(self, f"epoch_{scale}"), scale
        return self.epoch_utc, "utc"


class Graph(Table):
    """A communication graph: who hears whom (the fields shared by ``[network]`` and its switches)."""

    kind: Literal[tuple(GRAPH_KINDS)] = "none"  # coopsat.network.graphs: one builder per kind
    directed: bool = Field(False, description="Named graphs and edge lists: one-way links (i hears j only).")
    weight: float = Field(1.0, gt=0, le=MAX_GAIN, description="Weight of every link of a named graph.")
    hub: str | None = Field(None, description="Star: the hub spacecraft (default the first).")
    edges: list[Record(str, str, float)] | None = Field(
        None, description="kind = 'edges': [transmitter, receiver, weight] by spacecraft name."
    )
    adjacency: list[list[float]] | None = Field(None, description="kind = 'adjacency': A[i][j] = weight with which i hears j.")

    @field_validator("adjacency")
    @classmethod
    def _square(cls, a):
        if a is not None and any(len(row) != len(a) for row in a):
            raise ValueError("must be a square n×n matrix (every row as long as there are rows)")
        return a

    @model_validator(mode="after")
    def _fields_match_kind(self):
        if self.edges:
            pairs = [(a, b) for a, b, _ in self.edges]
            pairs += [] if self.directed else [(b, a) for a, b, _ in self.edges]
            seen = set()  # a set, not a scan of the pairs before: a long edge list is not quadratic
            for pair in pairs:
                if pair in seen:
                    raise ValueError(f"edges: link {pair[0]} -> {pair[1]} is given twice")
                seen.add(pair)
        if self.kind == "edges" and not self.edges:
            raise ValueError("kind = 'edges' needs a non-empty edges list [[transmitter, receiver, weight], ...]")
        if self.kind == "adjacency" and self.adjacency is None:
            raise ValueError("kind = 'adjacency' needs an adjacency matrix")
        if self.edges is not None and self.kind != "edges":
            raise ValueError("edges is only read when kind = 'edges'")
        if self.adjacency is not None and self.kind != "adjacency":
            raise ValueError("adjacency is only read when kind = 'adjacency'")
        if self.hub is not None and self.kind != "star":
            raise ValueError("hub is only read when kind = 'star'")
        return self


class GraphSwitch(Graph):
    """One ``[[network.switches]]`` entry: from ``t_s`` on, this graph replaces the previous one."""

    t_s: float = Field(gt=0, le=MAX_TIME_S, description="Switch time, s: a whole multiple of the control period.")


class Network(Graph):
    """``[network]``: who hears whom, when that changes, and how messages travel."""

    delivery: Delivery = Field(
        {"kind": "ideal"}, validate_default=True,
        description="Network model ([network.delivery], by kind): delays, losses, relaying.",
    )
    require_spanning_tree: bool = Field(
        True, description="A consensus law on a graph without a spanning tree is an error (false: a warning)."
    )
    switches: list[GraphSwitch] = Field(
        [], description="Later graphs, in time order ([[network.switches]]): switching topology, link failures."
    )

    @model_validator(mode="after")
    def _increasing_switch_times(self):
        times = [sw.t_s for sw in self.switches]
        if any(b <= a for a, b in zip(times, times[1:])):
            raise ValueError(f"switches: times must increase, got {times}")
        return self


class Sil(Table):
    """``[sil]``: how software in the loop (``coopsat sil``, docs/sil.md) treats this scenario's
    flight software; ``coopsat run`` ignores it."""

    fault_command: Literal["hold", "zero"] = Field(
        "hold",
        description="What a killed or paused spacecraft's actuators execute: its last command (hold) or zero.",
    )


class _CoreAnalysis(Table):
    """The core of ``[analysis]``: thresholds of the generic metrics and figures (pairwise
    synchronisation, how long a settled condition must hold)."""

    sync_attitude_deg: float = Field(1.0, gt=0, le=180, description="Pairwise attitude error that counts as synchronised, deg.")
    sync_rate_rad_s: float = Field(0.01, gt=0, le=MAX_RATE_RAD_S, description="Pairwise rate difference that counts as synchronised, rad/s.")
    settle_hold_s: float = Field(
        10.0, ge=0, le=MAX_TIME_S, description="A settle time counts only if the condition has held this long by the end of the run, s."
    )


def _analysis_table():
    """``[analysis]``: the core thresholds and every installed plug-in's (:attr:`Plugin.thresholds`),
    so that a paper owns its thresholds. Two plug-ins may share a thresholds table; two tables
    defining one field is a :class:`~coopsat.plugins.PluginError`."""
    from pydantic import create_model

    from coopsat.plugins import ROLES, PluginError

    fields, owner = {}, {name: "coopsat (core)" for name in _CoreAnalysis.model_fields}
    for role in ROLES:
        for p in plugins(role).values():
            table = p.thresholds
            for name, info in (table.model_fields.items() if table is not None else ()):
                if name in owner and fields.get(name, (None, None, None))[2] is not table:
                    raise PluginError(
                        f"[analysis] field '{name}' is defined by {owner[name]} and by {p.origin} ({table.__name__})"
                    )
                fields[name] = (info.annotation, info, table)
                owner[name] = f"{p.origin} ({table.__name__})"
    model = create_model(
        "Analysis", __base__=_CoreAnalysis, __module__=__name__,
        **{name: (annotation, info) for name, (annotation, info, _) in fields.items()},
    )
    model.__doc__ = "``[analysis]``: thresholds of the metrics (the core's and the installed papers')."
    return model


Analysis = _analysis_table()


class Published(Table):
    """One ``[[published]]`` number of the source paper, compared with ours after the run."""

    quantity: str = Field(description="Name of one of our metrics (metrics.json key).")
    value: float
    unit: str
    relation: Literal["approx", "greater", "less"] = Field(
        "approx", description="approx: within rel_tol/abs_tol; greater/less: ours must exceed/stay below value."
    )
    rel_tol: float = Field(0.2, ge=0, description="approx: relative difference that still agrees.")
    abs_tol: float = Field(0.0, ge=0, description="approx: absolute difference that still agrees (unit as value).")
    source: str = Field("", description="Where the paper states it.")
    note: str = Field("", description="What differs from the paper's set-up; quoted when the verdict is 'differs'.")


class Scenario(Table):
    """A whole scenario file."""

    name: str = Field(pattern=NAME_PATTERN, description="Scenario name (letters, digits, _ . -); default the file's stem.")
    description: str = ""
    seed: int = Field(0, ge=0, lt=2**63, description="Seed of every random draw of the run (stored in result.nc).")
    sim: Sim
    spacecraft: list[Spacecraft] = Field(min_length=1)
    orbit: Orbit | None = None
    network: Network = Network()
    controller: Controller = Field({"kind": "none"}, validate_default=True)
    actuators: Actuator | list[Actuator] = Field(
        {"kind": "ideal-torque"}, validate_default=True,
        description="One actuator table, or an array of tables [[actuators]] (each executes one command).",
    )
    sensors: list[Sensor] = Field([], description="[[sensors]]: each replaces one measured quantity by a sensor's reading.")
    disturbances: list[Disturbance] = Field([], description="[[disturbances]]: environment forces and torques.")
    navigation: Navigation | None = Field(None, description="[navigation]: the law flies on each spacecraft's estimate.")
    sil: Sil = Sil()
    analysis: Analysis = Analysis()
    published: list[Published] = []

    @model_validator(mode="after")
    def _consistent(self):
        names = [s.name for s in self.spacecraft]
        if len(set(names)) != len(names):
            raise ValueError(f"spacecraft: names must be unique, got {names}")
        has_rv = [s.has_state for s in self.spacecraft]
        absolute = {s.name for s in self.spacecraft if s.has_state and s.reference is None}
        for k, s in enumerate(self.spacecraft):
            if s.reference is not None and s.reference not in absolute:
                field = "relative" if s.relative is not None else "roe"
                raise ValueError(
                    f"spacecraft[{k}].{field}.to: '{s.reference}' must name a spacecraft whose own state is given "
                    f"(r_eci_m/v_eci_m_s, elements, tle or oem): {', '.join(sorted(absolute)) or 'none is'}"
                )
        if self.orbit is None and any(has_rv):
            raise ValueError("spacecraft: a position or orbital elements are given but there is no [orbit] table")
        if self.orbit is not None and not all(has_rv):
            missing = [s.name for s, h in zip(self.spacecraft, has_rv) if not h]
            raise ValueError(f"orbit: every spacecraft needs r_eci_m/v_eci_m_s, elements, tle, oem, relative or roe; missing for {missing}")
        period = self.control_period_s
        _whole_multiple(period, self.sim.dt_s, "controller.period_s", "sim.dt_s")
        _whole_multiple(self.record_interval_s, period, "sim.record_interval_s", "the control period")
        _whole_multiple(self.sim.t_final_s, self.record_interval_s, "sim.t_final_s", "sim.record_interval_s")
        n_ticks = self.sim.t_final_s / self.sim.dt_s
        if n_ticks > MAX_TICKS:
            raise ValueError(f"sim: {n_ticks:.3g} ticks (t_final_s / dt_s) is more than {MAX_TICKS:.0e}; take a larger step")
        n_samples = self.sim.t_final_s / self.record_interval_s
        if n_samples * len(self.spacecraft) > MAX_SAMPLES:
            raise ValueError(
                f"sim.record_interval_s: {n_samples:.3g} samples of {len(self.spacecraft)} spacecraft is more than "
                f"{MAX_SAMPLES:.0e} spacecraft-samples; record less often"
            )
        for k, sw in enumerate(self.network.switches):
            _whole_multiple(sw.t_s, period, f"network.switches[{k}].t_s", "the control period")
        return self

    @property
    def actuator_list(self):
        """The actuator tables as a list (``[actuators]`` or ``[[actuators]]``)."""
        return list(self.actuators) if isinstance(self.actuators, list) else [self.actuators]

    @property
    def control_period_s(self):
        """Control period, s (``sim.dt_s`` when there is no controller)."""
        return self.controller.period_s if self.controller.period_s is not None else self.sim.dt_s

    @property
    def record_interval_s(self):
        """Time between recorded samples, s."""
        return self.sim.record_interval_s if self.sim.record_interval_s is not None else self.control_period_s
