"""``--realtime``: each period's answers are due within its slot of wall time; a late command
is held, and every miss is counted and recorded (docs/sil.md)."""

import sys
from pathlib import Path

import numpy as np

import coopsat
from coopsat.workflows.sil.run import realtime_line, sil

LATE = Path(__file__).with_name("late_law3.py")


def test_a_late_command_is_held_and_counted():
    """sat2 overruns its slot (40 ms at 0.25x real time) by 20 ms every tenth period: those
    periods are counted against it, its actuators hold the command before (the record, one
    sample a period, shows the same command twice), and the run goes on."""
    s = (coopsat.Scenario.load("consensus-sync-a-stable").set("sim.record_interval_s", 0.01)
         .set("sim.t_final_s", 0.4))
    result = sil(s, externals={"sat2": f"{sys.executable} {LATE}"}, realtime=0.25)
    ds = result.dataset
    misses = ds["sil_deadline_misses"].sel(spacecraft="sat2").values
    assert ds["sil_deadline_misses"].dims == ("time", "spacecraft")
    overrun = [5, 15, 25, 35]
    assert all(misses[k] == 1 for k in overrun), misses
    torque = ds["torque_command"].sel(spacecraft="sat2").values
    for k in np.flatnonzero(misses):
        np.testing.assert_array_equal(torque[k], torque[k - 1], err_msg=f"period {k}: the late command is held")
    on_time = [k for k in range(1, 40) if not misses[k]]
    assert any(not np.array_equal(torque[k], torque[k - 1]) for k in on_time)  # the law does act when on time
    assert ds.attrs["sil_realtime_factor"] == 0.25
    assert "sat2 " in realtime_line(ds) and realtime_line(ds).startswith("realtime x0.25: deadline misses (periods): ")


def test_lockstep_records_no_schedule():
    ds = sil(coopsat.Scenario.load("consensus-sync-a-stable").set("sim.t_final_s", 0.5)).dataset
    assert "sil_deadline_misses" not in ds and "sil_realtime_factor" not in ds.attrs
