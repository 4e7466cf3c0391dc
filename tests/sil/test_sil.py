"""Software in the loop: the same result as the compiled loop, faults, the external law,
clean shutdown and bad input (docs/sil.md). Each run starts one process per spacecraft."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import coopsat
from coopsat.workflows.sil.processes import SILError
from coopsat.workflows.sil.schema import SILSetupError
from coopsat.workflows.sil.run import sil

ROOT = Path(__file__).resolve().parents[2]
LAW3 = ROOT / "examples" / "sil-external" / "law3.py"
RING = [["sat1", "sat2", 1.0], ["sat2", "sat3", 0.5], ["sat3", "sat4", 0.5], ["sat4", "sat5", 0.5], ["sat5", "sat1", 0.5]]


def _short(name="consensus-sync-a-stable", t_final_s=2.0):
    return coopsat.Scenario.load(name).set("sim.t_final_s", t_final_s)


def _without(name):
    """Ring (a) without the edges of one spacecraft: what its neighbours hear once it is silent."""
    return {"kind": "edges", "edges": [e for e in RING if name not in e[:2]]}


def _cmdline(pid):
    """A process's command line (empty while it is in the middle of ``exec``: read again)."""
    for _ in range(100):
        text = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
        if text:
            return text
        time.sleep(0.01)
    return text


def test_sil_equals_the_compiled_loop_with_one_process_per_spacecraft():
    """Every recorded variable equals coopsat run's (q and omega to 1e-12 is the promise; the
    same functions on the same numbers give the same bits)."""
    s = _short()
    seen = {}

    def on_start(pids):
        seen.update({n: _cmdline(p) for n, p in pids.items()})

    ours = sil(s, on_start=on_start)
    ref = coopsat.run(s)
    assert sorted(seen) == ["sat1", "sat2", "sat3", "sat4", "sat5"]
    assert all("coopsat.workflows.sil.fsw" in c for c in seen.values())
    assert set(ours.dataset.data_vars) == set(ref.dataset.data_vars)
    for v in ref.dataset.data_vars:
        np.testing.assert_allclose(ours.dataset[v].values, ref.dataset[v].values, rtol=0, atol=1e-12, err_msg=v)
    assert ours.metrics == ref.metrics
    assert ours.dataset.attrs["sil_protocol_version"] == 1


def test_killed_and_paused_flight_software_go_silent_as_lost_links():
    """sat1 paused from 0.3 s for 0.4 s and sat3 killed at 1.5 s, their actuators at zero (the
    scenario's ``[sil] fault_command``): the formation flies exactly as the compiled loop with
    those spacecraft's links removed while they are silent (their own law then hears nobody:
    zero torque)."""
    s = _short()
    ours = sil(s.set("sil.fault_command", "zero"), kill=[("sat3", 1.5)], pause=[("sat1", 0.3, 0.4)])
    assert ours.dataset.attrs["sil_fault_command"] == "zero"
    ref = coopsat.run(s.set("network.require_spanning_tree", False).set("network.switches", [{"t_s": 0.3, **_without("sat1")}, {"t_s": 0.7, "kind": "edges", "edges": RING},
                                                  {"t_s": 1.5, **_without("sat3")}]))
    for v in ("q", "omega", "torque"):
        np.testing.assert_allclose(ours.dataset[v].values, ref.dataset[v].values, rtol=0, atol=1e-12, err_msg=v)
    events = [(e["spacecraft"], e["event"], round(e["t_s"], 9)) for e in json.loads(ours.dataset.attrs["sil_events"])]
    assert events == [("sat1", "paused", 0.3), ("sat1", "resumed", 0.7), ("sat3", "killed", 1.5)]
    w = ours.dataset["omega"].sel(spacecraft=["sat1", "sat2", "sat4", "sat5"])
    rate_spread = (w.max("spacecraft") - w.min("spacecraft")).max("component")
    assert rate_spread.sel(time=2.0) < rate_spread.sel(time=1.5)  # the other four keep synchronising


