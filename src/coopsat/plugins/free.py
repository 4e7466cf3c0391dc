"""Controller ``none``: no flight software (torque- and force-free flight)."""

from typing import Literal

from pydantic import Field

from coopsat.plugins import Plugin, register
from coopsat.plugins.tables import Table


class NoController(Table):
    """``kind = "none"``: torque-free (no control)."""

    kind: Literal["none"]
    period_s: float | None = Field(None, gt=0, le=1e5, description="Default: sim.dt_s.")


def _build(table, ctx):
    from coopsat.control.free import NoControl

    return NoControl()


register(Plugin("controller", "none", NoController, _build))
