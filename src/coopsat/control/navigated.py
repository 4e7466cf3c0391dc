"""A law flying on a navigation filter's estimate: one spacecraft's flight software made of the
filter and the law, run per spacecraft (``local``) in the compiled loop and in software in the
loop alike.

Each period, spacecraft i's flight software (``step_one``):

1. updates its filter with its own readings and what the network delivered
   (``navigation.update_one``), which gives the estimate of the quantities the filter
   ``provides`` (``x_lvlh``, its state relative to the chief; or its own ``r_eci``, ``v_eci``);
2. runs the law's per-spacecraft form on its readings with those quantities replaced by the
   estimate (``law.step_one``);
3. carries the filter to the next period under the law's commands (``navigation.predict_one``).

Its message is the law's and the filter's together (their names must not clash); it records the
law's record and the filter's (estimate, covariance, innovations); truth stays in the plant
state the run records beside them.
"""

import jax

from coopsat.core.parts import part

_FILTER_KEY = 101  # the filter's stream, folded into the spacecraft's key (the law keeps the key itself)


@part()
class Navigated:
    """Flight software = a navigation filter feeding a law (see the module docstring).

    Attributes
    ----------
    navigation : part
        The filter (:class:`coopsat.plugins.protocols.Navigation`).
    law : part
        A controller with a per-spacecraft form (``reads``, ``outbox_one``, ``step_one``).
    """

    navigation: object
    law: object

    local = True

    @property
    def commands(self):
        return self.law.commands

    @property
    def reads(self):
        """The filter's readings and the law's, but for what the filter provides."""
        own = tuple(q for q in self.law.reads if q not in self.navigation.provides)
        return tuple(dict.fromkeys(self.navigation.reads + own))

    @property
    def reads_own(self):
        return bool(self.navigation.reads_own or getattr(self.law, "reads_own", False))

    def init(self, n):
        return {"navigation": self.navigation.init(n), "law": self.law.init(n)}

    def _law_reads(self, y_i, estimate):
        return {q: estimate[q] if q in estimate else y_i[q] for q in self.law.reads}

    def outbox_one(self, i, y_i, state_i):
        """The law's message (from the filter's present prior) and the filter's."""
        nav = self.navigation
        estimate = nav.estimate_of(i, state_i["navigation"])
        law_msg = self.law.outbox_one(i, self._law_reads(y_i, estimate), state_i["law"])
        return {**law_msg, **nav.outbox_one(i, y_i, state_i["navigation"])}

    def step_one(self, i, t, y_i, inbox_i, state_i, key_i):
        """Spacecraft i's commands, new state and record (the law's and the filter's)."""
        nav = self.navigation
        nav_state, estimate, nav_record = nav.update_one(
            i, t, y_i, inbox_i, state_i["navigation"], jax.random.fold_in(key_i, _FILTER_KEY)
        )
        commands, law_state, law_record = self.law.step_one(
            i, t, self._law_reads(y_i, estimate), inbox_i, state_i["law"], key_i
        )
        nav_state = nav.predict_one(i, nav_state, commands)
        return commands, {"navigation": nav_state, "law": law_state}, {**law_record, **nav_record}

    def output_specs(self):
        return {**self.law.output_specs(), **self.navigation.output_specs()}

    def __getattr__(self, name):
        # What the run's analysis reads of its law (targets, start time, chief) is the law's.
        if name in ("navigation", "law") or name.startswith("__"):
            raise AttributeError(name)
        return getattr(self.law, name)