def test_the_external_plain_python_law_takes_a_spacecraft_s_place():
    """examples/sil-external/law3.py (numpy, no coopsat) flies sat2 and passes the same
    agreement test as the built-in law, to 1e-12. Its torque differs from the jitted law's at
    rounding (another order of the same operations: 4e-15 N·m on the command, 4e-16 on q over
    these 200 periods of a contracting loop), and no PWM pulse crosses its threshold on a
    rounding difference (else the difference would be 1e-3)."""
    s = _short()
    ours = sil(s, externals={"sat2": f"{sys.executable} {LAW3}"})
    ref = coopsat.run(s)
    for v in ("q", "omega", "torque_command"):
        np.testing.assert_allclose(ours.dataset[v].values, ref.dataset[v].values, rtol=0, atol=1e-12, err_msg=v)
    assert json.loads(ours.dataset.attrs["sil_external"]) == {"sat2": f"{sys.executable} {LAW3}"}


@pytest.mark.slow
@pytest.mark.parametrize("name, t_final_s", [("consensus-track-stable", 2.0), ("deepspace-square-to-line-lmi", 2000.0)])
def test_other_families_equal_the_compiled_loop(name, t_final_s):
    """Law (4) (its per-spacecraft form beside the formation-wide step) and the deep-space
    formation law (a LocalController): states and commands to 1e-12 of their size. Not bit for
    bit: the same arithmetic compiled alone and inside the loop's fusions rounds apart."""
    s = _short(name, t_final_s)
    ours, ref = sil(s), coopsat.run(s)
    for v in ("q", "omega", "r_eci", "v_eci", "torque_command", "force_command"):
        if v in ref.dataset:
            a, b = ours.dataset[v].values, ref.dataset[v].values
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 * max(1.0, np.abs(b).max()), err_msg=v)


def test_a_kill_on_the_delayed_network_drops_its_links_and_messages_in_flight():
    """delay-designed without relaying, lost messages dropped (``on_loss = "drop"``), v2 killed
    at 3 s with its actuators at zero: the leader and v1 fly exactly as the compiled loop with
    v2's transmitting links removed at 3 s (the messages it sent in the 0.37–0.43 s before,
    still in flight, are lost with it: τ(t) is redrawn within the run), and v2 as before until
    the kill, then with zero torque."""
    edges = [["v0", "v1", 1.0], ["v0", "v2", 1.0], ["v1", "v2", 1.0], ["v2", "v1", 1.0]]
    s = (coopsat.Scenario.load("delay-designed").set("sim.t_final_s", 6.0).set("network.edges", edges)
         .set("network.delivery.relay", False).set("network.delivery.on_loss", "drop")
         .set("network.require_spanning_tree", False).set("sil.fault_command", "zero"))
    ours = sil(s, kill=[("v2", 3.0)]).dataset
    ref = coopsat.run(s.set("network.switches", [{"t_s": 3.0, "kind": "edges", "directed": True, "edges": edges[:3]}])).dataset
    assert len(np.unique(ref["network_tau_periods"].values)) > 1
    before = ref.time.values < 3.0
    for v in ("angle", "omega", "torque", "torque_command"):
        a, b = ours[v], ref[v]
        for sc in ("v0", "v1"):
            np.testing.assert_allclose(a.sel(spacecraft=sc).values, b.sel(spacecraft=sc).values, rtol=0, atol=1e-12,
                                       err_msg=f"{v} {sc}")
        np.testing.assert_allclose(a.sel(spacecraft="v2").values[before], b.sel(spacecraft="v2").values[before], rtol=0,
                                   atol=1e-12, err_msg=f"{v} v2 before the kill")
    after = ours.time.values > 3.0
    assert not ours["torque"].sel(spacecraft="v2").values[after].any()
    assert ref["torque"].sel(spacecraft="v2").values[after].any()  # the reference keeps v2 controlled


def _group_members(pgid):
    """Process ids whose process group is ``pgid`` (from /proc)."""
    members = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[2]) == pgid and fields[0] != "Z":
            members.append(int(stat.parent.name))
    return members


