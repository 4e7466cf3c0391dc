"""Metrics definitions and the comparison rules, on hand-made inputs."""

import numpy as np
import pytest

from coopsat.analysis.compare import compare_published, comparison_markdown
from coopsat.analysis.papers.consensus_2010 import EXPLAINERS
from coopsat.analysis.metrics import (
    inertial_angular_momentum_nms,
    pairwise_attitude_error_deg,
    pairwise_rate_difference_rad_s,
    quat_angle_between_deg,
    settle_time_s,
)
from coopsat.scenarios.schema import Published


def _q_about_z(angle_deg):
    half = np.radians(angle_deg) / 2
    return np.array([np.cos(half), 0.0, 0.0, np.sin(half)])


def test_angle_between_attitudes_is_sign_invariant_and_exact_near_zero():
    assert quat_angle_between_deg(_q_about_z(30.0), _q_about_z(-15.0)) == pytest.approx(45.0, abs=1e-12)
    assert quat_angle_between_deg(_q_about_z(30.0), -_q_about_z(30.0)) == pytest.approx(0.0, abs=1e-12)
    assert quat_angle_between_deg(_q_about_z(1e-9), _q_about_z(0.0)) == pytest.approx(1e-9, rel=1e-6)


def test_pairwise_maxima():
    q = np.array([[_q_about_z(0.0), _q_about_z(10.0), _q_about_z(-5.0)]])
    assert pairwise_attitude_error_deg(q)[0] == pytest.approx(15.0, abs=1e-12)
    w = np.array([[[0.0, 0, 0], [0.0, 3, 0], [0.0, 0, 4]]])
    assert pairwise_rate_difference_rad_s(w)[0] == pytest.approx(5.0)
    assert pairwise_attitude_error_deg(q[:, :1])[0] == 0.0


def test_settle_time_needs_the_condition_to_hold_to_the_end_and_for_the_hold():
    t = np.arange(11.0)
    ok = np.array([0, 1, 1, 0, 1, 1, 1, 1, 1, 1, 1], bool)
    assert settle_time_s(t, ok) == 4.0
    assert settle_time_s(t, ok, hold_s=6.0) == 4.0
    assert settle_time_s(t, ok, hold_s=6.5) is None
    assert settle_time_s(t, ~ok) is None
    assert settle_time_s(t, np.ones(11, bool)) == 0.0


def test_angular_momentum_is_rotated_into_the_inertial_frame():
    q = np.array([[_q_about_z(90.0)]])
    w = np.array([[[1.0, 0.0, 0.0]]])
    h = inertial_angular_momentum_nms(q, w, np.diag([2.0, 1.0, 1.0])[None], np.array([[0.0, 0.5, 0.0]]))
    np.testing.assert_allclose(h, [[-0.5, 2.0, 0.0]], atol=1e-15)


def _entry(**kw):
    return Published(**{"quantity": "sync_time_s", "value": 250.0, "unit": "s", **kw})


def test_verdicts_follow_the_relation_and_tolerances():
    rows = compare_published(
        [_entry(), _entry(rel_tol=0.1), _entry(relation="greater"), _entry(relation="less"), _entry(value=0.0, abs_tol=300.0)],
        {"sync_time_s": 290.0},
    )
    assert [r["verdict"] for r in rows] == ["agrees", "differs", "agrees", "differs", "agrees"]
    assert "outside" in rows[1]["reason"]


def test_a_never_reached_quantity_differs_and_the_unstable_loop_is_named():
    metrics = {"sync_time_s": None, "pwm_deadband_torque_nm": 0.005, "final_attitude_spread_deg": 1.7}
    stable = compare_published([_entry(note="run at 0.01 s")], metrics, None, 400.0, EXPLAINERS)[0]
    assert stable["verdict"] == "differs" and "never settled within the run (400 s)" in stable["reason"]
    assert "minimum pulse" in stable["reason"] and stable["reason"].endswith("run at 0.01 s")
    unstable = compare_published([_entry()], {**metrics, "spectral_radius": 15.8}, "loop UNSTABLE", 400.0, EXPLAINERS)[0]
    assert "UNSTABLE" in unstable["reason"] and "minimum pulse" not in unstable["reason"]


def test_an_agreement_in_an_unstable_loop_says_so():
    row = compare_published([_entry()], {"sync_time_s": 250.0}, "loop UNSTABLE")[0]
    assert row["verdict"] == "agrees" and row["reason"].startswith("agrees, although loop UNSTABLE")


def test_markdown_table():
    rows = compare_published([_entry(relation="greater")], {"sync_time_s": None})
    md = comparison_markdown(rows, "demo")
    assert md.startswith("# demo") and "| sync_time_s | s | > 250 | never | **differs** |" in md
