"""No flight software: the spacecraft fly free (torque-free and force-free)."""

from coopsat.core.parts import part


@part()
class NoControl:
    """A controller that commands nothing and broadcasts nothing (actuators get zero)."""

    commands = ()

    def init(self, n):
        return ()

    def outbox(self, y, state):
        return {}

    def step(self, t, y, inbox, state, key):
        return {}, state, {}

    def output_specs(self):
        return {}
