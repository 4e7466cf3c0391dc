"""A campaign closes its LocalCluster cleanly: no "Worker process still alive after 4.0 seconds,
killing" (the nanny's warning when a worker takes more than 4 s to exit, which a worker full of
JAX's objects did, collecting them at exit), on a real campaign and on a worker that holds five
million objects.
"""

import logging
import subprocess
import sys
from pathlib import Path

import pytest

COOPSAT = str(Path(sys.executable).parent / "coopsat")

CAMPAIGN = """
description = "4 runs in 2 batches, one per worker"
scenario = "consensus-sync-a-stable"
runs = 4
master_seed = 11
batch_size = 2
overrides = ["sim.t_final_s=20"]

[[dispersions]]
field = "controller.alpha"
distribution = "normal"
sigma = 0.1
mode = "relative"
"""


@pytest.mark.slow  # long: runs in CI's second pytest pass (README)
def test_a_campaign_on_two_local_workers_ends_without_a_warning(tmp_path):
    (tmp_path / "camp.toml").write_text(CAMPAIGN)
    done = subprocess.run([COOPSAT, "campaign", "run", "camp.toml", "--out", "c", "--workers", "2", "-q"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=180)
    assert done.returncode == 0, done.stderr
    assert "4 runs in 2 batches (0 already on disk); 0 failed" in done.stdout
    assert "still alive" not in done.stderr
    assert done.stderr == ""  # nothing else either: no warning, no traceback


class _Records(logging.Handler):
    def __init__(self):
        super().__init__()
        self.lines = []

    def emit(self, record):
        self.lines.append(record.getMessage())


def test_closing_freezes_the_workers_objects_so_that_they_exit_before_the_nanny_kills_them(monkeypatch):
    # Frozen objects are skipped by the collections at interpreter exit (gc.freeze). The frozen
    # count is the exact check; the warning also needs a loaded machine to show without it.
    import gc

    from coopsat.workflows.campaign.runner import _close, client_for

    records, frozen = _Records(), {}
    nanny_log = logging.getLogger("distributed.nanny")
    nanny_log.addHandler(records)
    try:
        client = client_for(1)
        real_close = client.close

        def close_after_looking():
            frozen.update(client.run(gc.get_freeze_count))
            real_close()

        monkeypatch.setattr(client, "close", close_after_looking)
        try:
            client.run(exec, "import sys; sys.ballast = [[] for _ in range(5_000_000)]")
        finally:
            _close(client)
    finally:
        nanny_log.removeHandler(records)
    assert len(frozen) == 1 and min(frozen.values()) > 5_000_000, frozen
    assert not [line for line in records.lines if "still alive" in line], records.lines
