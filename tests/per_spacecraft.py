"""A formation-wide law's per-spacecraft form, run by the engine's own per-spacecraft wrapper
(shared by the SIL tests that check the two forms agree)."""


class OneByOne:
    """The per-spacecraft form (``reads``, ``outbox_one``, ``step_one``) of ``law`` as a
    LocalController, so that ``coopsat.sim.flight_software._PerSpacecraft`` runs it once per
    spacecraft."""

    local = True

    def __init__(self, law):
        self.law, self.reads, self.commands = law, law.reads, law.commands
        self.reads_own = getattr(law, "reads_own", False)

    def init(self, n):
        return self.law.init(n)

    def outbox_one(self, *args):
        return self.law.outbox_one(*args)

    def step_one(self, *args):
        return self.law.step_one(*args)
