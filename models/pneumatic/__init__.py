"""pdmkit.models.pneumatic: the double-acting pneumatic piston's digital twin.

The rig of the seed thesis (``001``, chapters 3-4 and 8): valve mass flows with the
outflow function, a 5/2 solenoid valve with meter-out throttle valves, adiabatic
chambers, a supply reservoir, gravity, friction, hard stops, end dampers and chamber
air leaks (:class:`PneumaticParams`, :func:`piston_rhs`); a batched fixed-step
integrator (:func:`simulate_piston`, numpy or torch with autograd) checked against
``solve_ivp`` (:func:`simulate_piston_ivp`); models of the demonstration device's
fifteen sensors (:class:`SensorSpec`, :func:`default_sensor_specs`); and batched
estimation of the twin's parameters from recordings (:func:`estimate_parameters`).

Examples
--------
>>> from pdmkit.models.pneumatic import PneumaticParams, simulate_piston
>>> r = simulate_piston(PneumaticParams(), t_end=0.5, seed=0)
>>> round(float(r.states["position"][0, -1]), 3)
0.16
"""

from pdmkit.models.pneumatic._estimate import EstimationResult, estimate_parameters
from pdmkit.models.pneumatic._integrate import (
    PneumaticResponse,
    simulate_piston,
    simulate_piston_ivp,
)
from pdmkit.models.pneumatic._sensors import (
    SENSOR_NAMES,
    SENSOR_UNITS,
    SensorSpec,
    default_sensor_specs,
)
from pdmkit.models.pneumatic._twin import (
    STATE_NAMES,
    PneumaticParams,
    initial_state,
    orifice_mass_flow,
    outflow_function,
    piston_rhs,
    stack_params,
    valve_command,
)

__all__ = [
    "SENSOR_NAMES",
    "SENSOR_UNITS",
    "STATE_NAMES",
    "EstimationResult",
    "PneumaticParams",
    "PneumaticResponse",
    "SensorSpec",
    "default_sensor_specs",
    "estimate_parameters",
    "initial_state",
    "orifice_mass_flow",
    "outflow_function",
    "piston_rhs",
    "simulate_piston",
    "simulate_piston_ivp",
    "stack_params",
    "valve_command",
]
