"""The optional members of a plug-in's part: attributes a caller reads only where a part has
them, each with its type and default (re-exported by :mod:`coopsat.plugins.protocols`)."""

from __future__ import annotations

import dataclasses
from typing import Any


@dataclasses.dataclass(frozen=True)
class OptionalMember:
    """An attribute a part of ``roles`` may define; a part without it behaves as ``default``.

    Attributes
    ----------
    roles : tuple of str
        The roles whose parts may define it (:data:`PROTOCOLS`' keys).
    types : tuple of type
        What its value must be (``isinstance``), named in ``what``.
    what : str
        Its type in words (``"a bool"``).
    default : object
    doc : str
        What it means and who reads it.
    """

    roles: tuple
    types: tuple
    what: str
    default: Any
    doc: str


OPTIONAL = {
    "local": OptionalMember(
        ("controller",), (bool,), "a bool", False,
        "True: one spacecraft's flight software (:class:`LocalController`); the engine runs one copy per "
        "spacecraft (coopsat.sim.flight_software)."),
    "reads_own": OptionalMember(
        ("controller",), (bool,), "a bool", False,
        "True: the per-spacecraft form (``step_one``) reads, per link, its own outbox of the instant the link's "
        "message was sent (``inbox_i.own``); else ``own`` is empty. The engine and software in the loop deliver it."),
    "per_spacecraft_refusal": OptionalMember(
        ("controller",), (str, type(None)), "a str or None", None,
        "Why a formation-wide law offers no per-spacecraft form (``reads``, ``outbox_one``, ``step_one``): "
        "software in the loop quotes it when it refuses the law."),
    "lossy": OptionalMember(
        ("network",), (bool,), "a bool", False,
        "True: ``deliver`` may lose a message. Software in the loop then loses a silent spacecraft's links by the "
        "network's rule for a lost message (``hold``); else it drops them (weight 0)."),
    "hold": OptionalMember(
        ("network",), (bool,), "a bool", False,
        "True: a lost message is replaced by the last one the link delivered (its weight kept); False: its term "
        "is dropped (weight 0). Read where ``lossy`` is True."),
}
"""Every optional member of a part, by name (:class:`OptionalMember`): what callers may read of a
part besides its protocol's members, each with its type and default."""


def optional(part: Any, name: str) -> Any:
    """``part``'s optional member ``name`` (a key of :data:`OPTIONAL`), or its default where the
    part does not define it."""
    return getattr(part, name, OPTIONAL[name].default)
