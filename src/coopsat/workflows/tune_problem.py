"""The differentiable problem of ``coopsat tune`` (:mod:`coopsat.workflows.tune`): which
scenario fields are tuned and how they are scaled (:class:`Param`), the closed loop with its
smooth surrogates (:func:`smooth_system`), and the loss ``z -> (objective, constraints)`` of one
differentiable run (:func:`loss_function`).

Parametrisation: a positive field (a consensus gain, graph weights) is tuned as ``θ0·e^z`` so
that it stays positive; any other (a gain matrix) as ``θ0 + s ⊙ z`` with ``s`` the size of its
entries (at least 5 % of the largest of their column), so that every variable is of order one.
"""

import re
from dataclasses import dataclass, replace

import numpy as np

from coopsat.core.errors import InputError
from coopsat.analysis.surrogates import surrogates
from coopsat.plugins import plugin_for
from coopsat.scenarios.build import scenario_tables
from coopsat.scenarios.load import clip_echo


class TuneError(InputError):
    """A tuning that cannot be run as asked (one line)."""


@dataclass(frozen=True)
class Param:
    """One tuned field: where it is, its tunable, and how it is scaled.

    Attributes
    ----------
    path : str
        As given (``controller.alpha``, ``actuators.0.torque_max_nm``).
    place : str
        The table's place in the scenario file as an override prefix (``controller``).
    role : str
    index : int
        Position of the part among the parts of its role.
    name : str
        The table field.
    tunable : coopsat.plugins.Tunable
    log : bool
        Tuned as ``θ0·e^z`` (every entry positive), else ``θ0 + scale·z``.
    scale : ndarray
    """

    path: str
    place: str
    role: str
    index: int
    name: str
    tunable: object
    log: bool
    scale: np.ndarray

    @property
    def size(self):
        return int(np.size(self.tunable.value))

    def value(self, z):
        """The field's value for the variables ``z`` (JAX or NumPy), shape of the field."""
        import jax.numpy as jnp

        v0 = jnp.asarray(self.tunable.value, dtype=float)
        z = jnp.reshape(z, v0.shape)
        return v0 * jnp.exp(z) if self.log else v0 + jnp.asarray(self.scale) * z



def _dotted(place):
    """``actuators[0]`` → ``actuators.0`` (the override syntax)."""
    return re.sub(r"\[(\d+)\]", r".\1", place)


def resolve_params(built, paths):
    """The :class:`Param` of every ``--params`` path.

    Raises
    ------
    TuneError
        A path that names no table, or a field its plug-in does not offer for tuning (the
        message lists the ones it does).
    """
    tables = scenario_tables(built.scenario)
    by_place, counters = {}, {}
    for role, place, table in tables:
        index = counters.get(role, 0)
        counters[role] = index + 1
        dotted = _dotted(place)
        # Also by the names a user writes: `network` for its delivery table, `sensors` for
        # the only sensor; the tuned file is written at the table's own place.
        for alias in {dotted, dotted.replace("network.delivery", "network")}:
            by_place[alias] = (role, index, table, dotted)
        if dotted.endswith(".0") and sum(1 for r, _, _ in tables if r == role) == 1:
            by_place[dotted[:-2]] = (role, index, table, dotted)
    params = []
    for path in paths:
        alias, _, name = path.rpartition(".")
        if alias not in by_place:
            raise TuneError(f"params {clip_echo(path)}: no table '{clip_echo(alias)}' in this scenario "
                            f"(tables: {', '.join(sorted(by_place))})")
        role, index, table, place = by_place[alias]
        plugin = plugin_for(role, table)
        part = _part(built.system, role, index)
        offered = plugin.tunables(table, built.context, part) if plugin.tunables else {}
        if name not in offered:
            what = ", ".join(f"{alias}.{k}" for k in offered) or "none"
            raise TuneError(f"params {clip_echo(path)}: {table.kind} cannot tune '{clip_echo(name)}' (tunable here: {what})")
        tunable = offered[name]
        v0 = np.asarray(tunable.value, dtype=float)
        log = bool(np.all(v0 > 0))  # gains and graph weights stay positive
        # Each entry's own size, at least 5 % of the largest of its column (a gain matrix's
        # columns have different units: N/m beside N·s/m, three orders apart here).
        big = np.abs(v0).max(axis=0, keepdims=True) if v0.ndim == 2 else np.abs(v0).max()
        scale = np.maximum(np.abs(v0), 0.05 * np.where(big > 0, big, max(float(np.abs(v0).max()), 1e-12)))
        params.append(Param(path, place, role, index, name, tunable, bool(log), scale))
    if not params:
        raise TuneError("params: name at least one field to tune")
    if len({p.path for p in params}) != len(params):
        raise TuneError("params: a field is named twice")
    return params


def _part(system, role, index):
    """The built part of a role (the controller and the network are single)."""
    return getattr(system, role) if role in ("controller", "network") else getattr(system, role + "s")[index]


def with_params(system, params, values):
    """``system`` with every parameter's value in its part (traceable)."""
    for p, v in zip(params, values):
        if p.role in ("controller", "network"):
            system = replace(system, **{p.role: p.tunable.apply(getattr(system, p.role), v)})
        else:
            parts = list(getattr(system, p.role + "s"))
            parts[p.index] = p.tunable.apply(parts[p.index], v)
            system = replace(system, **{p.role + "s": tuple(parts)})
    return system


def smooth_system(system):
    """``system`` with every part that has a smooth surrogate replaced by it, and the notes
    saying what each is."""
    notes = []

    def sub(part):
        make = getattr(part, "surrogate", None)
        if make is None:
            return part
        smooth, note = make()
        notes.append(note)
        return smooth

    system = replace(
        system,
        controller=sub(system.controller),
        actuators=tuple(sub(a) for a in system.actuators),
        sensors=tuple(sub(s) for s in system.sensors),
        disturbances=tuple(sub(d) for d in system.disturbances),
    )
    return system, notes


def split_variables(params, z):
    """Flat variables → one array per parameter."""
    out, k = [], 0
    for p in params:
        out.append(p.value(z[k: k + p.size]))
        k += p.size
    return out


def loss_function(built, params, objective, constraints, smooth=True):
    """``z -> (objective, constraints (m,))`` of one run: pure JAX, differentiable.

    The objective is the metric's surrogate (not yet normalised); each constraint is ≤ 0 when
    it holds (dimensionless).
    """
    import jax.numpy as jnp

    from coopsat.sim.engine import run_samples

    table = surrogates(built)
    for spec in (objective, *constraints):
        if spec.metric not in table:
            raise TuneError(
                f"'{spec.metric}': no differentiable stand-in for this metric in this scenario "
                f"(metrics that can be tuned on here: {', '.join(sorted(table)) or 'none'})"
            )
        s = table[spec.metric]
        if (spec.bound is None and s.objective is None) or (spec.bound is not None and s.constraint is None):
            raise TuneError(f"'{spec.metric}' can be tuned on only as {'a constraint' if s.objective is None else 'an objective'}")
    system = smooth_system(built.system)[0] if smooth else built.system
    t_s = np.arange(built.n_records + 1) * built.record_interval_s
    n = built.n_records

    def f(z):
        tuned = with_params(system, params, split_variables(params, z))
        samples = run_samples(tuned, n)
        obj = table[objective.metric].objective(samples, t_s, built, tuned)
        cons = [table[c.metric].constraint(samples, t_s, built, tuned, c.bound) for c in constraints]
        return obj, jnp.stack(cons) if cons else jnp.zeros((0,))

    return f
