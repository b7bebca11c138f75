"""Physics of the double-acting pneumatic piston (seed 001, chapters 3, 4 and 8).

The model is written once, on plain array operations (see :mod:`pdmkit.models._xp`), and
runs on numpy arrays (fast batched path) and on torch tensors (differentiable path).

State vector (in this order, SI units)::

    position         x      m     piston position, 0 = bottom end, ``stroke`` = top end
    velocity         v      m/s   positive upwards (extension)
    pressure_a       p_A    Pa    absolute pressure of chamber A (cap end, below piston)
    pressure_b       p_B    Pa    absolute pressure of chamber B (rod end, above piston)
    pressure_supply  p_r    Pa    absolute pressure of the supply reservoir
    spool            s      -     5/2 valve spool position in [-1, 1] (+1: A filled)

Equations (seed numbering)

* outflow function psi (4.12-4.16, ISO 6358 / Beater form), choked below the critical
  pressure ratio ``b = (2/(k+1))**(k/(k-1)) = 0.528``, with a C1 quadratic blend to a
  laminar (linear) law for ratios above ``laminar_ratio`` so the flow has a finite slope
  at zero pressure difference;
* orifice mass flow ``m = C p_up sqrt(2/(R T)) psi(p_down/p_up)`` (4.13, 4.31), signed;
* 5/2 solenoid valve: spool ``T ds/dt = u(t - tau) - s`` (4.28), optional dead zone
  (4.29), four valve coefficients C_A,in/out and C_B,in/out (4.32, 4.33, 4.39), each in
  series with the throttle valve of its line (table 3.2). The throttle valves are
  one-way flow control valves in meter-out orientation: a line exhausts through its
  throttle alone and fills through the throttle and an open check valve in parallel.
  Reasons: the seed re-estimates C_in and C_out of a line separately for each fault
  (4.39, table 4.2), which a throttle acting alike in both directions would not need;
  its flow meters on line A rank FlowContraction (the exhaust of chamber A, through
  throttle valve 1) first for telling throttle valve 1 from normal (table 7.1, figure
  7.4); and meter-out one-way valves are how a double-acting cylinder's speed is set.
  With them the piston speed follows the exhaust throttle of the stroke (choked:
  ``v = C psi_max sqrt(2 R T) / S``), chamber A fills at about supply pressure on the up
  stroke, and the flow meter of line A reads the swept volume, i.e. the motion;
* adiabatic chamber pressures (4.25, 4.26) with an air leak to ambient (8.1, 8.2);
* a finite supply reservoir fed from a regulated source through an orifice;
* equation of motion with gravity (4.35, 4.36), Coulomb and viscous friction (4.37, sign
  smoothed by ``tanh(v / v_eps)``), one-sided hard stops (4.38) and end dampers modelled
  like the hard stop with an emphasis on damping (section 4.5.3). Each end has three
  one-sided contacts: the hard stop at the end, the static large damper engaging
  ``damper_large_travel`` before it and the adjustable small damper engaging
  ``damper_small_travel`` before it. Their damping acts only while moving into them
  (seed: ``D x' ge(x', 0)``) and builds up over ``contact_ramp`` of penetration.

Simplifications kept from the seed: the gas in the flow laws is at ambient temperature
(T_A = T_B = T_s = T_0); heat exchange only enters the sensor-side gas temperature.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pdmkit.errors import ModelError, did_you_mean
from pdmkit.models._xp import get_namespace, is_torch

__all__ = [
    "STATE_NAMES",
    "PneumaticParams",
    "initial_state",
    "orifice_mass_flow",
    "outflow_function",
    "piston_rhs",
    "stack_params",
    "valve_command",
]

STATE_NAMES = (
    "position",
    "velocity",
    "pressure_a",
    "pressure_b",
    "pressure_supply",
    "spool",
)
STATE_UNITS = {
    "position": "m",
    "velocity": "m/s",
    "pressure_a": "Pa",
    "pressure_b": "Pa",
    "pressure_supply": "Pa",
    "spool": "-",
}

_P0 = 101325.0


def _m(unit: str, doc: str, lo=None, hi=None, lo_open=False, scalar=False) -> dict:
    """Field metadata: unit, description and allowed range of a parameter."""
    return {
        "unit": unit,
        "doc": doc,
        "lo": lo,
        "hi": hi,
        "lo_open": lo_open,
        "scalar": scalar,
    }


@dataclass(frozen=True, eq=False)
class PneumaticParams:
    """Parameters of the pneumatic piston digital twin (SI units inside).

    Every field is a float, or an array of shape ``(n_members,)`` (numpy array or torch
    tensor) giving each member of a batch its own value. Defaults describe a healthy
    ~25 mm bore, 160 mm stroke vertical cylinder at 5 bar supply, like the demonstration
    device of the seed thesis (chapter 3); the thesis' own parameter file
    (``models/params.m``) is not part of the seed, so values marked *assumed* are
    engineering estimates for such a rig, not identified values.

    Parameters
    ----------
    p_ambient : float, Pa
        Ambient (atmospheric) pressure p_0. Default 101325.
    t_ambient : float, K
        Ambient temperature T_0, also the gas temperature in the flow laws
        (T_A = T_B = T_s = T_0, seed 4.32). Default 293.15.
    r_gas : float, J/(kg K)
        Specific gas constant of air, seed eq. 4.1. Default 287.1.
    kappa : float, -
        Heat capacity ratio c_p/c_v (adiabatic processes, seed 4.2). Default 1.4.
    gravity : float, m/s^2
        Gravitational acceleration acting against extension (vertical piston). 9.81.
    p_supply : float, Pa
        Absolute pressure of the regulated source; table 3.2 lists 5 or 6 bar (gauge).
        Default 601325 (5 bar gauge).
    v_reservoir : float, m^3
        Volume of the supply reservoir between regulator and valve (assumed 1 l).
    c_supply : float, m^2
        Effective area (valve coefficient) of the regulator feeding the reservoir
        (assumed 5e-6).
    bore : float, m
        Piston diameter (assumed 0.025).
    rod_diameter : float, m
        Piston rod diameter (assumed 0.010); S_B = S_A - pi d^2 / 4, S_0 = pi d^2 / 4.
    stroke : float, m
        Stroke L between the hard stops (assumed 0.160).
    v_dead_a, v_dead_b : float, m^3
        Dead volumes V_0A, V_0B of chambers and tubing (seed 4.21, 4.22; assumed 1e-5).
    mass_piston : float, kg
        Mass M of all moving parts (assumed 0.5).
    mass_load : float, kg
        Load mass M_L; table 3.2 settings are 0, 1.25, 5 and 6.25. Default 0.
    c_a_in, c_a_out, c_b_in, c_b_out : float, m^2
        Valve coefficients C = S_max C_d of the solenoid valve paths into / out of
        chambers A and B (seed 4.30, 4.39; assumed 5e-6, about a 2.5 mm orifice).
    throttle_a, throttle_b : float, -
        Settings 1..10 of throttle valve 1 (line to chamber A) and throttle valve 2
        (line to chamber B), table 3.2 (10 = fully open). Each is a one-way flow
        control valve (meter-out): exhausting the chamber, the throttle of effective
        area ``C_t = c_throttle_max * setting / 10`` is in series with the valve path
        (series coefficient ``C_v C_t / sqrt(C_v^2 + C_t^2)``); filling it, the check
        valve opens beside the throttle, ``C_t + c_check_valve`` in series with the valve
        path. Default 5.
    c_throttle_max : float, m^2
        Effective area of a throttle valve fully open (assumed 5e-6).
    c_check_valve : float, m^2
        Effective area of the open check valve of a one-way flow control valve, in
        parallel with the throttle in the filling direction (assumed 5e-6, as the
        throttle fully open). 0 makes the throttle act alike in both directions (the
        twin before the one-way valves).
    valve_time_constant : float, s
        Time constant T of the spool dynamics, seed 4.28 (assumed 0.005).
    valve_delay : float, s
        Transport delay tau of valve and lines, seed 4.28 (assumed 0.010).
    valve_dead_zone : float, -
        Half-width of the spool dead zone, seed 4.29, as a fraction of the spool travel;
        0 disables it. Default 0.
    cycle_period : float, s
        Period of the up/down valve command (assumed 2.0: five up and five down strokes
        in a 10 s recording).
    cycle_duty : float, -
        Fraction of a period commanded up (+1, fill A). Default 0.5.
    cycle_start : float, s
        Time of the first up command; before it the valve is commanded down. 0.1.
    friction_coulomb : float, N
        Coulomb friction force F_C, seed 4.37 (assumed 10).
    friction_viscous : float, N s/m
        Viscous friction coefficient B_v, seed 4.37 (assumed 20).
    friction_v_eps : float, m/s
        Velocity scale of the smoothed sign, ``sign(v) ~ tanh(v / v_eps)`` (0.002).
    stop_stiffness : float, N/m
        Hard-stop spring K of seed 4.38 (assumed 2e6, stiff enough that the piston
        penetrates less than 0.1 mm at rest, soft enough to resolve an impact in
        about ten 2e-4 s steps).
    stop_damping : float, N s/m
        Hard-stop damper D of seed 4.38, acting only while moving into the stop (1000).
    damper_upper, damper_bottom : float, -
        Settings 1..10 of the small adjustable end dampers (table 3.2), mapped
        log-linearly onto ``damper_small_min .. damper_small_max``. Default 5.
    damper_small_min, damper_small_max : float, N s/m
        Damping coefficient of a small damper at setting 1 and 10 (assumed 50, 1500).
    damper_small_travel : float, m
        Travel of the small dampers: they engage this far before each end (0.008).
    damper_small_stiffness : float, N/m
        Return spring of a small damper (assumed 2e3).
    damper_large_damping : float, N s/m
        Damping of the static large dampers (table 3.2: no adjustment; assumed 400).
    damper_large_travel : float, m
        Travel of the large dampers (assumed 0.003).
    damper_large_stiffness : float, N/m
        Stiffness of the large dampers (assumed 3e4).
    c_leak_a, c_leak_b : float, m^2
        Air-leak coefficients C_al from chamber A / B to ambient, seed 8.1-8.2; the seed
        ranges C_al from 1e-10 (healthy) to 1e-6 (severe leak). Default 1e-10.
    contact_ramp : float, m
        Penetration over which the damping of a stop or damper builds up (a smooth
        onset instead of the force jump of seed 4.38; assumed 2e-4).
    laminar_ratio : float, -
        Pressure ratio above which the outflow function blends into a laminar (linear)
        law (numerical regularisation near zero pressure difference). Default 0.99.
    frame_frequency : float, Hz
        Natural frequency of the frame mode seen by the static accelerometer and the
        strain gauge (assumed 120; below the 500 Hz Nyquist frequency at 1 kHz).
    frame_damping_ratio : float, -
        Damping ratio of that frame mode (assumed 0.05).
    frame_mass : float, kg
        Modal mass of the frame (assumed 8).
    strain_area : float, m^2
        Cross-section of the gauged frame member: stress = mount force / area (1e-4).
    mic_frequency : float, Hz
        Resonance excited at the bumpers by impacts, heard by the microphones (assumed
        310).
    mic_decay : float, s
        Decay time constant of that resonance (assumed 0.015).
    mic_gain : float, V/N
        Microphone voltage per newton of impact force change at the near bumper (0.004);
        the far bumper is heard at ``mic_far_gain`` of that, the ambient microphone at
        ``mic_ambient_gain`` of that.
    mic_far_gain, mic_ambient_gain : float, -
        Relative gains of the far bumper and of the ambient microphone (0.2, 0.1).
    mic_hiss_gain : float, V s/kg
        Exhaust hiss: noise amplitude per kg/s of exhaust flow (assumed 20).
    proximity_distance : float, m
        Switching distance of the proximity sensors from each end (assumed 0.002).
    temp_gas_time_constant : float, s
        Heat-exchange time constant relaxing the adiabatic gas temperature to the wall
        (assumed 0.5).
    temp_wall_gain : float, -
        Fraction of the mean gas temperature excess over ambient that the cylinder
        barrel (where TempCylinder sits) takes on (assumed 0.1).
    temp_sensor_time_constant : float, s
        Time constant of the cylinder temperature sensor (assumed 5).

    Examples
    --------
    >>> from pdmkit.models import PneumaticParams
    >>> p = PneumaticParams()
    >>> round(p.p_supply / 1e5 - p.p_ambient / 1e5, 3)   # bar gauge
    5.0
    >>> p.replace(throttle_b=2.0).throttle_b
    2.0
    >>> p.replace(throtle_b=2.0)
    Traceback (most recent call last):
    ...
    pdmkit.errors.ModelError: PneumaticParams has no parameter 'throtle_b'; did you ...
    """

    p_ambient: Any = field(
        default=_P0, metadata=_m("Pa", "ambient pressure", lo=0.0, lo_open=True)
    )
    t_ambient: Any = field(
        default=293.15, metadata=_m("K", "ambient temperature", lo=0.0, lo_open=True)
    )
    r_gas: Any = field(
        default=287.1, metadata=_m("J/(kg K)", "gas constant", lo=0.0, lo_open=True)
    )
    kappa: Any = field(
        default=1.4, metadata=_m("-", "heat capacity ratio", lo=1.0, lo_open=True, hi=2.0)
    )
    gravity: Any = field(default=9.81, metadata=_m("m/s^2", "gravitational acceleration"))
    p_supply: Any = field(
        default=_P0 + 5e5,
        metadata=_m("Pa", "supply pressure (absolute)", lo=0.0, lo_open=True),
    )
    v_reservoir: Any = field(
        default=1e-3, metadata=_m("m^3", "reservoir volume", lo=0.0, lo_open=True)
    )
    c_supply: Any = field(default=5e-6, metadata=_m("m^2", "regulator coefficient", lo=0.0))
    bore: Any = field(
        default=0.025, metadata=_m("m", "piston diameter", lo=0.0, lo_open=True)
    )
    rod_diameter: Any = field(default=0.010, metadata=_m("m", "rod diameter", lo=0.0))
    stroke: Any = field(default=0.160, metadata=_m("m", "stroke", lo=0.0, lo_open=True))
    v_dead_a: Any = field(
        default=1e-5, metadata=_m("m^3", "dead volume A", lo=0.0, lo_open=True)
    )
    v_dead_b: Any = field(
        default=1e-5, metadata=_m("m^3", "dead volume B", lo=0.0, lo_open=True)
    )
    mass_piston: Any = field(
        default=0.5, metadata=_m("kg", "moving mass", lo=0.0, lo_open=True)
    )
    mass_load: Any = field(default=0.0, metadata=_m("kg", "load mass", lo=0.0))
    c_a_in: Any = field(
        default=5e-6, metadata=_m("m^2", "valve coefficient into A", lo=0.0)
    )
    c_a_out: Any = field(
        default=5e-6, metadata=_m("m^2", "valve coefficient out of A", lo=0.0)
    )
    c_b_in: Any = field(
        default=5e-6, metadata=_m("m^2", "valve coefficient into B", lo=0.0)
    )
    c_b_out: Any = field(
        default=5e-6, metadata=_m("m^2", "valve coefficient out of B", lo=0.0)
    )
    throttle_a: Any = field(
        default=5.0, metadata=_m("-", "throttle valve 1 setting", lo=1.0, hi=10.0)
    )
    throttle_b: Any = field(
        default=5.0, metadata=_m("-", "throttle valve 2 setting", lo=1.0, hi=10.0)
    )
    c_throttle_max: Any = field(
        default=5e-6, metadata=_m("m^2", "throttle area fully open", lo=0.0, lo_open=True)
    )
    c_check_valve: Any = field(
        default=5e-6, metadata=_m("m^2", "check valve area (free direction)", lo=0.0)
    )
    valve_time_constant: Any = field(
        default=0.005, metadata=_m("s", "spool time constant", lo=0.0, lo_open=True)
    )
    valve_delay: Any = field(
        default=0.010, metadata=_m("s", "valve transport delay", lo=0.0)
    )
    valve_dead_zone: Any = field(
        default=0.0, metadata=_m("-", "spool dead zone", lo=0.0, hi=0.95)
    )
    cycle_period: Any = field(
        default=2.0, metadata=_m("s", "command period", lo=0.0, lo_open=True)
    )
    cycle_duty: Any = field(default=0.5, metadata=_m("-", "command duty", lo=0.0, hi=1.0))
    cycle_start: Any = field(default=0.1, metadata=_m("s", "first up command", lo=0.0))
    friction_coulomb: Any = field(
        default=10.0, metadata=_m("N", "Coulomb friction", lo=0.0)
    )
    friction_viscous: Any = field(
        default=20.0, metadata=_m("N s/m", "viscous friction", lo=0.0)
    )
    friction_v_eps: Any = field(
        default=2e-3, metadata=_m("m/s", "sign smoothing", lo=0.0, lo_open=True)
    )
    stop_stiffness: Any = field(
        default=2e6, metadata=_m("N/m", "hard stop stiffness", lo=0.0)
    )
    stop_damping: Any = field(
        default=1e3, metadata=_m("N s/m", "hard stop damping", lo=0.0)
    )
    damper_upper: Any = field(
        default=5.0, metadata=_m("-", "small upper damper setting", lo=1.0, hi=10.0)
    )
    damper_bottom: Any = field(
        default=5.0, metadata=_m("-", "small bottom damper setting", lo=1.0, hi=10.0)
    )
    damper_small_min: Any = field(
        default=50.0, metadata=_m("N s/m", "small damper at 1", lo=0.0, lo_open=True)
    )
    damper_small_max: Any = field(
        default=1500.0, metadata=_m("N s/m", "small damper at 10", lo=0.0, lo_open=True)
    )
    damper_small_travel: Any = field(
        default=0.008, metadata=_m("m", "small damper travel", lo=0.0)
    )
    damper_small_stiffness: Any = field(
        default=2e3, metadata=_m("N/m", "small damper spring", lo=0.0)
    )
    damper_large_damping: Any = field(
        default=400.0, metadata=_m("N s/m", "large damper damping", lo=0.0)
    )
    damper_large_travel: Any = field(
        default=0.003, metadata=_m("m", "large damper travel", lo=0.0)
    )
    damper_large_stiffness: Any = field(
        default=3e4, metadata=_m("N/m", "large damper stiffness", lo=0.0)
    )
    contact_ramp: Any = field(
        default=2e-4, metadata=_m("m", "damping ramp-in", lo=0.0, lo_open=True)
    )
    c_leak_a: Any = field(default=1e-10, metadata=_m("m^2", "leak coefficient A", lo=0.0))
    c_leak_b: Any = field(default=1e-10, metadata=_m("m^2", "leak coefficient B", lo=0.0))
    laminar_ratio: Any = field(
        default=0.99, metadata=_m("-", "laminar blend ratio", lo=0.6, hi=0.9999)
    )
    frame_frequency: Any = field(
        default=120.0, metadata=_m("Hz", "frame mode", lo=0.0, lo_open=True, scalar=True)
    )
    frame_damping_ratio: Any = field(
        default=0.05, metadata=_m("-", "frame damping", lo=0.0, lo_open=True, scalar=True)
    )
    frame_mass: Any = field(
        default=8.0,
        metadata=_m("kg", "frame modal mass", lo=0.0, lo_open=True, scalar=True),
    )
    strain_area: Any = field(
        default=1e-4,
        metadata=_m("m^2", "gauged section", lo=0.0, lo_open=True, scalar=True),
    )
    mic_frequency: Any = field(
        default=310.0,
        metadata=_m("Hz", "impact resonance", lo=0.0, lo_open=True, scalar=True),
    )
    mic_decay: Any = field(
        default=0.015, metadata=_m("s", "impact decay", lo=0.0, lo_open=True, scalar=True)
    )
    mic_gain: Any = field(default=0.004, metadata=_m("V/N", "microphone gain", lo=0.0))
    mic_far_gain: Any = field(default=0.2, metadata=_m("-", "far bumper gain", lo=0.0))
    mic_ambient_gain: Any = field(
        default=0.1, metadata=_m("-", "ambient microphone gain", lo=0.0)
    )
    mic_hiss_gain: Any = field(
        default=20.0, metadata=_m("V s/kg", "exhaust hiss gain", lo=0.0)
    )
    proximity_distance: Any = field(
        default=0.002, metadata=_m("m", "proximity switching distance", lo=0.0)
    )
    temp_gas_time_constant: Any = field(
        default=0.5, metadata=_m("s", "gas heat exchange", lo=0.0, lo_open=True)
    )
    temp_wall_gain: Any = field(
        default=0.1, metadata=_m("-", "barrel / gas temperature coupling", lo=0.0, hi=1.0)
    )
    temp_sensor_time_constant: Any = field(
        default=5.0, metadata=_m("s", "temperature sensor lag", lo=0.0)
    )

    # ------------------------------------------------------------------ validation
    def __post_init__(self) -> None:
        n = None
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            value = _coerce(f.name, value)
            object.__setattr__(self, f.name, value)
            shape = tuple(value.shape) if hasattr(value, "shape") else ()
            if len(shape) > 1:
                raise ModelError(
                    f"PneumaticParams.{f.name} must be a number or a 1-D array of shape "
                    f"(n_members,); got shape {shape}. Pass one value per member."
                )
            if shape:
                if f.metadata["scalar"]:
                    raise ModelError(
                        f"PneumaticParams.{f.name} is a sensor-physics constant shared by "
                        f"all members; got an array of shape {shape}. Pass one number."
                    )
                if n is None:
                    n = shape[0]
                elif shape[0] != n:
                    raise ModelError(
                        f"PneumaticParams.{f.name} has {shape[0]} member values but other "
                        f"parameters have {n}; give every batched parameter the same "
                        f"length (or use stack_params)."
                    )
            _check_range(f, value)
        _check_consistency(self)
        object.__setattr__(self, "_n_members", n)

    # ------------------------------------------------------------------ helpers
    def __eq__(self, other: object) -> bool:
        if not isinstance(other, PneumaticParams):
            return NotImplemented
        return all(
            np.array_equal(_values(getattr(self, f.name)), _values(getattr(other, f.name)))
            for f in dataclasses.fields(self)
        )

    __hash__ = None  # type: ignore[assignment]  (fields may be arrays)

    @property
    def n_members(self) -> int | None:
        """Number of members when any field is batched, else None."""
        return self._n_members

    @property
    def is_torch(self) -> bool:
        """True when any field is a torch tensor (differentiable path)."""
        return any(is_torch(getattr(self, f.name)) for f in dataclasses.fields(self))

    def replace(self, **changes: Any) -> PneumaticParams:
        """Return a copy with some fields changed; unknown names raise ModelError.

        Examples
        --------
        >>> from pdmkit.models import PneumaticParams
        >>> PneumaticParams().replace(mass_load=1.25).mass_load
        1.25
        """
        names = [f.name for f in dataclasses.fields(self)]
        for key in changes:
            if key not in names:
                raise ModelError(
                    f"PneumaticParams has no parameter {key!r}{did_you_mean(key, names)} "
                    f"Known parameters: {', '.join(names)}."
                )
        return dataclasses.replace(self, **changes)

    def member(self, i: int) -> PneumaticParams:
        """The scalar parameters of member ``i`` of a batch.

        Examples
        --------
        >>> from pdmkit.models import PneumaticParams, stack_params
        >>> b = stack_params([PneumaticParams(), PneumaticParams(mass_load=5.0)])
        >>> b.member(1).mass_load
        5.0
        """
        changes = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if hasattr(v, "shape") and len(v.shape) == 1:
                changes[f.name] = v[i] if is_torch(v) else float(v[i])
        return dataclasses.replace(self, **changes)

    @classmethod
    def describe(cls):
        """Every parameter with its default, unit and description, as a DataFrame.

        Examples
        --------
        >>> from pdmkit.models import PneumaticParams
        >>> table = PneumaticParams.describe()
        >>> table.loc["bore", "unit"], float(table.loc["bore", "default"])
        ('m', 0.025)
        """
        import pandas as pd

        rows = [
            {
                "name": f.name,
                "default": f.default,
                "unit": f.metadata["unit"],
                "description": f.metadata["doc"],
            }
            for f in dataclasses.fields(cls)
        ]
        return pd.DataFrame(rows).set_index("name")


def _coerce(name: str, value: Any) -> Any:
    if is_torch(value):
        import torch

        if value.dtype != torch.float64:
            value = value.to(torch.float64)
        return value
    if isinstance(value, bool):
        raise ModelError(f"PneumaticParams.{name} must be a number; got a bool {value!r}.")
    if isinstance(value, int | float | np.floating | np.integer):
        return float(value)
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ModelError(
            f"PneumaticParams.{name} must be a number or an array of numbers; got "
            f"{type(value).__name__} {value!r}."
        ) from exc
    if arr.ndim == 0:
        return float(arr)
    arr = arr.copy()
    arr.setflags(write=False)
    return arr


def _values(value: Any) -> np.ndarray:
    if is_torch(value):
        return value.detach().cpu().numpy()
    return np.asarray(value, dtype=np.float64)


def _check_range(f: dataclasses.Field, value: Any) -> None:
    vals = _values(value)
    meta = f.metadata
    unit = meta["unit"]
    if not np.all(np.isfinite(vals)):
        raise ModelError(
            f"PneumaticParams.{f.name} ({unit}) must be finite; got {value!r}."
        )
    lo, hi = meta["lo"], meta["hi"]
    if lo is not None:
        bad = vals <= lo if meta["lo_open"] else vals < lo
        if np.any(bad):
            op = ">" if meta["lo_open"] else ">="
            raise ModelError(
                f"PneumaticParams.{f.name} must be {op} {lo:g} {unit}; got "
                f"{vals[bad].ravel()[0]:g}. Default is {f.default:g} {unit}."
            )
    if hi is not None and np.any(vals > hi):
        raise ModelError(
            f"PneumaticParams.{f.name} must be <= {hi:g} {unit}; got "
            f"{vals[vals > hi].ravel()[0]:g}. Default is {f.default:g} {unit}."
        )


def _check_consistency(p: PneumaticParams) -> None:
    if np.any(_values(p.rod_diameter) >= _values(p.bore)):
        raise ModelError(
            f"PneumaticParams.rod_diameter ({p.rod_diameter!r} m) must be smaller than the "
            f"bore ({p.bore!r} m)."
        )
    for name in ("damper_small_travel", "damper_large_travel", "proximity_distance"):
        if np.any(_values(getattr(p, name)) >= 0.5 * _values(p.stroke)):
            raise ModelError(
                f"PneumaticParams.{name} ({getattr(p, name)!r} m) must be less than half "
                f"the stroke ({p.stroke!r} m)."
            )
    if np.any(_values(p.damper_small_max) < _values(p.damper_small_min)):
        raise ModelError(
            "PneumaticParams.damper_small_max must be >= damper_small_min; got "
            f"{p.damper_small_max!r} < {p.damper_small_min!r}."
        )


def stack_params(members: list[PneumaticParams]) -> PneumaticParams:
    """Combine scalar parameter sets into one batched :class:`PneumaticParams`.

    Fields equal across all members stay scalar; the others become arrays of shape
    ``(n_members,)``.

    Parameters
    ----------
    members : list of PneumaticParams
        Scalar parameter sets, one per member.

    Returns
    -------
    PneumaticParams
        Batched parameters with ``n_members == len(members)``.

    Examples
    --------
    >>> from pdmkit.models import PneumaticParams, stack_params
    >>> p = stack_params([PneumaticParams(), PneumaticParams(throttle_a=2.0)])
    >>> p.n_members, p.throttle_a.tolist(), p.throttle_b
    (2, [5.0, 2.0], 5.0)
    """
    if not members:
        raise ModelError(
            "stack_params needs at least one PneumaticParams; got an empty list."
        )
    for i, m in enumerate(members):
        if not isinstance(m, PneumaticParams):
            raise ModelError(
                f"stack_params: member {i} is a {type(m).__name__}, expected "
                "PneumaticParams."
            )
        if m.n_members is not None:
            raise ModelError(
                f"stack_params: member {i} is already batched ({m.n_members} members); "
                "pass scalar parameter sets."
            )
    kwargs = {}
    for f in dataclasses.fields(PneumaticParams):
        vals = [getattr(m, f.name) for m in members]
        if any(is_torch(v) for v in vals):
            import torch

            kwargs[f.name] = torch.stack(
                [torch.as_tensor(v, dtype=torch.float64) for v in vals]
            )
        elif all(v == vals[0] for v in vals):
            kwargs[f.name] = vals[0]
        else:
            kwargs[f.name] = np.array(vals, dtype=np.float64)
    return PneumaticParams(**kwargs)


# ---------------------------------------------------------------------- derived values
class _Resolved:
    """Derived quantities of a parameter set, computed once per simulation."""


class _PsiConstants:
    __slots__ = ("beta", "e1", "k1", "lam", "psi_max", "qa", "qb")


def _psi_constants(kappa, lam, xp) -> _PsiConstants:
    c = _PsiConstants()
    c.e1 = (kappa - 1.0) / kappa
    c.k1 = kappa / (kappa - 1.0)
    c.beta = xp.exp(xp.log(2.0 / (kappa + 1.0)) / c.e1)
    c.psi_max = xp.exp(xp.log(2.0 / (kappa + 1.0)) / (kappa - 1.0)) * xp.sqrt(
        kappa / (kappa + 1.0)
    )
    c.lam = lam
    # value and slope of the subsonic psi at the blend point, then q(e) = qa e + qb e^2
    y = xp.exp(c.e1 * xp.log(lam))
    psi_l = (lam / y) * xp.sqrt(c.k1 * (1.0 - y))
    a2 = 2.0 / kappa
    a3 = (kappa + 1.0) / kappa
    dbracket = a2 * xp.exp((a2 - 1.0) * xp.log(lam)) - a3 * xp.exp((a3 - 1.0) * xp.log(lam))
    d_l = -c.k1 * dbracket / (2.0 * psi_l)  # -dpsi/dPi > 0
    e_l = 1.0 - lam
    c.qb = (d_l * e_l - psi_l) / (e_l * e_l)
    c.qa = psi_l / e_l - c.qb * e_l
    if xp.name == "numpy":
        for name in ("beta", "psi_max", "qa", "qb", "e1", "k1", "lam"):
            v = getattr(c, name)
            if np.ndim(v) == 0:
                setattr(c, name, float(v))
    return c


def _column(values, xp):
    """Stack per-row constants into a (k, 1) column, or (k, n) if any is batched."""
    n = None
    for v in values:
        if hasattr(v, "shape") and len(v.shape) == 1:
            n = v.shape[0]
    if n is None:
        if xp.name == "numpy":
            return np.asarray(values, dtype=np.float64)[:, None]
        return xp.stack([xp.asarray(v) for v in values])[:, None]
    return xp.stack([xp.broadcast(v, n) for v in values])


def _resolve(p: PneumaticParams, xp) -> _Resolved:
    r = _Resolved()
    r.params = p
    r.xp = xp
    pi = math.pi
    r.s_a = pi / 4.0 * p.bore * p.bore
    r.s_rod = pi / 4.0 * p.rod_diameter * p.rod_diameter
    r.s_b = r.s_a - r.s_rod
    r.ks_a = p.kappa * r.s_a
    r.ks_b = p.kappa * r.s_b
    r.length = p.stroke
    r.v0a = p.v_dead_a
    r.v0b = p.v_dead_b
    r.mass = p.mass_piston + p.mass_load
    r.inv_m = 1.0 / r.mass
    r.p0 = p.p_ambient
    r.f0 = p.p_ambient * r.s_rod + r.mass * p.gravity  # ambient on the rod + weight
    r.p_supply = p.p_supply
    r.kappa = p.kappa
    r.kt = xp.sqrt(2.0 / (p.r_gas * p.t_ambient))
    r.krt = p.kappa * p.r_gas * p.t_ambient
    r.krt_vr = r.krt / p.v_reservoir
    r.psi = _psi_constants(p.kappa, p.laminar_ratio, xp)
    # valve paths in series with the one-way flow control valves of lines A and B
    # (settings 1..10 -> throttle area): exhaust through the throttle alone, filling
    # through the throttle and the open check valve in parallel (meter-out)
    ct_a = p.c_throttle_max * p.throttle_a / 10.0
    ct_b = p.c_throttle_max * p.throttle_b / 10.0
    r.c_a_in = _series(p.c_a_in, ct_a + p.c_check_valve, xp)
    r.c_a_out = _series(p.c_a_out, ct_a, xp)
    r.c_b_in = _series(p.c_b_in, ct_b + p.c_check_valve, xp)
    r.c_b_out = _series(p.c_b_out, ct_b, xp)
    r.c_leak_a = p.c_leak_a
    r.c_leak_b = p.c_leak_b
    r.c_supply = p.c_supply
    r.t_v = p.valve_time_constant
    r.valve_delay = p.valve_delay
    r.dz = p.valve_dead_zone
    r.has_dz = _nonzero(p.valve_dead_zone)
    r.cycle_period = p.cycle_period
    r.cycle_duty = p.cycle_duty
    r.cycle_start = p.cycle_start
    r.cmd_scalar = all(
        isinstance(v, float)
        for v in (p.cycle_period, p.cycle_duty, p.cycle_start, p.valve_delay)
    )
    r.fc = p.friction_coulomb
    r.bv = p.friction_viscous
    r.inv_eps = 1.0 / p.friction_v_eps
    r.fc_eps = p.friction_coulomb / p.friction_v_eps
    r.b_up = _damper_coefficient(p.damper_upper, p.damper_small_min, p.damper_small_max, xp)
    r.b_bot = _damper_coefficient(
        p.damper_bottom, p.damper_small_min, p.damper_small_max, xp
    )
    # the six one-sided contacts: hard stop, large damper, small damper at the top, then
    # the same three at the bottom. Penetration e_i = sg_i (x - edge_i) > 0 when engaged.
    L, dl, ds = p.stroke, p.damper_large_travel, p.damper_small_travel
    r.edges = _column([L, L - dl, L - ds, 0.0, dl, ds], xp)
    r.sg = _column([1.0, 1.0, 1.0, -1.0, -1.0, -1.0], xp)
    k = [p.stop_stiffness, p.damper_large_stiffness, p.damper_small_stiffness]
    c_top = [p.stop_damping, p.damper_large_damping, r.b_up]
    c_bot = [p.stop_damping, p.damper_large_damping, r.b_bot]
    r.k6 = _column(k + k, xp)
    r.c6 = _column(c_top + c_bot, xp)
    r.inv_ramp = 1.0 / p.contact_ramp
    return r


def _series(c1, c2, xp):
    """Effective coefficient of two orifices in series (ISO 6358 style combination)."""
    return c1 * c2 / xp.sqrt(c1 * c1 + c2 * c2 + 1e-30)


def _damper_coefficient(setting, b_min, b_max, xp):
    """Small-damper setting 1..10 -> damping coefficient, log-linear."""
    return b_min * xp.exp((setting - 1.0) / 9.0 * xp.log(b_max / b_min))


def _nonzero(value) -> bool:
    if is_torch(value):
        return bool((value != 0).any())
    return bool(np.any(np.asarray(value) != 0))


_CACHE: list = [None, None, None]


def _resolved_cached(p: PneumaticParams, xp) -> _Resolved:
    if _CACHE[0] is p and _CACHE[1] == xp.name:
        return _CACHE[2]
    r = _resolve(p, xp)
    _CACHE[:] = [p, xp.name, r]
    return r


# ---------------------------------------------------------------------- flow laws
def _psi(pi, c: _PsiConstants, xp):
    """Outflow function; ``pi`` in (0, 1]. NaN-free in value and gradient."""
    pi_sub = xp.clip(pi, c.beta, c.lam)
    y = xp.exp(c.e1 * xp.log(pi_sub))
    psi_sub = (pi_sub / y) * xp.sqrt(c.k1 * (1.0 - y))
    e = 1.0 - pi
    psi_lam = e * (c.qa + c.qb * e)
    return xp.where(pi > c.lam, psi_lam, psi_sub)


def _flow(p_up, p_down, kt, c: _PsiConstants, xp):
    """Signed mass flow per unit coefficient, kg/(s m^2): positive from up to down."""
    hi = xp.maximum(p_up, p_down)
    lo = xp.minimum(p_up, p_down)
    psi = _psi(lo / hi, c, xp)
    return (kt * xp.sign(p_up - p_down)) * (hi * psi)


def outflow_function(pressure_ratio, kappa=1.4, laminar_ratio=0.99):
    """Outflow function psi(p_down / p_up) of an orifice (seed eqs. 4.12-4.16).

    ``psi = sqrt(k/(k-1) * (r**(2/k) - r**((k+1)/k)))`` for subcritical ratios
    ``b < r <= laminar_ratio``; ``psi_max = (2/(k+1))**(1/(k-1)) * sqrt(k/(k+1))`` (0.484
    for air) for choked flow ``r <= b = (2/(k+1))**(k/(k-1))`` (0.528); above
    ``laminar_ratio`` a quadratic in ``1 - r`` with matching value and slope takes over,
    so that psi(1) = 0 with a finite slope (laminar flow at tiny pressure differences).

    Parameters
    ----------
    pressure_ratio : array_like
        Downstream over upstream absolute pressure, in (0, 1].
    kappa : float
        Heat capacity ratio.
    laminar_ratio : float
        Start of the laminar blend (use 0.9999 to approach the textbook curve).

    Returns
    -------
    ndarray or tensor
        psi, same shape as ``pressure_ratio``.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models import outflow_function
    >>> np.round(outflow_function(np.array([0.1, 0.5, 0.8, 1.0])), 4)
    array([0.4842, 0.4842, 0.3964, 0.    ])
    """
    xp = get_namespace(pressure_ratio, kappa)
    pr = xp.asarray(pressure_ratio)
    if np.any(_values(pr) <= 0) or np.any(_values(pr) > 1):
        raise ModelError(
            "outflow_function: pressure_ratio must lie in (0, 1] (downstream / upstream "
            f"absolute pressure); got values in [{_values(pr).min():g}, "
            f"{_values(pr).max():g}]."
        )
    return _psi(pr, _psi_constants(kappa, laminar_ratio, xp), xp)


def orifice_mass_flow(
    c, p_up, p_down, t_up=293.15, kappa=1.4, r_gas=287.1, laminar_ratio=0.99
):
    """Mass flow through an orifice of coefficient ``c`` (seed eqs. 4.13, 4.31, 8.1).

    ``m = c * p_hi * sqrt(2 / (R T)) * psi(p_lo / p_hi)``, positive from ``p_up`` to
    ``p_down`` and negative when the flow reverses.

    Parameters
    ----------
    c : float or array_like
        Valve coefficient (effective area) ``C = S_max C_d``, m^2.
    p_up, p_down : array_like
        Absolute pressures on either side, Pa.
    t_up : float
        Gas temperature, K.
    kappa, r_gas, laminar_ratio : float
        Heat capacity ratio, gas constant J/(kg K), laminar blend ratio.

    Returns
    -------
    ndarray or tensor
        Mass flow in kg/s.

    Examples
    --------
    >>> from pdmkit.models import orifice_mass_flow
    >>> m1 = orifice_mass_flow(1e-6, 6e5, 1.0e5)   # choked: independent of p_down
    >>> m2 = orifice_mass_flow(1e-6, 6e5, 2.0e5)
    >>> bool(abs(m1 - m2) < 1e-15), round(float(m1) * 1e3, 4)  # g/s
    (True, 1.4162)
    """
    xp = get_namespace(c, p_up, p_down, t_up, kappa)
    kt = xp.sqrt(2.0 / (r_gas * xp.asarray(t_up)))
    consts = _psi_constants(kappa, laminar_ratio, xp)
    return c * _flow(xp.asarray(p_up), xp.asarray(p_down), kt, consts, xp)


# ---------------------------------------------------------------------- valve command
#: tolerance on switching instants: a jump due at t switches at a step landing on t
#: even when the step's time carries rounding error
_T_TOL = 1e-9


def _command(t, r: _Resolved, xp):
    tau = t - r.cycle_start + _T_TOL
    period = r.cycle_period
    phase = tau - period * xp.floor(tau / period)
    up = xp.where(tau >= 0.0, 1.0, 0.0) * xp.where(phase < r.cycle_duty * period, 1.0, 0.0)
    return 2.0 * up - 1.0


def _command_now(t, r: _Resolved, xp):
    """The delayed command at time t; plain Python for scalar command parameters."""
    if r.cmd_scalar and isinstance(t, float):
        tau = t - r.valve_delay - r.cycle_start + _T_TOL
        if tau < 0.0:
            return -1.0
        phase = tau - r.cycle_period * math.floor(tau / r.cycle_period)
        return 1.0 if phase < r.cycle_duty * r.cycle_period else -1.0
    return _command(t - r.valve_delay, r, xp)


def valve_command(t, params: PneumaticParams):
    """The valve command u(t) in {-1, +1} (seed eq. 4.27): +1 fills chamber A (up).

    A square wave of period ``cycle_period`` and duty ``cycle_duty`` starting at
    ``cycle_start``; before it the valve is commanded down (-1). The spool follows it
    after ``valve_delay``.

    Parameters
    ----------
    t : float or array_like
        Times in s. With batched parameters pass ``t`` of shape ``(n_samples,)``; the
        result then has shape ``(n_members, n_samples)``.
    params : PneumaticParams
        Parameters.

    Returns
    -------
    ndarray or tensor
        The command, +1 or -1.

    Examples
    --------
    >>> from pdmkit.models import PneumaticParams, valve_command
    >>> valve_command([0.0, 0.5, 1.5, 2.5], PneumaticParams()).tolist()
    [-1.0, 1.0, -1.0, 1.0]
    """
    xp = get_namespace(t, *[getattr(params, f.name) for f in dataclasses.fields(params)])
    r = _resolve(params, xp)
    t = xp.asarray(t)
    if params.n_members is not None and len(getattr(t, "shape", ())) == 1:
        t = t[None, :]
        for name in ("cycle_start", "cycle_period", "cycle_duty"):
            v = getattr(r, name)
            if hasattr(v, "shape") and len(v.shape) == 1:
                setattr(r, name, v[:, None])
        u = _command(t, r, xp)
        return u + 0.0 * xp.asarray(np.zeros((params.n_members, 1)))
    return _command(t, r, xp)


# ---------------------------------------------------------------------- right-hand side
class _Derivs:
    __slots__ = (
        "acc",
        "c_eff",
        "dpa",
        "dpb",
        "dpr",
        "ds",
        "f_bot",
        "f_top",
        "k_eff",
        "m_a",
        "m_exhaust",
    )


def _derivs(t, x, v, pa, pb, pr, s, r: _Resolved, xp, aux: bool = False) -> _Derivs:
    """Time derivatives of the six plant states (and integrator helpers).

    States are 1-D arrays of shape (n_members,). With ``aux`` (integrator use; needs
    ``r.imp = theta dt / m``) the result also carries the engaged stiffness ``k_eff``
    and damping ``c_eff`` times ``theta dt / m`` (for the linearly implicit mechanical
    step), the contact forces and the valve / exhaust mass flows.
    """
    d = _Derivs()
    p0 = r.p0
    # --- 5/2 valve: delayed command, first-order spool (4.28), dead zone (4.29)
    if not aux:  # the fixed-step integrator updates the spool exactly itself
        d.ds = (_command_now(t, r, xp) - s) / r.t_v
    if r.has_dz:
        mag = xp.relu(xp.abs(s) - r.dz) / (1.0 - r.dz)
        s = xp.where(s >= 0.0, mag, -mag)
    sp = xp.relu(s)
    sn = xp.relu(-s)
    a_up = s > 0.0
    # --- five orifices at once: valve paths A and B (4.32, 4.33, 4.39; one path per
    # chamber is open at a time), leaks A and B to ambient (8.1), regulator -> reservoir
    src_a = xp.where(a_up, pr, p0)
    src_b = xp.where(a_up, p0, pr)
    shape = x.shape
    q = _flow(
        xp.rows((src_a, src_b, pa, pb, r.p_supply), shape),
        xp.rows((pa, pb, p0, p0, pr), shape),
        r.kt,
        r.psi,
        xp,
    )
    m_a = (sp * r.c_a_in + sn * r.c_a_out) * q[0]
    m_b = (sn * r.c_b_in + sp * r.c_b_out) * q[1]
    leak_a = r.c_leak_a * q[2]
    leak_b = r.c_leak_b * q[3]
    draw = xp.where(a_up, m_a, m_b)
    # --- chamber pressures (4.25, 4.26, 8.2) and reservoir
    d.dpa = (r.krt * (m_a - leak_a) - r.ks_a * pa * v) / (r.s_a * x + r.v0a)
    d.dpb = (r.krt * (m_b - leak_b) + r.ks_b * pb * v) / (r.s_b * (r.length - x) + r.v0b)
    d.dpr = r.krt_vr * (r.c_supply * q[4] - draw)
    # --- mechanics (4.35-4.38): pressure force, friction, six one-sided contacts
    th = xp.tanh(v * r.inv_eps)
    pen = r.sg * (x - r.edges)  # (6, n) penetrations, > 0 where engaged
    vin = r.sg * v  # velocity into each contact
    on = xp.step(pen)
    kon = r.k6 * on
    # damping builds up over contact_ramp and acts only while moving in (seed 4.38)
    con = (r.c6 * on) * xp.minimum(pen * r.inv_ramp, 1.0)
    f6 = xp.rowsum3(kon * pen + con * xp.relu(vin))  # (2, n): top, bottom
    f_top = f6[0]
    f_bot = f6[1]
    f_net = pa * r.s_a - pb * r.s_b - r.f0 - r.fc * th - r.bv * v - f_top + f_bot
    d.acc = f_net * r.inv_m
    if aux:
        # engaged stiffness and damping per unit mass, times theta dt (r.imp = theta dt/m)
        d.k_eff = xp.sum0(kon) * r.imp
        d.c_eff = (r.bv + r.fc_eps * (1.0 - th * th) + xp.sum0(con * xp.step(vin))) * r.imp
        d.f_top = f_top
        d.f_bot = f_bot
        d.m_a = m_a
        d.m_exhaust = xp.where(a_up, -m_b, -m_a) + leak_a + leak_b
    return d


def piston_rhs(t, state, params: PneumaticParams):
    """Right-hand side dy/dt of the piston model, usable by ``scipy.integrate.solve_ivp``.

    Parameters
    ----------
    t : float
        Time, s.
    state : array_like, shape (6,) or (n_members, 6)
        States in the order of :data:`STATE_NAMES` (position, velocity, pressure_a,
        pressure_b, pressure_supply, spool), states on the last axis. A numpy array or a
        torch tensor.
    params : PneumaticParams
        Scalar parameters for a 1-D state, or batched parameters with ``n_members`` rows.

    Returns
    -------
    ndarray or tensor
        dy/dt, same shape as ``state``.

    Examples
    --------
    >>> from scipy.integrate import solve_ivp
    >>> from pdmkit.models import PneumaticParams, initial_state, piston_rhs
    >>> p = PneumaticParams()
    >>> sol = solve_ivp(piston_rhs, (0.0, 0.3), initial_state(p), args=(p,), method="LSODA",
    ...                 rtol=1e-6, atol=1e-8)
    >>> bool(sol.success), bool(sol.y[0, -1] > 0.05)   # the piston is on its way up
    (True, True)
    """
    xp = get_namespace(
        state, *[getattr(params, f.name) for f in dataclasses.fields(params)]
    )
    r = _resolved_cached(params, xp)
    y = state if is_torch(state) else np.asarray(state, dtype=np.float64)
    if y.shape[-1] != len(STATE_NAMES):
        raise ModelError(
            f"rhs: state must have {len(STATE_NAMES)} entries on its last axis "
            f"({', '.join(STATE_NAMES)}); got shape {tuple(y.shape)}."
        )
    one = len(y.shape) == 1
    y2 = y[None, :] if one else y
    cols = [y2[:, i] for i in range(len(STATE_NAMES))]
    d = _derivs(float(t), *cols, r, xp)
    ds = d.ds + 0.0 * cols[5]
    out = xp.stack([cols[1], d.acc, d.dpa, d.dpb, d.dpr, ds], axis=-1)
    return out[0] if one else out


def _rest_position(p: PneumaticParams, xp):
    """Static equilibrium at the bottom: the contact springs carry the net load."""
    s_a = math.pi / 4.0 * p.bore * p.bore
    s_rod = math.pi / 4.0 * p.rod_diameter * p.rod_diameter
    load = (p.p_supply - p.p_ambient) * (s_a - s_rod) + (p.mass_piston + p.mass_load) * (
        p.gravity
    )
    k_hs, k_ld, k_sd = p.stop_stiffness, p.damper_large_stiffness, p.damper_small_stiffness
    dl, ds = p.damper_large_travel, p.damper_small_travel
    pre = k_ld * dl + k_sd * ds  # spring force of both dampers at x = 0
    x_stop = (pre - load) / (k_hs + k_ld + k_sd)  # on the hard stop (x <= 0)
    x_large = (pre - load) / (k_ld + k_sd + 1e-300)  # within the large damper
    x_small = ds - load / (k_sd + 1e-300)  # within the small damper only
    x = xp.where(load >= pre, x_stop, xp.where(load >= k_sd * (ds - dl), x_large, x_small))
    return xp.minimum(x, ds)


def initial_state(params: PneumaticParams, n_members: int | None = None):
    """Rest state at the bottom end with the valve commanded down.

    Chamber A at ambient pressure, chamber B and the reservoir at supply pressure, the
    spool at -1, the piston at rest where the bottom stop and dampers carry the load
    (a few hundredths of a millimetre below 0 for the defaults).

    Parameters
    ----------
    params : PneumaticParams
        Parameters (scalar or batched).
    n_members : int, optional
        Number of members for scalar parameters; default: a 1-D state of one member.

    Returns
    -------
    ndarray or tensor
        Shape ``(6,)``, or ``(n_members, 6)`` for batched parameters or ``n_members``.

    Examples
    --------
    >>> from pdmkit.models import PneumaticParams, initial_state
    >>> y0 = initial_state(PneumaticParams())
    >>> round(float(y0[0]) * 1e3, 3), y0[1:].round(1).tolist()   # mm; then the rest
    (-0.052, [0.0, 101325.0, 601325.0, 601325.0, -1.0])
    """
    xp = get_namespace(*[getattr(params, f.name) for f in dataclasses.fields(params)])
    n = params.n_members if params.n_members is not None else n_members
    x0 = _rest_position(params, xp)
    cols = [x0, 0.0, params.p_ambient, params.p_supply, params.p_supply, -1.0]
    if n is None:
        return xp.stack([xp.asarray(c) for c in cols])
    return xp.stack([xp.broadcast(c, n) for c in cols], axis=-1)
