"""pdmkit.models: dynamic models, starting with the pneumatic-piston digital twin.

The double-acting pneumatic piston of the seed thesis (chapters 3-4, 8): valve mass flows
with the outflow function, 5/2 solenoid valve, adiabatic chambers, a supply reservoir,
gravity, friction, hard stops, end dampers and chamber air leaks, plus models of the
fifteen sensors of the demonstration device. One right-hand side (:func:`rhs`) drives a
batched fixed-step integrator (:func:`simulate`; numpy, or torch with autograd) and a
``solve_ivp`` reference (:func:`simulate_ivp`).

Examples
--------
>>> from pdmkit.models import PneumaticParams, simulate
>>> r = simulate(PneumaticParams(), t_end=0.5, seed=0)
>>> round(float(r.states["position"][0, -1]), 3)
0.16
"""

from pdmkit.models._estimate import EstimationResult, estimate_parameters
from pdmkit.models._integrate import simulate, simulate_ivp
from pdmkit.models._pneumatic import (
    STATE_NAMES,
    PneumaticParams,
    initial_state,
    orifice_mass_flow,
    outflow_function,
    rhs,
    stack_params,
    valve_command,
)
from pdmkit.models._response import PneumaticResponse, ResponseData
from pdmkit.models._sensors import (
    SENSOR_NAMES,
    SENSOR_UNITS,
    SensorSpec,
    default_sensor_specs,
)

__all__ = [
    "SENSOR_NAMES",
    "SENSOR_UNITS",
    "STATE_NAMES",
    "EstimationResult",
    "PneumaticParams",
    "PneumaticResponse",
    "ResponseData",
    "SensorSpec",
    "default_sensor_specs",
    "estimate_parameters",
    "initial_state",
    "orifice_mass_flow",
    "outflow_function",
    "rhs",
    "simulate",
    "simulate_ivp",
    "stack_params",
    "valve_command",
]
