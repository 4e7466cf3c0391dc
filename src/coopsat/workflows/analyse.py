"""A finished run's metrics and comparison rows (:func:`analyse`), and every run's of a batch
at once (:func:`analyse_batch`): the generic metrics (:mod:`coopsat.analysis.metrics`), then
each paper module's (:mod:`coopsat.analysis.papers`), each stage guarded
(:func:`~coopsat.analysis.stages.guarded`)."""

import numpy as np

from coopsat.analysis.compare import compare_published
from coopsat.analysis.metrics import attitude_moves, batch_run_metrics, records_torque, run_metrics, run_rows
from coopsat.analysis.papers import explainers, paper_batch_metrics, paper_metrics
from coopsat.analysis.stages import guarded
from coopsat.scenarios.build import inertia_matrix


def analyse(built, ds, compare=True, failures=None):
    """Metrics and comparison rows (empty unless ``compare``) of a finished run.

    ``failures``: a list to which each stage that raises is appended as a
    :class:`~coopsat.analysis.stages.StageFailure` (its numbers left out); None: it raises.
    """
    sc = built.scenario
    inertia, h_wheels = _bodies(built)
    common = guarded(failures, "metrics", "coopsat", {}, run_metrics, ds, built.names, inertia, h_wheels,
                     _attitude_moves(ds, built))
    metrics = {**built.design_metrics, **common, **paper_metrics(ds, built, failures)}
    if not compare:
        return metrics, []
    note = "; ".join(built.warnings) or None
    rows = guarded(failures, "comparison", "coopsat", [], compare_published, sc.published, metrics, note,
                   sc.sim.t_final_s, explainers(built, failures))
    return metrics, rows


def analyse_batch(builds, ds, failures=None):
    """:func:`analyse`'s metrics (no comparison) of every run of a batch, one dict per run, the
    numbers computed over the whole batch at once (a paper module without ``batch_metrics``
    run by run: :func:`~coopsat.analysis.papers.paper_batch_metrics`).

    Parameters
    ----------
    builds : sequence of Built
        Each run's build, one structure (:func:`coopsat.workflows.sweep.group_runs`).
    ds : xarray.Dataset
        Their record, dimension ``run`` first, without the paper modules' derived series
        (:func:`coopsat.workflows.sweep.batch_record`).
    failures : list, optional
        As :func:`analyse`.
    """
    inertia, h_wheels = (np.stack(a) for a in zip(*(_bodies(b) for b in builds)))
    torqued = records_torque(ds)  # the batch's structure: once, not per run
    moves = np.array([torqued or _attitude_moves(ds, b) for b in builds])
    rows = [dict(b.design_metrics) for b in builds]
    for flag in np.unique(moves):  # a run that starts at rest untorqued has no rate metrics
        idx = np.flatnonzero(moves == flag)
        part = ds if idx.size == len(builds) else ds.isel(run=idx)
        common = guarded(failures, "metrics", "coopsat", None, lambda: run_rows(
            batch_run_metrics(part, builds[0].names, inertia[idx], h_wheels[idx], bool(flag)), idx.size))
        for r, values in zip(idx, common or ()):
            rows[r].update(values)
    for row, paper in zip(rows, paper_batch_metrics(ds, builds, failures)):
        row.update(paper)
    return rows


def _bodies(built):
    """Inertia (n, 3, 3) and wheel momenta (n, 3) of a run's spacecraft, from its scenario."""
    spacecraft = built.scenario.spacecraft
    return (np.stack([inertia_matrix(s.inertia_kgm2) for s in spacecraft]),
            np.array([s.h_wheels_b_nms for s in spacecraft], dtype=float))


def _attitude_moves(ds, built):
    # From the scenario's initial state, not the record's: metric_names' stand-in record is zeros.
    spacecraft = built.scenario.spacecraft
    return attitude_moves(ds, [s.omega_b_rad_s for s in spacecraft], [s.angle_rad for s in spacecraft])
