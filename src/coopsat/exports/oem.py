"""CCSDS Orbit Ephemeris Message (OEM 2.0, KVN) of one spacecraft of a run.

Each data line is ``EPOCH X Y Z X_DOT Y_DOT Z_DOT``: the run's recorded inertial position and
velocity in km and km/s (the OEM's units), ``REF_FRAME`` the run's inertial frame (``GCRF``,
or ``EME2000`` for the papers' Earth) centred on its central body (``EARTH`` or ``SUN``),
``TIME_SYSTEM`` its clock (``TT``; ``UTC`` for a result older than the run's time scales). Values are written as the shortest
decimal that reads back as the same float64, so a reader recovers the km values exactly.
"""

from coopsat.exports import ccsds
from coopsat.exports.run import epochs_iso, require_positions

SUFFIX = ".oem"
ONE_OBJECT_PER_FILE = True
WHAT = "an OEM"
LIBRARY = ("ccsds-ndm", "ccsds_ndm")
"""The distribution that writes the format, and its import name (the ``export`` extra)."""
KM_PER_M = 1e-3


def render(run, name):
    """The OEM text of spacecraft ``name`` of ``run``: a format's ``render`` (:mod:`coopsat.exports`).

    Raises
    ------
    ExportError
        A run without positions, or about a body with no CCSDS name.
    """
    from ccsds_ndm.models import ndmxml2 as m
    from ccsds_ndm.models.ndmxml2.ndmxml_2_0_0_master_2_0 import Oem

    require_positions(run, WHAT)
    k = run.names.index(name)
    r_km = run.r_eci_m[:, k] * KM_PER_M
    v_km_s = run.v_eci_m_s[:, k] * KM_PER_M
    epochs = epochs_iso(run)
    states = [
        m.StateVectorAccType(
            epoch=epoch,
            x=m.PositionType(value=float(r[0])), y=m.PositionType(value=float(r[1])), z=m.PositionType(value=float(r[2])),
            x_dot=m.VelocityType(value=float(v[0])), y_dot=m.VelocityType(value=float(v[1])),
            z_dot=m.VelocityType(value=float(v[2])),
        )
        for epoch, r, v in zip(epochs, r_km, v_km_s)
    ]
    metadata = m.OemMetadata(
        object_name=name, object_id=name, center_name=run.center_name, ref_frame=run.ref_frame,
        time_system=run.time_system, start_time=str(epochs[0]), stop_time=str(epochs[-1]),
    )
    segment = m.OemSegment(metadata=metadata, data=m.OemData(state_vector=states))
    return ccsds.kvn_text(Oem(header=ccsds.header(m, run), body=m.OemBody(segment=[segment])))

