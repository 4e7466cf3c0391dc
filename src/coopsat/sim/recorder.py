"""Engine output to a labelled :class:`xarray.Dataset` (dims time, spacecraft, component, …).

Saved as netCDF-4 (h5netcdf), the dataset reads in Python (xarray), MATLAB (``ncread``) and
Julia without this package. Each variable carries ``units`` and ``long_name``; vectors carry
the frame of their components in ``frame``.
"""

import numpy as np

from coopsat.actuators.pwm import THRUSTER_NAMES

# engine sample key -> (variable name, dims after (time, spacecraft), units, frame, long name)
_VARIABLES = {
    "q_bi": ("q", ("q_component",), "1", "", "attitude quaternion of body relative to inertial, scalar first"),
    "omega_b": ("omega", ("component",), "rad/s", "body", "body angular rate relative to inertial"),
    "torque_nm": ("torque", ("component",), "N m", "body", "mean torque actually applied over the record interval starting at the sample (last sample: over the control period that would follow)"),
    "command_nm": ("torque_command", ("component",), "N m", "body", "torque commanded by the control law at the sample"),
    "impulse_nms": ("angular_impulse", ("component",), "N m s", "body", "cumulative signed angular impulse of the actuators per body axis, from t = 0 to the sample"),
    "abs_impulse_nms": ("impulse", ("component",), "N m s", "body", "cumulative absolute angular impulse per body axis (actuator effort), from t = 0 to the sample"),
    "thruster_on_time_s": ("thruster_on_time", ("thruster",), "s", "", "cumulative on-time of each thruster, from t = 0 to the sample"),
    "thruster_firings": ("thruster_firings", ("thruster",), "1", "", "cumulative number of firings (control periods with a pulse) of each thruster"),
    "r_eci": ("r_eci", ("component",), "m", "ECI", "position"),
    "v_eci": ("v_eci", ("component",), "m/s", "ECI", "velocity"),
}
_REFERENCE = {
    "q_ref": ("q_ref", ("q_component",), "1", "", "reference attitude quaternion, scalar first"),
}


def to_dataset(output, names, attrs, batched=False):
    """Wrap a :class:`~coopsat.sim.engine.RunOutput` in an :class:`xarray.Dataset`.

    Parameters
    ----------
    output : RunOutput
    names : sequence of str
        Spacecraft names.
    attrs : dict
        Global attributes (scenario TOML, seed, version, design checks…); values must be
        str, int or float.
    batched : bool
        Samples carry a leading ``run`` axis.

    Returns
    -------
    xarray.Dataset
    """
    import xarray as xr

    lead = ("run", "time") if batched else ("time",)
    data_vars = {}
    for key, value in output.samples.items():
        if key in _VARIABLES:
            name, dims, units, frame, long_name = _VARIABLES[key]
            full_dims = lead + ("spacecraft",) + dims
        elif key in _REFERENCE:
            name, dims, units, frame, long_name = _REFERENCE[key]
            full_dims = lead + dims
        else:
            raise KeyError(f"engine produced an unknown output '{key}'")
        var_attrs = {"units": units, "long_name": long_name}
        if frame:
            var_attrs["frame"] = frame
        data_vars[name] = (full_dims, np.asarray(value), var_attrs)
    coords = {
        "time": ("time", output.t_s, {"units": "s", "long_name": "time since start of run"}),
        "spacecraft": ("spacecraft", list(names)),
        "component": ("component", ["x", "y", "z"]),
        "q_component": ("q_component", ["q0", "q1", "q2", "q3"]),
    }
    if "thruster_on_time_s" in output.samples:
        coords["thruster"] = ("thruster", list(THRUSTER_NAMES))
    return xr.Dataset(data_vars, coords=coords, attrs=dict(attrs))
