"""Software in the loop honours what a network part from another package declares
(coopsat.plugins.protocols.OPTIONAL): a network that loses messages and holds them (``lossy =
True``, ``hold = True``) loses a silent spacecraft's links by holding them, as the compiled loop
does when that network loses them.

The package is made here and installed as docs/plugins.md §7 says (an entry point, found on
PYTHONPATH); a fresh interpreter runs the scenario both ways and saves the records, which this
process compares (as tests/sil/test_sil.py compares SIL with the compiled loop)."""

import os
import subprocess
import sys
import textwrap

import numpy as np

from plugins.test_entry_points import fake_distribution

PLUGIN = textwrap.dedent('''
    """lossy-hold: no delay; every link loses its message with a probability each period and, from
    an instant on, every message of one spacecraft; a lost message is held (the last one the link
    delivered, with the receiver's own outbox of that instant)."""

    from typing import Literal

    import jax
    import jax.numpy as jnp
    from pydantic import Field

    from coopsat.plugins import Inbox, Plugin, Table, part, register


    class LossyHoldTable(Table):
        kind: Literal["lossy-hold"]
        loss_probability: float = Field(0.0, ge=0, lt=1)
        silent: str | None = None
        silent_from_s: float = 0.0


    def _links(outbox, index):
        return jax.tree_util.tree_map(lambda v: jnp.take(v, index, axis=-1), outbox)


    @part()
    class LossyHold:
        src: jnp.ndarray
        dst: jnp.ndarray
        weight: jnp.ndarray
        loss_probability: jnp.ndarray
        silent: jnp.ndarray  # per link: its transmitter falls silent at silent_from_tick
        silent_from_tick: jnp.ndarray

        lossy = True
        hold = True

        def init(self, outbox0):
            return _links(outbox0, self.src), _links(outbox0, self.dst)

        def deliver(self, tick, outbox, state, key):
            lost = jax.random.uniform(key, self.weight.shape) < self.loss_probability
            lost = lost | (self.silent & (tick >= self.silent_from_tick))
            keep = lambda new, old: jnp.where(lost, old, new)  # noqa: E731
            msg, own = jax.tree_util.tree_map(keep, (_links(outbox, self.src), _links(outbox, self.dst)), state)
            return Inbox(msg, self.weight, self.dst, own), (msg, own), {}

        def output_specs(self):
            return {}


    def _build(table, ctx):
        import numpy as np

        from coopsat.network import topology
        from coopsat.sim.system import as_arrays

        links = topology.links_for_schedule(ctx.adjacencies)
        silent = (links.src == ctx.index(table.silent, "network.delivery.silent") if table.silent
                  else np.zeros(links.src.shape, bool))
        from_tick = round(table.silent_from_s / ctx.dt_s)
        return LossyHold(*as_arrays((links.src, links.dst, links.weight[0], table.loss_probability, silent, from_tick)))


    register(Plugin("network", "lossy-hold", LossyHoldTable, _build))
''')

RUNS = textwrap.dedent('''
    import sys

    import numpy as np

    import coopsat
    from coopsat.plugins import protocol_problems
    from coopsat.scenarios.build import build

    NET = {"kind": "lossy-hold", "loss_probability": 0.3}
    s = coopsat.Scenario.load("consensus-sync-a-stable").set("sim.t_final_s", 2.0).set("network.delivery", NET)
    print("problems", protocol_problems(build(s.model).system.network, "network"))
    killed = s.set("sil.fault_command", "zero")
    lost = s.set("network.delivery", {**NET, "silent": "sat3", "silent_from_s": 1.0})
    runs = {"sil": coopsat.sil(s, report=False), "run": coopsat.run(s, report=False),
            "sil_kill": coopsat.sil(killed, kill=[("sat3", 1.0)], report=False), "run_lost": coopsat.run(lost, report=False)}
    np.savez(sys.argv[1], **{f"{k}/{v}": r.dataset[v].values for k, r in runs.items() for v in r.dataset.data_vars},
             time=runs["run"].dataset["time"].values, spacecraft=runs["run"].dataset["spacecraft"].values.astype(str))
''')


def test_sil_holds_a_silent_spacecrafts_links_on_a_third_party_network_that_holds(tmp_path):
    site = fake_distribution(tmp_path / "site", "coopsat-lossy", {"lossy": "coopsat_lossy"}, {"coopsat_lossy": PLUGIN})
    (tmp_path / "runs.py").write_text(RUNS)
    proc = subprocess.run([sys.executable, str(tmp_path / "runs.py"), str(tmp_path / "runs.npz")], capture_output=True,
                          text=True, env={**os.environ, "PYTHONPATH": str(site)})
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "problems []" in proc.stdout
    with np.load(tmp_path / "runs.npz") as f:
        runs = dict(f)
    time, spacecraft = runs.pop("time"), list(runs.pop("spacecraft"))
    names = {k.split("/")[1] for k in runs if k.startswith("run/")}
    assert {k.split("/")[1] for k in runs if k.startswith("sil/")} == names
    # Every process answering: SIL is the compiled loop (the network's own losses, held, in both).
    for v in names:
        np.testing.assert_allclose(runs[f"sil/{v}"], runs[f"run/{v}"], rtol=0, atol=1e-12, err_msg=v)
    # sat3 killed at 1 s, its actuators at zero: the others fly as the compiled loop whose network
    # loses every message of sat3 from 1 s and holds it; sat3 as before until the kill.
    sat3 = spacecraft.index("sat3")
    others = [i for i in range(len(spacecraft)) if i != sat3]
    for v in ("q", "omega", "torque", "torque_command"):
        a, b = runs[f"sil_kill/{v}"], runs[f"run_lost/{v}"]
        np.testing.assert_allclose(a[:, others], b[:, others], rtol=0, atol=1e-12, err_msg=v)
        np.testing.assert_allclose(a[time < 1.0, sat3], b[time < 1.0, sat3], rtol=0, atol=1e-12, err_msg=f"{v} sat3")
    assert not runs["sil_kill/torque"][time > 1.0, sat3].any()
