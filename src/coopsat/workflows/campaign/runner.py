"""Running a campaign on Dask: batches of runs as tasks, one Parquet file per finished batch.

Run ids ``0 … runs−1`` are cut into batches of ``batch_size``; a task runs one batch
(:func:`run_batch_rows`): each run's values are drawn from its own seed sequence, its scenario
built (an invalid dispersed scenario fails that run alone), the valid runs of one compiled
structure simulated as one vmapped call, and every run's metrics computed as ``coopsat run``
computes them. A batch in which a run turns non-finite is run again one run at a time, so the
poisoned run fails alone. The driver writes each finished batch as
``batches/batch_NNNNNN.parquet`` (written beside, then renamed: a file there is complete), so
``campaign run`` on an existing folder skips the batches that are there: nothing is run twice
or lost, even after SIGKILL. SIGINT or SIGTERM stops the campaign when the next batch finishes
(it is written first; status 130 or 143, the last line saying how many batches the folder
holds); the local workers ignore both, so that a Ctrl-C, which reaches the whole process group,
stops them only through the driver. Each batch's Parquet file also records what decided its
bits on the worker that ran it (:mod:`~coopsat.workflows.campaign.provenance`), which
:func:`replay` reproduces or names.
"""

import contextlib
import gc
import json
import os
import re
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np

from coopsat.core.progress import progress_bar
from coopsat.workflows import interrupt
from coopsat.workflows.campaign.batch import batch_builds, batch_models, batch_series
from coopsat.workflows.campaign.provenance import batch_provenance, compare, read_provenance, summary_line, to_metadata
from coopsat.workflows.campaign.spec import (
    Campaign,
    CampaignError,
    bundled_campaign,
    load_campaign,
)

MARKER = "campaign.json"
"""Written into every campaign folder first: what is being run (a resumed run must match it)."""

CALLS = "calls.json"
"""The wall time of every call of ``campaign run`` that wrote batches into the folder (one
killed by SIGKILL leaves none)."""


def batch_ids(runs, batch_size):
    """Run ids of every batch: ``[[0 … b−1], [b … 2b−1], …]``."""
    return [list(range(s, min(s + batch_size, runs))) for s in range(0, runs, batch_size)]


def batch_file(out_dir, b):
    return Path(out_dir) / "batches" / f"batch_{b:06d}.parquet"


def make_job(campaign_path):
    """Everything a worker needs to run any batch, as plain data: the campaign, the scenario
    as resolved TOML text (``extends`` and the campaign's ``overrides`` applied) and the
    dispersed paths. Workers need neither the files nor a shared disk, and a stored job
    replays a run after the files have changed.

    Returns
    -------
    dict
        ``campaign`` (the validated file as a dict), ``scenario_toml``, ``fields``.
    """
    from coopsat.scenarios.load import load_scenario, resolved_toml

    campaign, ref, fields = load_campaign(campaign_path)
    return {"campaign": campaign.model_dump(), "scenario_toml": resolved_toml(load_scenario(ref, campaign.overrides)),
            "fields": fields}


def run_batch_rows(campaign_path, run_ids):
    """One row (dict) per run of a batch of a campaign file (:func:`run_batch`'s rows)."""
    return run_batch(make_job(campaign_path), run_ids)[0]


