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

    # The per-spacecraft form (software in the loop runs one spacecraft per process,
    # docs/sil.md): each spacecraft reads nothing, broadcasts nothing, commands nothing.
    reads = ()

    def outbox_one(self, i, y_i, state_i):
        return {}

    def step_one(self, i, t, y_i, inbox_i, state_i, key_i):
        return {}, state_i, {}

    def output_specs(self):
        return {}
