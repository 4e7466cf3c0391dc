"""CCSDS Attitude Ephemeris Message (AEM 1.0, KVN) of one spacecraft of a run.

Our quaternion ``q_bi`` (scalar first, Hamilton) takes body components to inertial ones,
``v_i = q_bi ⊗ v_b ⊗ q_bi*``: it is the rotation that turns the inertial axes onto the body
axes. That is what ADM calls the attitude from frame A to frame B with A the inertial frame:
its direction-cosine matrix ``M(q) = (qc² − |q|²) I + 2 q qᵀ − 2 qc [q×]`` maps A components
to B components, and ``M(q_bi) = C_ib = quat_to_dcm(q_bi)ᵀ`` for the same four numbers. So the
run's quaternion is written unchanged, with ``REF_FRAME_A`` the run's inertial frame, ``REF_FRAME_B =
SC_BODY_1``, ``ATTITUDE_DIR = A2B``, ``QUATERNION_TYPE = FIRST`` (tests/unit/export checks
the matrix identity). The sign is the run's, continuous in time, so that a reader's
interpolation between lines is sound (ADM only recommends ``QC ≥ 0``).
"""

from coopsat.exports import ccsds
from coopsat.exports.run import epochs_iso, require_attitude

SUFFIX = ".aem"
ONE_OBJECT_PER_FILE = True
WHAT = "an AEM"
LIBRARY = ("ccsds-ndm", "ccsds_ndm")
"""The distribution that writes the format, and its import name (the ``export`` extra)."""


def render(run, name):
    """The AEM text of spacecraft ``name`` of ``run``: a format's ``render`` (:mod:`coopsat.exports`).

    Raises
    ------
    ExportError
        A run without attitude quaternions.
    """
    from ccsds_ndm.models import ndmxml2 as m
    from ccsds_ndm.models.ndmxml2.ndmxml_2_0_0_master_2_0 import Aem

    require_attitude(run, WHAT)
    q_bi = run.q_bi[:, run.names.index(name)]
    epochs = epochs_iso(run)
    states = [
        m.AttitudeStateType(quaternion_state=m.QuaternionEphemerisType(
            epoch=epoch, quaternion=m.QuaternionType(qc=float(q[0]), q1=float(q[1]), q2=float(q[2]), q3=float(q[3]))))
        for epoch, q in zip(epochs, q_bi)
    ]
    metadata = m.AemMetadata(
        object_name=name, object_id=name, center_name=run.center_name,
        ref_frame_a=run.ref_frame, ref_frame_b=ccsds.REF_FRAME_BODY, attitude_dir=m.RotDirectionType.A2_B,
        time_system=m.TimeSystemType(run.time_system), start_time=str(epochs[0]), stop_time=str(epochs[-1]),
        attitude_type=m.AttitudeTypeType.QUATERNION_1, quaternion_type=m.QuaternionTypeType.FIRST_1,
    )
    segment = m.AemSegment(metadata=metadata, data=m.AemData(attitude_state=states))
    return ccsds.kvn_text(Aem(header=ccsds.header(m, run), body=m.AemBody(segment=[segment])))
