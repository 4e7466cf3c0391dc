"""Recorded plant quantities: how the state appears in a run's dataset.

The parts (controllers, actuators, sensors, …) describe their own outputs
(``output_specs()``); this module describes the plant's.
"""

from coopsat.core.parts import OutputSpec

_STATE_OUTPUTS = {
    "q": OutputSpec(("q_component",), "1", "", "attitude quaternion of body relative to inertial, scalar first"),
    "angle": OutputSpec(("component",), "rad", "body", "small attitude angles about the body axes (small-angle model)"),
    "omega": OutputSpec(("component",), "rad/s", "body", "body angular rate relative to inertial"),
    "h_wheels": OutputSpec(("component",), "N m s", "body", "angular momentum of the wheels relative to the body"),
    "r_eci": OutputSpec(("component",), "m", "ECI", "position"),
    "v_eci": OutputSpec(("component",), "m/s", "ECI", "velocity"),
}


def state_output_specs(quantities):
    """Specs of the recorded state quantities (:func:`coopsat.dynamics.plant.state_quantities`).

    Returns
    -------
    dict of str -> OutputSpec
    """
    return {k: _STATE_OUTPUTS[k] for k in quantities}


def measured_output_spec(quantity):
    """Spec of a sensor's reading of a state quantity (``"q"``, ``"omega"``, …): the
    quantity's own dims, units and frame.

    Returns
    -------
    OutputSpec
    """
    spec = _STATE_OUTPUTS[quantity]
    return spec._replace(long_name=f"{spec.long_name}, as measured by its sensor at the sample")
