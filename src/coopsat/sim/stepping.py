"""The closed loop one control period at a time: the engine's stages as a public API.

The compiled loop is built from these functions (:mod:`coopsat.sim.period` composes a period,
:mod:`coopsat.sim.programs` a record interval, the first and the last sample), and a caller
that steps the loop itself, with a stage of its own in between (software in the loop,
:mod:`coopsat.workflows.sil.loop`, runs the flight software in other processes), calls the same
ones, so that the same functions on the same numbers give the same result. The stages take the
system in the loop's layout (:func:`engine_view`) and the closed loop's state as a
:class:`PeriodState`; one run, component-major ``(k, n)`` arrays::

    state, y0 = initial_parts(system)                 # t = 0; y0 fills the network's history
    view = engine_view(system)
    every period:
        sensed = sense(view, state.x, state.parts, state.tick)
        outbox (flight software, from sensed.y)
        inbox, net_state, net_record = deliver(view, state.tick, outbox, net_state, sensed.key)
        commands, record (flight software; spacecraft i's key fold_in(controller_key(sensed.key), i))
        pulses, parts, record = actuate(view, state.x, sensed.parts, sensed.t, sensed.key, commands, record)
        state = advance(view, state, parts, pulses, account(view, pulses))

A record interval's sample is :func:`sample` of the truth (:func:`truth`) and the counters at
its start, the record of its first period and :func:`interval_means` over it; the last sample is
:func:`final_sample`. :func:`command` is the compiled loop's whole controlled start of a period
(sense, outbox, deliver, control, actuate).
"""

from coopsat.sim.layout import _engine_view as engine_view
from coopsat.sim.period import (PeriodState, Sensed, account, actuate, advance, command, controller_key, deliver,
                                integrate, network_key, sense, truth)
from coopsat.sim.programs import final_sample, initial_parts, interval_means, sample

__all__ = ["PeriodState", "Sensed", "account", "actuate", "advance", "command", "controller_key", "deliver",
           "engine_view", "final_sample", "initial_parts", "integrate", "interval_means", "network_key", "sample",
           "sense", "truth"]
