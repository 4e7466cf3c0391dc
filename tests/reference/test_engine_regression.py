"""The plug-in engine reproduces the single-paper engine it replaced (issue 5).

The reference states were computed by the engine of commit f0d461c (tests/data/README.md):
the stable consensus runs over their whole length, the literal (chaotic) runs over 30 s.
"""

from pathlib import Path

import numpy as np
import pytest

from coopsat.workflows.pipeline import prepare, simulate_built
from coopsat.scenarios.load import load_scenario

DATA = np.load(Path(__file__).resolve().parents[1] / "data" / "engine_regression_f0d461c.npz")

CASES = [
    pytest.param("consensus-sync-a-stable", None, marks=pytest.mark.slow),
    pytest.param("consensus-sync-b-stable", None, marks=pytest.mark.slow),
    pytest.param("consensus-track-stable", None, marks=pytest.mark.slow),
    pytest.param("consensus-sync-link-failure", None, marks=pytest.mark.slow),
    ("consensus-sync-a", 30.0),
    ("consensus-sync-b", 30.0),
    ("consensus-track", 30.0),
]


@pytest.mark.parametrize("name, t_final_s", CASES)
def test_states_equal_the_previous_engine(name, t_final_s):
    overrides = [] if t_final_s is None else [f"sim.t_final_s={t_final_s}"]
    ds, _ = simulate_built(prepare(load_scenario(name, overrides)))
    t_ref = DATA[f"{name}/time"]
    step = max(1, (len(ds.time) - 1) // 100)
    np.testing.assert_array_equal(ds.time.values[::step], t_ref)
    np.testing.assert_allclose(ds.q.values[::step], DATA[f"{name}/q"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(ds.omega.values[::step], DATA[f"{name}/omega"], rtol=0, atol=1e-9)