def run_batch(job, run_ids, native=None):
    """Run one batch: one row (dict) per run — ``run_id``, ``status`` ("ok" or "failed"),
    ``reason``, ``seed``, ``params`` (JSON of the applied values), then every metric — the
    campaign's ``timeseries`` of the ok runs (an xarray Dataset with a ``run`` dimension, or
    None), and the batch's provenance (:func:`~coopsat.workflows.campaign.provenance.
    batch_provenance`: what decides its bits, taken in this process). Executed on a Dask
    worker; never raises for a failing run. ``native``: as :func:`coopsat.sim.engine.simulate`
    (a replay takes the path the batch took).

    Raises
    ------
    NativeUnavailableError
        ``native`` is True and the kernels cannot run in this process.
    """
    from coopsat.sim.engine import NonFiniteStateError
    from coopsat.workflows.sweep import analysed_runs

    t0 = time.perf_counter()
    campaign = Campaign.model_validate(job["campaign"])
    rows, models, where = batch_models(job, campaign, run_ids)
    builds, stacked, note, where = batch_builds(job, models, where, rows)
    series = {}
    # Taken here, on the worker that runs the batch, before it runs: it decides the native
    # kernels' path for the whole batch (the probe, if any, runs now).
    provenance = batch_provenance(builds, run_ids, native, note)
    seconds = {"compile": 0.0, "simulate": 0.0}

    def finish(ids, blds):
        # One device whatever the machine, so that a run's stored result (and its replay) does
        # not depend on how many cores the worker had; groups padded to recurring sizes, so
        # that a worker compiles each structure a few times, not once per batch.
        # Each run's dataset made only when the campaign keeps its timeseries.
        metrics, datasets, compile_s, run_s = analysed_runs(
            blds, datasets=bool(campaign.timeseries), every_core=False, bucket=campaign.batch_size, native=native,
            stacked=stacked if len(blds) == len(builds) else None)
        seconds["compile"] += compile_s
        seconds["simulate"] += run_s
        for k, m, ds in zip(ids, metrics, datasets):
            rows[k].update({name: _scalar(v) for name, v in m.items()})
            if campaign.timeseries:
                series[k] = ds[campaign.timeseries].isel(time=slice(None, None, campaign.decimate))

    try:
        finish(where, builds)
    except NonFiniteStateError:
        for k, b in zip(where, builds):  # one at a time: only the poisoned run fails
            try:
                finish([k], [b])
            except NonFiniteStateError as err:
                # The engine counts runs within the batch it ran (here a batch of one).
                rows[k].update(status="failed", reason=re.sub(r"^(state became non-finite: )run \d+, ", r"\1", str(err)))
    # Not what decides the bits, but where the batch's time went (benchmarks/campaign_throughput.py).
    provenance["seconds"] = {**seconds, "total": time.perf_counter() - t0}
    return [rows[k] for k in run_ids], batch_series(series, run_ids), provenance


def _scalar(v):
    return None if v is None else float(v)


def series_file(out_dir, b):
    return Path(out_dir) / "timeseries" / f"batch_{b:06d}.zarr"


def write_batch(out_dir, b, rows, series=None, provenance=None):
    """Write one batch: its time series (Zarr, when kept) first, then its rows as Parquet,
    each atomically (written beside, renamed into place), its ``provenance`` (when given) in
    the Parquet file's key-value metadata (:mod:`~coopsat.workflows.campaign.provenance`). The
    Parquet file is the batch's completion mark: when it exists, so does everything else of
    the batch.

    Raises
    ------
    CampaignError
        When the disk refuses the batch (full, read-only, quota): the half-written files are
        removed, so the folder holds only complete batches and resumes once there is room.
    """
    import shutil

    import pyarrow as pa
    import pyarrow.parquet as pq

    names = list(dict.fromkeys(k for r in rows for k in r))
    table = pa.table({k: [r.get(k) for r in rows] for k in names})
    if provenance is not None:
        table = table.replace_schema_metadata(to_metadata(provenance))
    path = batch_file(out_dir, b)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp_dir = None
    try:
        if series is not None:
            target = series_file(out_dir, b)
            target.parent.mkdir(exist_ok=True)
            tmp_dir = target.with_name(f".{target.name}.{os.getpid()}.tmp")
            shutil.rmtree(tmp_dir, ignore_errors=True)
            series.to_zarr(tmp_dir, mode="w", consolidated=False)
            shutil.rmtree(target, ignore_errors=True)  # a leftover of a killed run of this batch
            os.replace(tmp_dir, target)
        pq.write_table(table, tmp)
        os.replace(tmp, path)
    except OSError as err:
        tmp.unlink(missing_ok=True)
        if tmp_dir is not None:
            shutil.rmtree(tmp_dir, ignore_errors=True)
        done = sum(1 for _ in Path(out_dir, "batches").glob("batch_*.parquet"))
        raise CampaignError(
            f"cannot write batch {b} in {out_dir}: {err.strerror or err}; the {done} batches on disk are complete "
            "(free space, then run the same command to resume)"
        ) from err


def read_series(out_dir):
    """Every stored time series of a campaign folder, concatenated over runs (xarray), or None."""
    import xarray as xr

    stores = sorted((Path(out_dir) / "timeseries").glob("batch_*.zarr"))
    stores = [s for s in stores if batch_file(out_dir, int(s.stem.split("_")[1])).is_file()]
    if not stores:
        return None
    return xr.concat([xr.open_zarr(s, consolidated=False).load() for s in stores], dim="run")


