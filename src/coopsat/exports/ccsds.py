"""What the CCSDS messages (OEM, AEM) share: names, the header, the KVN text.

Written with ccsds-ndm's NDM/XML 2.0.0 models (OEM 2.0, CCSDS 502.0-B-2; AEM 1.0, CCSDS
504.0-B-1): the versions most tools read (GMAT, STK, Orekit), and the AEM version whose
metadata states the quaternion's direction and scalar position outright (``ATTITUDE_DIR``,
``QUATERNION_TYPE``). Keyword-value notation (KVN), the form those tools exchange.

A CCSDS OEM or AEM describes one object, so each spacecraft gets its own message
(docs/export.md).
"""

from datetime import datetime, timezone

REF_FRAME_BODY = "SC_BODY_1"
"""CCSDS name of the spacecraft's body axes."""

ORIGINATOR = "coopsat"


def header(models, run):
    """The message header: creation date (now, UTC), originator, and comments saying which run
    and how its epoch was set.

    Parameters
    ----------
    models : module
        ``ccsds_ndm.models.ndmxml2``.
    run : coopsat.exports.run.RunStates
    """
    import coopsat

    now = datetime.now(timezone.utc).replace(tzinfo=None).isoformat(timespec="seconds")
    return models.NdmHeader(
        comment=[f"coopsat {coopsat.__version__}, scenario {run.scenario_name}", run.epoch_note],
        creation_date=now,
        originator=ORIGINATOR,
    )


def kvn_text(message):
    """The KVN text of a ccsds-ndm message object, ending in a newline."""
    from ccsds_ndm.ndm_kvn_io import NdmKvnIo

    return NdmKvnIo().to_string(message).rstrip("\n") + "\n"
