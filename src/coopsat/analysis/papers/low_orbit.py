"""The low-orbit environment (``gravity-field``, ``drag``, ``third-body``, and solar radiation
pressure about the Earth): what it did to the formation along the orbit.

* ``air_density_mean_kg_m3``, ``air_density_max_kg_m3``: over the spacecraft and the samples
  (drag only).
* ``eclipse_fraction``: the mean over the samples of ``1 − sunlight_fraction`` for the first
  spacecraft (radiation pressure only; the penumbra counts by its fraction).
* ``along_track_drift_max_m``: the largest change over the run of a spacecraft's along-track
  position relative to the first, the first's LVLH frame (truth; two or more spacecraft). It is
  the drift differential drag causes when nothing keeps the formation.

The series ``relative_position_lvlh`` is every spacecraft's true position relative to the first,
in the first's LVLH frame (x along-track, y against the orbit normal, z to nadir).
"""

import numpy as np

FIGURES = "coopsat.plots.low_orbit"
"""Module with the environment-along-the-orbit and relative-motion figures."""


def relative_position_lvlh(r_eci, v_eci):
    """Each spacecraft's true position relative to the first, its LVLH frame, (T, n, 3) m.

    Parameters
    ----------
    r_eci, v_eci : (T, n, 3)
        Truth, m and m/s, ECI.
    """
    from coopsat.geometry.frames import eci_to_lvlh

    return np.asarray(eci_to_lvlh(r_eci[:, :1], v_eci[:, :1], r_eci, v_eci)[0])


def lvlh_series(values_m, what):
    """A (time, spacecraft, component) series in metres, in the first spacecraft's LVLH frame;
    ``what`` begins its long name."""
    import xarray as xr

    return xr.DataArray(values_m, dims=("time", "spacecraft", "component"), attrs={
        "units": "m", "long_name": f"{what}, the first spacecraft's LVLH frame (x along-track, y against the orbit "
                                   "normal, z to nadir)"})


def series(ds, built):
    """``relative_position_lvlh`` (time, spacecraft, component), m, for two or more spacecraft."""
    if ds.sizes["spacecraft"] < 2:
        return {}
    rho = relative_position_lvlh(ds["r_eci"].values, ds["v_eci"].values)
    return {"relative_position_lvlh": lvlh_series(rho, "true position relative to the first spacecraft")}


def metrics(ds, built):
    m = {}
    if "air_density" in ds:
        rho = ds["air_density"].values
        m["air_density_mean_kg_m3"] = float(rho.mean())
        m["air_density_max_kg_m3"] = float(rho.max())
    if "sunlight_fraction" in ds:
        m["eclipse_fraction"] = float(1.0 - ds["sunlight_fraction"].values[:, 0].mean())
    if ds.sizes["spacecraft"] >= 2:
        rel = ds["relative_position_lvlh"].values if "relative_position_lvlh" in ds else series(ds, built)[
            "relative_position_lvlh"].values
        m["along_track_drift_max_m"] = float(np.abs(rel[:, :, 0] - rel[0, :, 0]).max())
    return m
