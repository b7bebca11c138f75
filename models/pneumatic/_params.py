"""Parameters of the pneumatic piston digital twin (Voronin's thesis, chapters 3-4 and 8).

:class:`PneumaticParams` (every parameter with its unit, allowed range and source) and
:func:`stack_params` (scalar sets into one batched set); the physics that uses them is
:mod:`pdmkit.models.pneumatic._twin`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pdmkit._checks import replace_fields
from pdmkit.errors import ModelError
from pdmkit.models._xp import is_torch

__all__ = ["PneumaticParams", "stack_params"]

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
        Natural frequency of the frame mode seen by the static accelerometer (assumed
        120; below the 500 Hz Nyquist frequency at 1 kHz).
    frame_damping_ratio : float, -
        Damping ratio of that frame mode (assumed 0.05).
    frame_mass : float, kg
        Modal mass of the frame (assumed 8).
    strain_area : float, m^2
        Cross-section of the gauged member, the rod's load cell: its reading is the
        rod force over this area (1e-4).
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
        return replace_fields(self, changes, "parameter")

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


def piston_areas(bore, rod_diameter):
    """Piston areas ``(S_A, S_B)``, m^2: the cap side and the rod side (S_A less the rod).

    Works on floats, numpy arrays and torch tensors alike.

    Examples
    --------
    >>> from pdmkit.models.pneumatic._params import piston_areas
    >>> [round(s * 1e6, 1) for s in piston_areas(0.02, 0.008)]
    [314.2, 263.9]
    """
    s_a = math.pi / 4.0 * bore * bore
    return s_a, s_a - math.pi / 4.0 * rod_diameter * rod_diameter


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
