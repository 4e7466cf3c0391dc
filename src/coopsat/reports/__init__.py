"""The interactive run report, ``report.html``: a 3D view of the formation, its network over
time and the run's time series on one time slider, with the published comparison, the
design-time checks and the metrics. One self-contained file that works offline
(docs/report.md).

:func:`report_html` makes the page from a built scenario and its record. ``coopsat run`` writes
it into every run folder and ``coopsat report RUN_DIR`` makes it again from ``result.nc``.
"""

from coopsat.reports.page import ReportError

__all__ = ["ReportError", "report_html"]


def report_html(built, ds, metrics, comparison):
    """The report page of one run.

    Parameters
    ----------
    built : coopsat.scenarios.build.Built
        The run's built scenario (its graphs, routes, design-time checks, ``[orbit]``).
    ds : xarray.Dataset
        The run's record (``result.nc``).
    metrics : dict of str -> float or None
    comparison : list of dict
        ``comparison.json``'s rows (empty without ``[[published]]`` numbers).

    Returns
    -------
    str
        The HTML page.
    """
    from coopsat.analysis.series import run_series
    from coopsat.reports import page
    from coopsat.reports.network_view import build_network_view
    from coopsat.reports.scene import build_scene

    scene = build_scene(ds, built.scenario.orbit)
    times = ds["time"].values[scene.frame_index]
    data = {
        "names": list(built.names),
        "times": page.packed(times),
        "scene": page.scene_json(scene),
        "network": page.network_json(build_network_view(built, ds), scene.frame_index),
        "series": page.series_json(run_series(ds, built.scenario.analysis)),
    }
    attrs = ds.attrs
    lines = [built.scenario.description or "",
             f"seed {attrs.get('seed', built.scenario.seed)} · coopsat {attrs.get('coopsat_version', '')} · "
             f"{attrs.get('created_utc', '')} · compile {float(attrs.get('compile_time_s', 0.0)):.2f} s, "
             f"run {float(attrs.get('run_time_s', 0.0)):.2f} s · {ds.sizes['time']} samples over "
             f"{float(ds['time'].values[-1]):g} s"]
    sections = [page.comparison_section(comparison), page.checks_section(built.checks), page.metrics_section(metrics)]
    return page.page_html(built.scenario.name, lines, data, sections, scene.note)
