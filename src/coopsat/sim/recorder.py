"""Engine output to a labelled :class:`xarray.Dataset` (dims time, spacecraft, component, …).

Each sample's name, dimensions, units and frame come from the part that produced it
(:class:`coopsat.core.parts.OutputSpec`), so a new plug-in's outputs need no change here.

Saved as netCDF-4 (h5netcdf), the dataset reads in Python (xarray), MATLAB (``ncread``) and
Julia without this package. Each variable carries ``units`` and ``long_name``; vectors carry
the frame of their components in ``frame``.
"""

import numpy as np


def to_dataset(output, names, attrs, specs, batched=False):
    """Wrap a :class:`~coopsat.sim.engine.RunOutput` in an :class:`xarray.Dataset`.

    Parameters
    ----------
    output : RunOutput
    names : sequence of str
        Spacecraft names.
    attrs : dict
        Global attributes (scenario TOML, seed, version, design checks…); values must be
        str, int or float.
    specs : dict of str -> coopsat.core.parts.OutputSpec
        How each sample appears (:func:`coopsat.sim.engine.output_specs`).
    batched : bool
        Samples carry a leading ``run`` axis.

    Returns
    -------
    xarray.Dataset
    """
    import xarray as xr

    lead = ("run", "time") if batched else ("time",)
    data_vars = {}
    coords = {
        "time": ("time", output.t_s, {"units": "s", "long_name": "time since start of run"}),
        "spacecraft": ("spacecraft", list(names)),
        "component": ("component", ["x", "y", "z"]),
        "q_component": ("q_component", ["q0", "q1", "q2", "q3"]),
    }
    for key, value in output.samples.items():
        if key not in specs:
            raise KeyError(f"engine produced an output '{key}' that no part describes")
        spec = specs[key]
        var_attrs = {"units": spec.units, "long_name": spec.long_name}
        if spec.frame:
            var_attrs["frame"] = spec.frame
        dims = lead + (("spacecraft",) if spec.per_spacecraft else ()) + spec.dims
        data_vars[key] = (dims, np.asarray(value), var_attrs)
        for dim, labels in spec.coords:
            coords[dim] = (dim, list(labels))
    return xr.Dataset(data_vars, coords=coords, attrs=dict(attrs))


def to_datasets(output, names, attrs, specs):
    """One :class:`xarray.Dataset` per run of a batched :class:`~coopsat.sim.engine.RunOutput`
    (samples ``(runs, time, ...)``), each what :func:`to_dataset` gives for that run alone.

    The first is made by :func:`to_dataset`; the others are shallow copies of it with their own
    data and attributes, which skip building the coordinates and their indexes again (0.2 ms a
    run instead of 1.9 ms for consensus-sync-a-stable).

    Parameters
    ----------
    attrs : sequence of dict
        Each run's global attributes.
    """
    from coopsat.sim.engine import RunOutput

    runs = len(attrs)
    first = to_dataset(RunOutput(output.t_s, {k: v[0] for k, v in output.samples.items()}, 0.0, 0.0), names, attrs[0], specs)
    out = [first]
    for i in range(1, runs):
        ds = first.copy(deep=False, data={k: np.asarray(v[i]) for k, v in output.samples.items()})
        ds.attrs = dict(attrs[i])
        out.append(ds)
    return out