@pytest.mark.parametrize("how", ["sigint-group", "sigkill-simulator"])
def test_no_process_remains_after_a_stop(tmp_path, how):
    """Ctrl-C (SIGINT to the whole process group, as a terminal sends it) and a simulator
    killed outright: no process of the group remains; and once the processes are connected,
    nothing of the run is left in the file system (the socket's folder is gone, the logs are
    anonymous files), so a simulator killed outright leaves no file either."""
    cmd = [sys.executable, "-m", "coopsat.cli", "sil", "consensus-sync-a-stable", "--set", "sim.t_final_s=100",
           "--realtime", "5", "--out", str(tmp_path / "D")]
    proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        line = ""
        while "sil: flight software" not in line:
            line = proc.stderr.readline()
            assert line, "the simulator ended before starting its processes"
        pids = [int(p) for p in line.split(" pid ")[1:] for p in [p.split(",")[0]]]
        assert len(pids) == 5 and all(pid in _group_members(proc.pid) for pid in pids)
        time.sleep(4.0)  # into the run (or still starting, on a busy machine: a stop then too)
        if how == "sigkill-simulator":  # once connected, nothing in the file system
            endpoint = dict(v.split("=", 1) for v in Path(f"/proc/{pids[0]}/environ").read_text().split("\0") if "=" in v)
            folder = Path(endpoint["COOPSAT_SIL_ENDPOINT"].removeprefix("ipc://")).parent
            deadline = time.monotonic() + 90
            while folder.exists() and time.monotonic() < deadline:
                time.sleep(0.1)
            assert not folder.exists() and proc.poll() is None
        if how == "sigint-group":
            os.killpg(proc.pid, signal.SIGINT)
            assert proc.wait(60) == 130
        else:
            proc.kill()
            proc.wait(60)
            assert not folder.exists()
        deadline = time.monotonic() + 10
        while _group_members(proc.pid) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert _group_members(proc.pid) == []
        assert not (tmp_path / "D").exists()
    finally:
        if _group_members(proc.pid):
            os.killpg(proc.pid, signal.SIGKILL)


@pytest.mark.parametrize("kwargs, says", [
    ({"kill": [("sat9", 1.0)]}, "kill ('sat9', 1.0): no spacecraft 'sat9'"),
    ({"kill": [("sat3", 5.0)]}, "kill ('sat3', 5.0): t = 5 s is outside the run (0 to 2 s)"),
    ({"pause": [("sat3", 1.0)]}, "pause ('sat3', 1.0): give (name, t_s, duration_s)"),
    ({"kill": ["sat3@1"]}, "kill 'sat3@1': give (name, t_s)"),  # the command line's text is the command's to parse
    ({"pause": [("sat3", 1.0, 0.0)]}, "pause ('sat3', 1.0, 0.0): the pause must last more than 0 s"),
    ({"externals": {"sat2": "no-such-program-xyz"}}, "external command of sat2: cannot start 'no-such-program-xyz'"),
])
def test_bad_input_is_one_line_before_anything_starts(kwargs, says):
    with pytest.raises(SILSetupError, match="^" + says.replace("(", r"\(").replace(")", r"\)")):
        sil(_short(), **kwargs)


@pytest.mark.parametrize("name", ["delay-designed", pytest.param("delay-classic", marks=pytest.mark.slow)])
def test_the_delayed_network_equals_the_compiled_loop(tmp_path, name):
    """Leader–follower under the delayed network (random τ(t) redrawn at random instants,
    multi-hop relaying; law (3), and the classical protocol whose inbox carries each receiver's
    own past state): ``coopsat sil``'s result.nc equals ``coopsat run``'s in every recorded
    variable (to 1e-12 is the promise; it is bit for bit)."""
    import xarray as xr

    base = [sys.executable, "-m", "coopsat.cli"]
    opts = [name, "--set", "sim.t_final_s=10", "--no-figures", "--no-report", "-q"]
    for cmd in ("sil", "run"):
        out = subprocess.run([*base, cmd, *opts, "--out", str(tmp_path / cmd)], capture_output=True, text=True, timeout=300)
        assert out.returncode == 0, out.stderr
    with xr.open_dataset(tmp_path / "sil" / "result.nc") as ours, xr.open_dataset(tmp_path / "run" / "result.nc") as ref:
        assert set(ours.data_vars) == set(ref.data_vars)
        assert len(np.unique(ref["network_tau_periods"].values)) > 1  # τ(t) redrawn within the run
        for v in ref.data_vars:
            np.testing.assert_allclose(ours[v].values, ref[v].values, rtol=0, atol=1e-12, err_msg=v)
        assert ours.attrs["sil_protocol_version"] == 1


def test_a_controller_that_cannot_be_split_is_refused_saying_why():
    """LVLH station keeping without a relative-navigation sensor or a filter: its per-spacecraft
    form reads a relative state that nothing in the run measures."""
    s = coopsat.Scenario.load("cartwheel-keeping-ground").set("published", []).set("sim.t_final_s", 100.0)
    s = s.update({"controller": {"kind": "lvlh-pd", "period_s": 1.0, "k_p": 1e-3, "k_d": 0.1,
                                 "rho_target_lvlh_m": [0.0, 100.0, 0.0]}})
    s = s.set("sensors", [])
    with pytest.raises(SILSetupError, match="^controller kind 'lvlh-pd' cannot be split per spacecraft: its per-spacecraft "
                                       "form reads x_lvlh, which nothing in this run measures"):
        sil(s)


