"""A scenario of 20 000 spacecraft builds with memory linear in its links: no n × n matrix
(one would be 3.2 GB; every graph is an edge list, docs/architecture.md). Built in a process of
its own, so that its memory is measured alone and not kept by a test worker."""

import json
import subprocess
import sys

import numpy as np
import pytest

N = 20_000
DENSE_GB = N * N * 8 / 1e9  # one float64 adjacency: 3.2 GB


def _scenario(path, delivery):
    rng = np.random.default_rng(2)
    q = rng.normal(size=(N, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    lines = ['description = "a big ring"', "[sim]", "t_final_s = 0.02", "dt_s = 0.01", "record_interval_s = 0.01"]
    for k in range(N):
        lines += ["[[spacecraft]]", "inertia_kgm2 = [1, 1.2, 0.9]", "q_bi = [" + ", ".join(f"{v:.4f}" for v in q[k]) + "]"]
    lines += ["[network]", 'kind = "ring"', *delivery, "[controller]", 'kind = "consensus-sync"', "period_s = 0.01",
              "alpha = 1.0", "beta = 2.0", "[actuators]", 'kind = "ideal-torque"']
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("delivery, field", [
    ([], "src"),
    (["[network.delivery]", 'kind = "delayed"', "delay_s = 0.02", "dropout_probability = 0.1"], "delay_periods"),
])
def test_a_ring_of_twenty_thousand_builds_without_a_dense_graph(tmp_path, delivery, field):
    path = _scenario(tmp_path / "ring.toml", delivery)
    script = (
        "import json, resource, numpy as np\n"
        "from coopsat.core import runtime\n"
        "from coopsat.scenarios.build import build\n"
        "from coopsat.scenarios.load import load_scenario\n"
        "runtime.enable()\n"
        f"scenario = load_scenario({str(path)!r})\n"
        "before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss\n"
        "built = build(scenario)\n"
        "grown = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before\n"
        f"shape = np.shape(getattr(built.system.network, {field!r}))\n"
        "print(json.dumps({'links': built.graphs[0].n_links, 'shape': shape, 'failed': [c.name for c in built.checks.values() if not c.ok], 'grown_gb': grown / 1024**2}))\n"
    )
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    out = json.loads(proc.stdout.splitlines()[-1])
    assert out["links"] == 2 * N  # the undirected ring: two links a spacecraft
    # The padded in-neighbour table of a ring (ideal), or one row of delays per graph (delayed).
    assert out["shape"] == ([2, N] if field == "src" else [1, 2, N])
    assert out["failed"] == []  # the ring has a spanning tree; the sampled-data check is skipped at this size
    assert out["grown_gb"] < DENSE_GB / 8, out  # far below one adjacency; the build itself is a few hundred MB