def read_results(out_dir):
    """Every finished run of a campaign folder as a pandas-free dict of columns (pyarrow Table)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    files = sorted((Path(out_dir) / "batches").glob("batch_*.parquet"))
    if not files:
        return pa.table({})
    return pa.concat_tables([pq.read_table(f) for f in files], promote_options="default")


def _check_timeseries(campaign, ref):
    """Every output named in ``timeseries`` is one the scenario records."""
    if not campaign.timeseries:
        return
    from coopsat.workflows.pipeline import prepare
    from coopsat.scenarios.load import load_scenario
    from coopsat.sim.engine import output_specs

    known = set(output_specs(prepare(load_scenario(ref, campaign.overrides)).system))
    unknown = [name for name in campaign.timeseries if name not in known]
    if unknown:
        raise CampaignError(f"timeseries: '{unknown[0]}' is not recorded by this scenario (recorded: {', '.join(sorted(known))})")


def _check_folder(out_dir, job):
    """Refuse an existing folder that is not a campaign folder, or holds another campaign."""
    out_dir = Path(out_dir)
    marker = out_dir / MARKER
    if out_dir.exists():
        if not marker.is_file():
            raise CampaignError(f"{out_dir}: exists and is not a campaign folder (no {MARKER}); choose another")
        old = json.loads(marker.read_text())
        if (old["campaign"], old["scenario_toml"]) != (job["campaign"], job["scenario_toml"]):
            raise CampaignError(f"{out_dir}: holds another campaign (a different file, settings or scenario); "
                                "choose another folder")


def _start_folder(out_dir, campaign_path, job):
    """Create the folder with its marker (nothing to do when it exists: :func:`_check_folder`)."""
    out_dir = Path(out_dir)
    marker = out_dir / MARKER
    if marker.is_file():
        return
    spec = {**job, "campaign_file": str(Path(campaign_path).resolve())}
    (out_dir / "batches").mkdir(parents=True, exist_ok=True)
    tmp = marker.with_name(f".{MARKER}.tmp")
    tmp.write_text(json.dumps(spec, indent=2) + "\n")
    os.replace(tmp, marker)


def client_for(workers=None, scheduler=None, connect_timeout_s=5.0):
    """A Dask client: an existing scheduler at ``scheduler`` (tcp://host:port), else a
    LocalCluster of ``workers`` processes with one thread each.

    Raises
    ------
    CampaignError
        When the scheduler cannot be reached within ``connect_timeout_s``.
    """
    from dask.distributed import Client, LocalCluster

    if scheduler:
        try:
            return Client(scheduler, timeout=f"{connect_timeout_s}s")
        except (OSError, TimeoutError) as err:
            raise CampaignError(f"scheduler {scheduler}: cannot reach it within {connect_timeout_s:g} s ({type(err).__name__})") from None
    # Port 0: a dashboard on any free port (None still binds 8787, and warns when it is taken).
    from coopsat.core import runtime

    # Workers are processes coopsat starts, so they get the CLI's settings (XLA's CPU options,
    # the compilation cache) through their environment; one worker per core already, so each
    # runs its batches on one CPU device.
    cluster = LocalCluster(n_workers=workers or 1, threads_per_worker=1, processes=True, dashboard_address="127.0.0.1:0",
                           env=runtime.process_environment(cpu_devices=1))
    client = Client(cluster)
    client.run(_leave_signals_to_the_driver)
    return client


def _leave_signals_to_the_driver():
    """Ignore SIGINT and SIGTERM in a local worker (run on each): a Ctrl-C reaches the whole
    process group, and a worker that died of it would print its traceback; the driver stops
    at its next batch and closes the workers itself (:mod:`coopsat.workflows.interrupt`)."""
    import signal

    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, signal.SIG_IGN)


def run_campaign(campaign_path, out_dir, workers=None, scheduler=None, progress=False):
    """Run (or resume) a campaign into ``out_dir``.

    Returns
    -------
    dict
        ``runs``, ``batches``, ``skipped_batches`` (already on disk), ``failed`` (runs),
        ``wall_s``, ``worker_peak_rss_mb`` (the largest worker's peak memory; None when
        nothing ran), ``build_notes`` (how the batches of this call built their runs, each
        distinct line once: :func:`coopsat.workflows.sweep.build_runs`), ``worker_s`` (the
        workers' seconds summed over the batches of this call: ``compile``, ``simulate``, and
        ``total`` of the batch tasks).
    """
    campaign_path = bundled_campaign(campaign_path)
    campaign, ref, _ = load_campaign(campaign_path)
    _check_timeseries(campaign, ref)
    job = make_job(campaign_path)
    _check_folder(out_dir, job)
    batches = batch_ids(campaign.runs, campaign.batch_size)
    todo = [b for b in range(len(batches)) if not batch_file(out_dir, b).is_file()]
    t0 = time.perf_counter()
    failed, peak_mb, notes, worker_s = 0, None, {}, {}
    if todo:
        from dask.distributed import as_completed

        bar, written = None, 0
        client = client_for(workers, scheduler)  # before the folder: an unreachable scheduler leaves nothing
        try:
            interrupt.check()  # a stop while the workers started: nothing written
            _start_folder(out_dir, campaign_path, job)
            on_disk = len(batches) - len(todo)
            interrupt.wrote(out_dir, _resume_note(out_dir, on_disk, len(batches)))
            if progress:
                bar = progress_bar(campaign.runs, "campaign", "runs",
                                   initial=campaign.runs - sum(len(batches[b]) for b in todo))
            shared = client.scatter(job, broadcast=True)
            futures = {client.submit(run_batch, shared, batches[b], key=f"batch-{b}-{time.time_ns()}", pure=False): b for b in todo}
            for future in as_completed(futures):
                # Dropping our reference lets the worker free the batch's result once written:
                # a campaign larger than memory streams to disk instead of piling up.
                b = futures.pop(future)
                rows, series, provenance = future.result()
                notes[_build_kind(provenance["build"])] = None
                for name, value in provenance["seconds"].items():
                    worker_s[name] = worker_s.get(name, 0.0) + value
                with interrupt.holding():  # a finished batch is written whole, even after a signal
                    write_batch(out_dir, b, rows, series, provenance)
                    on_disk += 1
                    written += 1
                    interrupt.wrote(out_dir, _resume_note(out_dir, on_disk, len(batches)))
                failed += sum(r["status"] != "ok" for r in rows)
                if bar is not None:
                    bar.update(len(rows))
                interrupt.check()  # a stop: the batches on disk are complete, the others wait for a resume
            peak_mb = max(client.run(_peak_rss_mb).values(), default=None)
        finally:
            if bar is not None:
                bar.close()
            _close(client)
            if written:
                _record_call(out_dir, time.perf_counter() - t0, written)
    return {"runs": campaign.runs, "batches": len(batches), "skipped_batches": len(batches) - len(todo), "failed": failed,
            "wall_s": time.perf_counter() - t0, "worker_peak_rss_mb": peak_mb, "build_notes": list(notes),
            "worker_s": worker_s}


def _build_kind(note):
    """A batch's build note without its run count, so that batches built alike say it once."""
    return re.sub(r"^\d+ runs built once", "runs built once", note)


def _record_call(out_dir, wall_s, batches):
    """Add a call of :func:`run_campaign` (its wall time, s, and the batches it wrote) to the
    folder's :data:`CALLS`, which the report sums; written beside and renamed into place."""
    path = Path(out_dir) / CALLS
    # A note for the report: a disk that refuses it must not hide the campaign's own outcome
    # (a full disk's one-line error, a stop), and a damaged file only loses the earlier notes.
    with contextlib.suppress(OSError, ValueError):
        calls = json.loads(path.read_text()) if path.is_file() else []
        tmp = path.with_name(f".{CALLS}.{os.getpid()}.tmp")
        tmp.write_text(json.dumps([*calls, {"wall_s": wall_s, "batches": batches}], indent=1) + "\n")
        os.replace(tmp, path)


def read_calls(out_dir):
    """The recorded calls of a campaign folder (:func:`_record_call`): list of dicts with
    ``wall_s`` and ``batches``; empty when none was recorded (a folder from before they were)."""
    path = Path(out_dir) / CALLS
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return []


def _resume_note(out_dir, on_disk, total):
    """What the last line of a stopped campaign says of its folder (:func:`interrupt.wrote`),
    ``on_disk`` of its ``total`` batches being there."""
    if on_disk == total:
        return f"the folder {out_dir} is complete ({total} batches)"
    return f"the folder {out_dir} holds {on_disk} of {total} batches, each complete (the same command resumes the campaign)"


def _close(client):
    """Close ``client`` and, when it started one, its LocalCluster, letting the workers exit
    on their own.

    A worker process that has run batches holds a few hundred thousand Python objects (JAX's
    traces and caches), and the interpreter's collections at exit walk them all: seconds under
    load, past the 4 s after which the nanny kills the process and warns ("Worker process still
    alive after 4.0 seconds, killing"). Frozen objects (:func:`gc.freeze`) are skipped by those
    collections; memory is given back when the process ends either way.

    Closing is ours, so what the workers and their nannies log while it happens (a batch in
    flight after a stop cancelled, a heartbeat to a scheduler already gone, with its traceback)
    is not news: their ``distributed`` loggers are turned down to CRITICAL first."""
    cluster = client.cluster
    if cluster is not None:
        with contextlib.suppress(Exception):  # a worker that is already gone needs no help
            client.run(gc.freeze)
            client.run(_quiet_distributed_logs)
            client.run(_quiet_distributed_logs, nanny=True)
    client.close()
    if cluster is not None:
        cluster.close()


def _quiet_distributed_logs():
    """Only CRITICAL records from dask.distributed in this process (run on every worker and
    nanny before the driver closes them)."""
    import logging

    logging.getLogger("distributed").setLevel(logging.CRITICAL)


def _peak_rss_mb():
    """This process's peak resident memory, MB (run on every worker)."""
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


class Replay(NamedTuple):
    """A stored run replayed (:func:`replay`)."""

    stored: dict
    """The run's stored row."""
    replayed: dict
    """The same row computed again."""
    identical: bool
    """Every number of the two rows equal bit for bit."""
    stored_provenance: dict | None
    """What decided the batch's bits where it ran (None: a batch written before it was recorded)."""
    replayed_provenance: dict
    """The same in this process, as the replay ran."""
    provenance_differences: tuple[str, ...]
    """The fields deciding bits that differ, each ``field (stored …, here …)``; empty when none does."""
    tolerance: str | None
    """The agreement that then applies; None when bit for bit is expected."""

    @property
    def provenance_line(self):
        """One line on the provenance (:func:`~coopsat.workflows.campaign.provenance.summary_line`)."""
        return summary_line(self.stored_provenance, self.provenance_differences, self.tolerance)

    @property
    def report_lines(self):
        """What ``coopsat campaign replay`` prints: the verdict, each differing figure, the
        provenance line."""
        k = self.stored["run_id"]
        lines = [f"run {k}: {'identical to the stored result, bit for bit' if self.identical else 'DIFFERS from the stored result'}"]
        lines += [f"  {name}: stored {value!r}, replayed {self.replayed.get(name)!r}" for name, value in self.stored.items()
                  if name not in ("run_id", "params") and value != self.replayed.get(name)]
        return [*lines, self.provenance_line]


def replay(out_dir, run_id):
    """Run one stored run again — with the rest of its batch, as it first ran — from the job
    stored in the folder (not the files, which may have changed), and compare its metrics with
    the stored ones.

    The batch's stored provenance (:mod:`~coopsat.workflows.campaign.provenance`) decides how:
    its runs in their order, and the native kernels on or off as where it ran (a Dask worker
    may have chosen otherwise than this process). What cannot be reproduced here (another jax,
    another CPU family) is named in :attr:`Replay.provenance_differences`, with the agreement
    that then applies.

    Returns
    -------
    Replay
    """
    from coopsat.sim.native.capability import NativeUnavailableError

    out_dir = Path(out_dir)
    marker = out_dir / MARKER
    if not marker.is_file():
        raise CampaignError(f"{out_dir}: not a campaign folder (no {MARKER})")
    spec = json.loads(marker.read_text())
    table = read_results(out_dir)
    if table.num_rows == 0 or run_id not in set(table.column("run_id").to_pylist()):
        raise CampaignError(f"run {run_id}: not among the finished runs of {out_dir}")
    stored = next(r for r in table.to_pylist() if r["run_id"] == run_id)
    c = Campaign.model_validate(spec["campaign"])
    b = run_id // c.batch_size
    before = read_provenance(batch_file(out_dir, b))
    # The whole batch the run was stored from, as it ran: XLA's program for a batch of one can
    # differ from the batch's in the last bit.
    ids = before["run_ids"] if before else batch_ids(c.runs, c.batch_size)[b]
    job = {k: spec[k] for k in ("campaign", "scenario_toml", "fields")}
    try:
        rows, _, here = run_batch(job, ids, native=before["native"] if before else None)
    except NativeUnavailableError:
        # The batch ran with the kernels and they cannot run here: XLA's path, its difference
        # reported with the agreement that applies.
        rows, _, here = run_batch(job, ids, native=False)
    replayed = rows[ids.index(run_id)]
    keys = [k for k in stored if k not in ("run_id",)]
    identical = all(_same(stored.get(k), replayed.get(k)) for k in keys)
    differences, tolerance = compare(before, here) if before else ((), None)
    return Replay(stored, replayed, identical, before, here, differences, tolerance)


def _same(a, b):
    if isinstance(a, float) and isinstance(b, float):
        return np.float64(a).tobytes() == np.float64(b).tobytes() or (np.isnan(a) and np.isnan(b))
    return a == b