def test_a_spacecraft_silent_from_the_start_flies_free():
    """Killed at t = 0, before its first broadcast: its neighbours hear nothing of it (the
    law's broadcast in zeros stands in its slot, its links dropped) and it flies uncontrolled,
    as the compiled loop with its edges removed from the start."""
    s = _short().set("network.require_spanning_tree", False).set("sil.fault_command", "zero")
    ours = sil(s, kill=[("sat3", 0.0)])
    ref = coopsat.run(s.set("network", {**_without("sat3"), "require_spanning_tree": False}))
    for v in ("q", "omega", "torque"):
        np.testing.assert_allclose(ours.dataset[v].values, ref.dataset[v].values, rtol=0, atol=1e-12, err_msg=v)
    assert not ours.dataset["torque"].sel(spacecraft="sat3").values.any()


def test_an_external_that_does_not_answer_the_handshake_is_refused():
    silent = f'{sys.executable} -c "import time; time.sleep(60)"'
    t0 = time.monotonic()
    with pytest.raises(SILError, match=r"^sat2: flight software did not say hello \(did it start"):
        sil(_short(), externals={"sat2": silent}, handshake_s=5.0)
    assert time.monotonic() - t0 < 30


def test_an_external_broadcast_of_the_wrong_shape_ends_the_run_in_one_line():
    wrong = Path(__file__).with_name("wrong_outbox.py")
    with pytest.raises(SILError, match=r"^sat2: outbox reply: msg field 'q' has shape \(3,\) \(expected float64 shape "
                                       r"\(4,\)\)$"):
        sil(_short(), externals={"sat2": f"{sys.executable} {wrong}"})


def test_the_command_line_says_bad_input_in_one_line(tmp_path):
    out = subprocess.run([sys.executable, "-m", "coopsat.cli", "sil", "consensus-sync-a-stable", "--set",
                          "sim.t_final_s=2", "--kill", "sat7@1", "--out", str(tmp_path / "D")],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 2
    assert out.stderr.strip().splitlines() == ["coopsat: error: kill ('sat7', 1.0): no spacecraft 'sat7' (spacecraft: sat1, "
                                               "sat2, sat3, sat4, sat5)"]


BAD_REPLY = Path(__file__).with_name("bad_reply.py")


def test_a_flight_software_that_replies_by_the_setup_schema_alone_flies():
    """The schema ``setup`` tells (``replies``) is the one replies are checked against: a flight
    software that answers zeros of every shape it names flies, here law (4), whose record holds
    the reference attitude too (one value per instant, not per spacecraft)."""
    ds = sil(_short("consensus-track-stable"), externals={"sat2": f"{sys.executable} {BAD_REPLY} zeros"}).dataset
    assert "q_ref" in ds and not ds["torque_command"].sel(spacecraft="sat2").values.any()
    assert ds["torque_command"].sel(spacecraft="sat1").values.any()


@pytest.mark.parametrize("mode, says", [
    ("no-record", "sat2: command reply: record field 'torque_command' missing (expected float64 shape (3,))"),
    ("short-record", "sat2: command reply: record field 'torque_command' has shape (2,) (expected float64 shape (3,))"),
], ids=["no-record", "short-record"])
def test_a_reply_without_its_record_ends_the_command_in_one_line_leaving_nothing(tmp_path, mode, says):
    """An external flight software whose command comes without its record, or with it one number
    short: one line on stderr (nothing else with ``-q``), status 2, no run folder, no process of
    the run left."""
    cmd = [sys.executable, "-m", "coopsat.cli", "sil", "consensus-sync-a-stable", "--set", "sim.t_final_s=1", "-q",
           "--out", str(tmp_path / "D"), "--external", f"sat2={sys.executable} {BAD_REPLY} {mode}"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        out, err = proc.communicate(timeout=300)
        assert (proc.returncode, out, err.splitlines()) == (2, "", [f"coopsat: error: {says}"])
        assert not (tmp_path / "D").exists()
        assert _group_members(proc.pid) == []
    finally:
        if _group_members(proc.pid):
            os.killpg(proc.pid, signal.SIGKILL)
