"""How long a built run will take, estimated before it starts, and the refusal of one too long."""

from coopsat.scenarios.load import ScenarioError


ENGINE_RATE_SC_STEPS_S = 2e6
"""Spacecraft-steps per second assumed when estimating a run's wall time: the consensus loop's
lower figure on the 2-core CPU machine of `coopsat bench` (docs/performance.md); pulsed actuators
split ticks and count double."""

LONG_RUN_S = 1800.0
"""Estimated wall time above which a run needs ``allow_long`` (``--allow-long``), s."""


class RunTooLongError(ScenarioError):
    """A run whose estimated wall time is above :data:`LONG_RUN_S` and was not allowed."""


def estimated_run_s(built):
    """Rough wall time of the closed loop, s, from the run's size and the engine's speed."""
    s = built.scenario
    steps = s.sim.t_final_s / s.sim.dt_s * len(built.names) * s.sim.substeps
    pulsed = any(getattr(a, "pulsed", False) for a in built.system.actuators)
    return steps * (2.0 if pulsed else 1.0) / ENGINE_RATE_SC_STEPS_S


def check_run_length(built, allow_long=False):
    """Refuse, before anything runs, a run estimated to take longer than :data:`LONG_RUN_S`.

    Raises
    ------
    RunTooLongError
    """
    estimate = estimated_run_s(built)
    if estimate > LONG_RUN_S and not allow_long:
        s = built.scenario
        raise RunTooLongError(
            f"sim: {s.sim.t_final_s / s.sim.dt_s:.3g} ticks of {len(built.names)} spacecraft would take about "
            f"{estimate / 3600:.2g} h at ~{ENGINE_RATE_SC_STEPS_S / 1e6:g} M spacecraft-steps/s; shorten the run or "
            "take a larger step, or pass --allow-long to run it anyway"
        )
    return estimate
