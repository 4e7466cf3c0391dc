"""CZML (Cesium's scene format) of a whole run: a document packet and one packet per spacecraft.

CZML places objects around the Earth and defines an orientation as the rotation from body axes
to the Earth-fixed axes, so both position and orientation are given in Cesium's ``FIXED``
frame, obtained from the run's ECI by the run's own Earth rotation (about z by
``θ = GMST(epoch_utc) + ω_E t``, IAU-82, no precession or nutation: coopsat.astro.earth). A
viewer then shows each spacecraft over the ground point the run itself computed (the
observation scenarios' targets); Cesium's ``INERTIAL`` frame would move them by the precession
since J2000 (0.3° in 2020). A run about another body is refused.

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


# θ and the rotation are computed here in NumPy float64, as astro.earth's rotation_angle_rad and
# eci_to_ecef define them: those are jax.numpy, float32 in a process that has not run a
# scenario (the export does not), which would misplace a low orbit by metres.
def earth_rotation_rad(run):
    """Earth rotation angle ``θ = GMST(epoch) + ω_E t`` at every sample, rad, shape (T,)."""
    from coopsat.astro.earth import OMEGA_EARTH_RAD_S, gmst_rad, julian_date_utc

    return gmst_rad(julian_date_utc(str(run.epoch))) + OMEGA_EARTH_RAD_S * run.t_s


def r_fixed_m(r_eci_m, theta_rad):
    """Earth-fixed components ``R3(θ) r`` of ECI vectors, shapes (T, n, 3) and (T,) -> (T, n, 3), m."""
    c, s = np.cos(theta_rad)[:, None], np.sin(theta_rad)[:, None]
    x, y, z = np.moveaxis(r_eci_m, -1, 0)
    return np.stack([c * x + s * y, -s * x + c * y, z], axis=-1)


def q_body_to_fixed(q_bi, theta_rad):
    """Attitude relative to the Earth-fixed axes, ``q_fi ⊗ q_bi`` with ``q_fi = [cos(θ/2), 0, 0,
    −sin(θ/2)]`` (takes ECI components to fixed ones), scalar first, shapes (T, n, 4) and (T,)."""
    from coopsat.geometry.quaternion import quat_multiply

    half = 0.5 * theta_rad
    zero = np.zeros_like(half)
    q_fi = np.stack([np.cos(half), zero, zero, -np.sin(half)], axis=-1)[:, None, :]
    return quat_multiply(q_fi, q_bi)


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
    epochs = epochs_iso(run)
    epoch, interval = f"{epochs[0]}Z", f"{epochs[0]}Z/{epochs[-1]}Z"
    theta = earth_rotation_rad(run)
    r_f = r_fixed_m(run.r_eci_m, theta)
    q_f = None if run.q_bi is None else q_body_to_fixed(run.q_bi, theta)
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
