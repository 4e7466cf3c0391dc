"""CZML (Cesium's scene format) of a whole run: a document packet and one packet per spacecraft.

CZML places objects around the Earth and defines an orientation as the rotation from body axes
to the Earth-fixed axes, so both position and orientation are given in Cesium's ``FIXED``
frame, obtained from the run's inertial states by the run's own Earth orientation (rebuilt from
its ``[orbit]`` table: IAU 2006/2000A by default, or the papers' GMST turn,
coopsat.astro.earth_orientation). A viewer then shows each spacecraft over the ground point the
run itself computed (the observation scenarios' targets). Sample times are UTC, ``epoch_utc + t``.
A run about another body is refused.

Per spacecraft: ``position.cartesian`` samples ``[t, x, y, z, …]`` in m (t in s from the packet's
``epoch``), ``orientation.unitQuaternion`` samples ``[t, x, y, z, w, …]`` (scalar last, as CZML
orders it) when the run has attitude, a path and a label.
"""

import numpy as np

from coopsat.exports.run import ExportError, epochs_iso, require_positions

SUFFIX = ".czml"
ONE_OBJECT_PER_FILE = False
WHAT = "a CZML scene"
LIBRARY = ("czml3", "czml3")
"""The distribution that writes the format, and its import name (the ``export`` extra)."""


def fixed_from_inertial(run):
    """The run's inertial-to-Earth-fixed matrices at every sample, shape (T, 3, 3): its own Earth
    orientation table, in NumPy float64 (JAX is float32 in a process that has not run a
    scenario, which would misplace a low orbit by metres)."""
    from coopsat.astro.earth_orientation import itrf_from_gcrf_matrix
    from coopsat.plugins.earth_environment import run_clock
    from coopsat.scenarios.schema import Orbit

    table = run_clock(Orbit.model_validate(run.orbit), float(run.t_s[-1])).earth
    return itrf_from_gcrf_matrix(table, run.t_s, np)


def r_fixed_m(r_eci_m, to_fixed):
    """Earth-fixed components ``M r`` of inertial vectors, shapes (T, n, 3) and (T, 3, 3) -> (T, n, 3), m."""
    return np.einsum("tij,tnj->tni", to_fixed, r_eci_m)


def q_body_to_fixed(q_bi, to_fixed):
    """Attitude relative to the Earth-fixed axes, ``q_fi ⊗ q_bi`` with ``q_fi`` the rotation whose
    matrix is ``M`` (it takes inertial components to fixed ones), scalar first, shapes (T, n, 4)
    and (T, 3, 3)."""
    from scipy.spatial.transform import Rotation

    from coopsat.geometry.quaternion import quat_multiply

    q_fi = Rotation.from_matrix(to_fixed).as_quat(scalar_first=True)[:, None, :]
    return np.asarray(quat_multiply(q_fi, q_bi))


def _samples(t_s, values):
    """CZML's flat sample list ``[t0, v0…, t1, v1…]`` of times (T,) and values (T, k)."""
    return np.concatenate([t_s[:, None], values], axis=1).ravel().tolist()


def render(run, names):
    """The CZML text (JSON) of the spacecraft ``names`` of ``run``.

    Parameters
    ----------
    run : coopsat.exports.run.RunStates
    names : sequence of str

    Raises
    ------
    ExportError
        A run without positions, or about a body other than the Earth.
    """
    from czml3 import Document, Packet
    from czml3.properties import Clock, Label, Orientation, Path, Position

    require_positions(run, WHAT)
    if run.center_name != "EARTH":
        raise ExportError(f"{run.scenario_name}: {WHAT} places spacecraft around the Earth and this run's central "
                          f"body is the {run.center_name.title()}; export its orbits with --format oem")
    epochs = epochs_iso(run, utc=True)
    epoch, interval = f"{epochs[0]}Z", f"{epochs[0]}Z/{epochs[-1]}Z"
    to_fixed = fixed_from_inertial(run)
    r_f = r_fixed_m(run.r_eci_m, to_fixed)
    q_f = None if run.q_bi is None else q_body_to_fixed(run.q_bi, to_fixed)
    packets = [Packet(id="document", name=run.scenario_name, version="1.0",
                      clock=Clock(interval=interval, currentTime=epoch, multiplier=10.0))]
    for name in names:
        k = run.names.index(name)
        orientation = None if q_f is None else Orientation(
            epoch=epoch, interpolationAlgorithm="LINEAR", unitQuaternion=_samples(run.t_s, q_f[:, k][:, [1, 2, 3, 0]]))
        packets.append(Packet(
            id=name, name=name, availability=interval,
            position=Position(epoch=epoch, referenceFrame="FIXED", interpolationAlgorithm="LAGRANGE",
                              interpolationDegree=5, cartesian=_samples(run.t_s, r_f[:, k])),
            orientation=orientation, path=Path(show=True, width=1.0), label=Label(text=name, show=True),
        ))
    return Document(packets=packets).model_dump_json(exclude_none=True) + "\n"
