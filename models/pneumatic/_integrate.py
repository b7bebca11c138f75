"""Batched fixed-step simulation of the piston model, and a solve_ivp reference.

Scheme (IMEX, fixed step ``dt``, 2e-4 s by default; output decimated to ``fs``):

* spool: exact exponential update of the first-order lag (the command is constant over
  a step); the flows of the step see the spool at mid-step, so the valve opening has no
  O(dt) lag;
* pressures (chambers, reservoir): explicit Euler;
* mechanics (x, v): linearly implicit trapezoidal (theta = 1/2) step, using the
  stiffness ``k`` and damping ``c`` (per unit mass) of whatever is engaged - hard stops,
  dampers, the steep smoothed Coulomb friction::

      dv = dt (a - theta dt k v) / (1 + theta dt c + theta^2 dt^2 k)
      x+ = x + dt (v + theta dv),   v+ = v + dv

  A-stable, so the stiff stops and the friction law stay stable at the fixed step, and
  without the artificial damping of a backward-Euler step (impacts rebound correctly).

A step in which a fast member (more than 0.1 mm in the step) engages or leaves a stop or
damper, or completes a damper's damping ramp-in, is redone in four sub-steps (contact
events, see ``_EVENT_SUBSTEPS``): without them the contact switched only at the step's
end, an O(dt) error in the impact and its rebound (0.74 mm on the benchmark's 5 kg
member striking the top at 1.9 m/s).

Measured against ``solve_ivp`` (LSODA, rtol 1e-6) on the same :func:`piston_rhs`: maximum
position error over a 10 s recording about 0.1 mm at the default step for the healthy
piston and about 0.2 mm for the hard, rebounding impacts of a loaded piston with its
exhaust throttle wide open (``benchmarks/pneumatic_sim.py``). Members are
stepped together (batch on the first axis), in numpy or, when any parameter is a torch
tensor, in torch with autograd. Between output samples the contact forces, the valve
mass flow and the exhaust flow are averaged over the sample interval (what a sampling
sensor sees).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike

from pdmkit._progress import progress
from pdmkit.errors import ModelError
from pdmkit.models._xp import get_namespace, is_torch
from pdmkit.models.ode import ResponseData
from pdmkit.models.pneumatic._sensors import (
    SENSOR_NAMES,
    SENSOR_UNITS,
    resolve_specs,
    sensor_outputs,
)
from pdmkit.models.pneumatic._twin import (
    STATE_NAMES,
    STATE_UNITS,
    PneumaticParams,
    _command_now,
    _derivs,
    _PsiConstants,
    _resolve,
    _Resolved,
    initial_state,
    piston_rhs,
    valve_command,
)

__all__ = ["PneumaticResponse", "simulate_piston", "simulate_piston_ivp"]

SIGNAL_UNITS = {
    "acceleration": "m/s^2",
    "mass_flow_a": "kg/s",
    "mass_flow_exhaust": "kg/s",
    "force_top": "N",
    "force_bottom": "N",
    "temperature_a": "K",
    "temperature_b": "K",
}


#: implicitness of the linearised mechanical step: 0.5 = trapezoidal (second order, no
#: numerical damping of impacts), 1 = backward Euler.
_THETA = 0.5

#: Contact events: a step in which a member engages or leaves a stop or damper, or
#: passes the end of a contact's damping ramp-in (``contact_ramp``), while moving more
#: than ``_EVENT_TRAVEL`` (m; 0.5 m/s at the default step) is redone as
#: ``_EVENT_SUBSTEPS`` sub-steps. The step, linearised at its start, sees a contact
#: switching within it only at its end: an O(dt) error in the impact's impulse, the
#: rebound and everything after (the benchmark's 5 kg member striking the top at
#: 1.9 m/s: 0.74 mm against LSODA at 2e-4 s, 0.35 mm at 1e-4 s, 0.18 mm at 5e-5 s).
#: With 4 sub-steps there: 0.23 mm at 2e-4 s for 15 % more time on 256 members (8:
#: 0.15 mm, 60 % more); slow crossings (the creep into the dampers) keep the plain step.
_EVENT_TRAVEL = 1e-4
_EVENT_SUBSTEPS = 4
#: batches larger than this sub-step only their members with an event (more than the six
#: contact rows, so that no other axis is mistaken for the members')
_SUBSET_FROM = 6


class PneumaticResponse(ResponseData):
    """Response of :func:`simulate_piston`: a :class:`ResponseData` with the params.

    Attributes
    ----------
    params : PneumaticParams
        The parameters simulated (batched when members differ).
    sensor_specs : dict of str to SensorSpec or None
        The sensor models used for :attr:`outputs`.

    Examples
    --------
    >>> from pdmkit.models import simulate_piston
    >>> r = simulate_piston(t_end=0.05, sensors=False)
    >>> type(r).__name__, r.states["position"].shape
    ('PneumaticResponse', (1, 50))
    """

    def __init__(self, *args, params=None, sensor_specs=None, **kwargs) -> None:
        kwargs.setdefault("name", "pneumatic piston")
        super().__init__(*args, **kwargs)
        self.params = params
        self.sensor_specs = sensor_specs

    def _default_signals(self) -> list[str]:
        if "LeverPosition" in self.outputs:
            return ["LeverPosition", "FlowExtrusion", "AirPressure", "MIC_uBumper"]
        return ["position", "pressure_a", "pressure_b", "pressure_supply"]


def _check_timing(t_end, fs, dt):
    for name, v in (("t_end", t_end), ("fs", fs), ("dt", dt)):
        if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
            raise ModelError(
                f"simulate_piston: {name} must be a positive number; got {v!r}."
            )
    n_samples = round(t_end * fs)
    if n_samples < 1:
        raise ModelError(
            "simulate_piston: t_end * fs must give at least one sample; got "
            f"t_end={t_end}, fs={fs}."
        )
    sub = 1.0 / (fs * dt)
    n_sub = round(sub)
    if n_sub < 1 or abs(sub - n_sub) > 1e-6 * sub:
        raise ModelError(
            f"simulate_piston: the output interval 1/fs = {1 / fs:g} s must be a whole "
            f"number of steps dt = {dt:g} s; got {sub:g} steps. Choose dt = 1/(fs * k), "
            f"e.g. {1 / (fs * max(1, round(sub))):g}."
        )
    return n_samples, n_sub, 1.0 / (fs * n_sub)


def _n_members(params: PneumaticParams, batch):
    if batch is not None:
        if not isinstance(batch, int | np.integer) or batch < 1:
            raise ModelError(
                f"simulate_piston: batch must be a positive integer; got {batch!r}."
            )
        if params.n_members is not None and params.n_members != batch:
            raise ModelError(
                f"simulate_piston: batch={batch} but the parameters hold "
                f"{params.n_members} members; leave batch=None for batched parameters."
            )
        return int(batch)
    return params.n_members or 1


def _integrate(
    params: PneumaticParams,
    n: int,
    n_samples: int,
    n_sub: int,
    h: float,
    show_progress: bool | None,
):
    fields = [getattr(params, f.name) for f in dataclasses.fields(params)]
    xp = get_namespace(*fields)
    r = _resolve(params, xp)
    y0 = initial_state(params, n)
    x, v, pa, pb, pr, s = (y0[:, i] for i in range(len(STATE_NAMES)))
    rec = {k: [] for k in STATE_NAMES}
    aux = {k: [] for k in ("mass_flow_a", "mass_flow_exhaust", "force_top", "force_bottom")}

    def record(d_avg):
        for k, val in zip(STATE_NAMES, (x, v, pa, pb, pr, s), strict=True):
            rec[k].append(val)
        for k, val in zip(aux, d_avg, strict=True):
            aux[k].append(val)

    th_h = _THETA * h
    r.imp = th_h * r.inv_m  # _derivs returns k and c scaled by theta dt / m
    d = _derivs(0.0, x, v, pa, pb, pr, s, r, xp, aux=True)
    record((d.m_a, d.m_exhaust, d.f_top, d.f_bot))
    acc0 = d.acc
    inv = 1.0 / n_sub
    # the spool is linear between command jumps: exact exponential update
    coefs = step_coefficients(r, h, xp)
    step = 0
    for _ in progress(
        range(1, n_samples), desc="simulate", total=n_samples - 1, enable=show_progress
    ):
        s_ma = s_ex = s_top = s_bot = 0.0
        for _j in range(n_sub):
            t = step * h
            # the flows see the spool at mid-step (exact for the linear spool), which
            # removes the O(dt) lag of the valve opening in the explicit pressure step
            u = _command_now(t, r, xp)
            (x, v, pa, pb, pr, s), d = event_step(
                t, (x, v, pa, pb, pr, s), u, r, h, coefs, xp
            )
            s_ma = s_ma + d.m_a
            s_ex = s_ex + d.m_exhaust
            s_top = s_top + d.f_top
            s_bot = s_bot + d.f_bot
            step += 1
        record((s_ma * inv, s_ex * inv, s_top * inv, s_bot * inv))
    states = {k: xp.stack(val, axis=1) for k, val in rec.items()}
    signals = {k: xp.stack(val, axis=1) for k, val in aux.items()}
    return xp, r, states, signals, acc0


def _spool_decay(r, h: float, xp):
    """``(exp(-h/(2 t_v)), exp(-h/t_v))``: the spool's exact update over a step."""
    if is_torch(r.t_v):
        return xp.exp(-0.5 * h / r.t_v), xp.exp(-h / r.t_v)
    half = np.exp(-0.5 * h / np.asarray(r.t_v))
    decay = np.exp(-h / np.asarray(r.t_v))
    if decay.ndim == 0:
        half, decay = float(half), float(decay)
    return half, decay


def step_coefficients(r, h: float, xp) -> dict:
    """The step's and the event sub-step's coefficients for :func:`event_step`."""
    h_sub = h / _EVENT_SUBSTEPS
    return {
        "step": (_THETA * h, *_spool_decay(r, h, xp)),
        "sub": (_THETA * h_sub, *_spool_decay(r, h_sub, xp)),
        "imp": _THETA * h * r.inv_m,
        "imp_sub": _THETA * h_sub * r.inv_m,
    }


class _MeanDerivs:
    """The sample-relevant derivatives averaged over the sub-steps of a step."""

    __slots__ = ("f_bot", "f_top", "m_a", "m_exhaust")


def event_step(t, state: tuple, u, r, h: float, coefs: dict, xp) -> tuple:
    """One integrator step, redone in sub-steps where a contact switches within it.

    :func:`imex_step` over ``h``; if any member crossed the edge of a stop or damper
    while moving more than ``_EVENT_TRAVEL`` in it, every member repeats the step as
    ``_EVENT_SUBSTEPS`` steps (the same command; the flows and contact forces returned
    are their means) and keeps the sub-stepped result for those members only, so that a
    member's result does not depend on the batch it is in. ``coefs`` from
    :func:`step_coefficients`. The step that :func:`simulate_piston` and the parameter
    estimation both take.
    """
    r.imp = coefs["imp"]
    new, d = imex_step(t, state, u, r, h, coefs["step"], xp)
    x0, x1 = state[0], new[0]
    pen0 = r.sg * (x0 - r.edges)  # (6, n) penetrations at the start and the end
    pen1 = r.sg * (x1 - r.edges)
    ramp = 1.0 / r.inv_ramp
    # a contact engaged or released, or its damping's ramp-in begun or completed
    switched = (pen0 * pen1 <= 0.0) | ((pen0 - ramp) * (pen1 - ramp) <= 0.0)
    crossed = switched & (xp.abs(x1 - x0) > _EVENT_TRAVEL)
    hit = xp.sum0(crossed * 1.0) > 0.0  # (n,): the members with an event in the step
    if not bool(hit.any()):
        return new, d
    n = int(np.shape(x0)[0]) if np.ndim(x0) else 1
    if xp.name == "numpy" and n > _SUBSET_FROM and int(hit.sum()) < n:
        # only the members with an event take the sub-steps (a large batch has one
        # somewhere in most steps); each member's arithmetic is the same either way
        return _substeps_of_some(t, state, u, r, h, coefs, np.flatnonzero(hit), new, d)
    h_sub = h / _EVENT_SUBSTEPS
    r.imp = coefs["imp_sub"]
    sub, mean_sub = _substeps(t, state, u, r, h_sub, coefs["sub"], xp)
    r.imp = coefs["imp"]
    # member by member: a member's result never depends on the others in its batch
    mean = _MeanDerivs()
    for name in _MeanDerivs.__slots__:
        setattr(mean, name, xp.where(hit, getattr(mean_sub, name), getattr(d, name)))
    return tuple(xp.where(hit, a, b) for a, b in zip(sub, new, strict=True)), mean


def _substeps(t, state, u, r, h_sub: float, coefs_sub: tuple, xp):
    """``_EVENT_SUBSTEPS`` steps of ``h_sub``: the state and the mean derivatives."""
    mean = _MeanDerivs()
    for name in _MeanDerivs.__slots__:
        setattr(mean, name, 0.0)
    inv = 1.0 / _EVENT_SUBSTEPS
    sub = state
    for j in range(_EVENT_SUBSTEPS):
        sub, dj = imex_step(t + j * h_sub, sub, u, r, h_sub, coefs_sub, xp)
        for name in _MeanDerivs.__slots__:
            setattr(mean, name, getattr(mean, name) + getattr(dj, name) * inv)
    return sub, mean


def _take(value, idx: np.ndarray, n: int):
    """``value`` at the members ``idx`` when it has one entry per member (last axis)."""
    if isinstance(value, np.ndarray) and value.ndim >= 1 and value.shape[-1] == n:
        return value[..., idx]
    if isinstance(value, _PsiConstants):
        out = _PsiConstants()
        for name in _PsiConstants.__slots__:
            setattr(out, name, _take(getattr(value, name), idx, n))
        return out
    return value


def _substeps_of_some(t, state, u, r, h, coefs, idx, new, d):
    """:func:`event_step`'s sub-steps for the members ``idx`` only, merged into ``new``."""
    n = int(np.shape(state[0])[0])
    rs = _Resolved()
    rs.__dict__.update({k: _take(v, idx, n) for k, v in vars(r).items()})
    rs.imp = _take(coefs["imp_sub"], idx, n)
    coefs_sub = tuple(_take(c, idx, n) for c in coefs["sub"])
    sub, mean_sub = _substeps(
        t, tuple(_take(a, idx, n) for a in state), _take(u, idx, n), rs,
        h / _EVENT_SUBSTEPS, coefs_sub, r.xp,
    )  # fmt: skip
    out = []
    for a, b in zip(sub, new, strict=True):
        merged = np.array(b, dtype=np.float64, copy=True)
        merged[idx] = a
        out.append(merged)
    mean = _MeanDerivs()
    for name in _MeanDerivs.__slots__:
        merged = np.array(np.broadcast_to(getattr(d, name), (n,)), dtype=np.float64)
        merged[idx] = getattr(mean_sub, name)
        setattr(mean, name, merged)
    return tuple(out), mean


def imex_step(t, state: tuple, u, r, h: float, coefs: tuple, xp) -> tuple:
    """One step of the piston's integrator: ``((x, v, pa, pb, pr, s), derivatives)``.

    The spool ``s`` relaxes exactly towards the command ``u`` (the flows see it at
    mid-step, which removes the O(dt) lag of the valve opening), the mechanics take the
    theta-method step with the dampers' and stops' stiffness implicit, the pressures an
    explicit one. ``coefs`` = ``(theta * h, exp(-h/(2 t_v)), exp(-h/t_v))``. The one
    step that :func:`simulate_piston` and the parameter estimation both take.
    """
    x, v, pa, pb, pr, s = state
    th_h, half, decay = coefs
    s_u = s - u
    d = _derivs(t, x, v, pa, pb, pr, u + s_u * half, r, xp, aux=True)
    dv = h * (d.acc - d.k_eff * v) / (1.0 + d.c_eff + th_h * d.k_eff)
    new = (
        x + h * (v + _THETA * dv),
        v + dv,
        pa + h * d.dpa,
        pb + h * d.dpb,
        pr + h * d.dpr,
        u + s_u * decay,
    )
    return new, d


def _gas_temperatures(p_chamber, params: PneumaticParams, fs: float, xp):
    """Adiabatic gas temperature with heat exchange to the wall, sampled at ``fs``.

    ``d ln T = (k - 1)/k d ln p - (1 - T_w / T) dt / tau``: the isentropic change of the
    pressure model (T_w = ambient) relaxed with the heat-exchange time constant.
    """
    e1 = (params.kappa - 1.0) / params.kappa
    tw = params.t_ambient
    dt_tau = (1.0 / fs) / params.temp_gas_time_constant
    lnp = xp.log(p_chamber)
    dlnp = lnp[:, 1:] - lnp[:, :-1]
    lnt = xp.log(xp.asarray(tw) + 0.0 * p_chamber[:, 0])
    out = [xp.exp(lnt)]
    for k in range(dlnp.shape[1]):
        temp = out[-1]
        lnt = lnt + e1 * dlnp[:, k] - (1.0 - tw / temp) * dt_tau
        out.append(xp.exp(lnt))
    return xp.stack(out, axis=1)


def simulate_piston(
    params: PneumaticParams | None = None,
    t_end: float = 10.0,
    fs: float = 1000.0,
    batch: int | None = None,
    sensors: bool | Sequence[str] = True,
    seed: int | np.random.SeedSequence | np.random.Generator | None = None,
    dt: float = 2e-4,
    sensor_specs: Mapping | None = None,
    progress: bool | None = None,
) -> PneumaticResponse:
    """Simulate the pneumatic piston for a batch of members on a fixed step.

    All members are stepped together (IMEX scheme, see the module notes): numpy by
    default, torch with autograd when any parameter is a torch tensor. A 10 s recording
    of 1000 members takes about 12 s of CPU time at the default step on a 2-core x86
    machine (states only; all fifteen sensors add roughly half of that again, mostly
    allocating the (members x samples) arrays: pick ``sensors`` to keep what you need).

    Parameters
    ----------
    params : PneumaticParams, optional
        Scalar or batched parameters (fields of shape ``(n_members,)``); default
        ``PneumaticParams()``.
    t_end : float
        Length of the recording in s (10 s in the seed's dataset).
    fs : float
        Output sampling rate in Hz (1 kHz).
    batch : int, optional
        Number of members for scalar parameters (identical physics; sensor noise
        differs). Must match ``params.n_members`` if given with batched parameters.
    sensors : bool or sequence of str
        True: all fifteen sensors of seed table 3.1 in :attr:`outputs`; a list: those
        sensors; False: none (states and signals only).
    seed : int, numpy SeedSequence or Generator, optional
        Seed of the sensor noise (each sensor has its own stream, so choosing a subset
        of ``sensors`` does not change the noise of the others).
    dt : float
        Integration step in s; ``1 / (fs * dt)`` must be a whole number.
    sensor_specs : dict of str to SensorSpec, optional
        Overrides of :func:`default_sensor_specs` (sensor faults), by sensor name.
    progress : bool, optional
        Show a progress bar (default: only on a terminal).

    Returns
    -------
    PneumaticResponse
        ``time`` (n_samples,); ``states`` position, velocity, pressure_a, pressure_b,
        pressure_supply, spool; ``signals`` acceleration, mass_flow_a,
        mass_flow_exhaust, force_top, force_bottom (means over each sample interval),
        temperature_a/b; ``inputs`` valve_command; ``outputs`` the sensor readings;
        all ``(n_members, n_samples)``.

    Examples
    --------
    >>> from pdmkit.models import PneumaticParams, simulate_piston, stack_params
    >>> p = stack_params([PneumaticParams(), PneumaticParams(mass_load=6.25)])
    >>> r = simulate_piston(p, t_end=1.0, seed=0)
    >>> r.states["position"].shape, sorted(r.outputs)[:2]
    ((2, 1000), ['AccelerometerMoving_axisZ', 'AccelerometerStatic_axisZ'])
    >>> bool(r.states["position"][0].max() > 0.159)   # the light piston reached the top
    True
    """
    if params is None:
        params = PneumaticParams()
    if not isinstance(params, PneumaticParams):
        raise ModelError(
            "simulate_piston: params must be a PneumaticParams; got "
            f"{type(params).__name__}."
        )
    n_samples, n_sub, h = _check_timing(t_end, fs, dt)
    n = _n_members(params, batch)
    if sensors is True:
        names = list(SENSOR_NAMES)
    elif sensors is False or sensors is None:
        names = []
    else:
        names = list(sensors)
        unknown = [s for s in names if s not in SENSOR_UNITS]
        if unknown:
            raise ModelError(
                f"simulate_piston: unknown sensors {unknown}; choose from "
                f"{', '.join(SENSOR_NAMES)}."
            )
    specs = resolve_specs(sensor_specs)
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        # a diverging run is detected and reported right below
        xp, _, states, signals, acc0 = _integrate(params, n, n_samples, n_sub, h, progress)
    _check_finite(states, dt)
    # mean acceleration over each sample interval (what a sampled accelerometer sees)
    v = states["velocity"]
    first = (acc0 + 0.0 * v[:, 0])[:, None]
    signals["acceleration"] = xp.concat([first, (v[:, 1:] - v[:, :-1]) * fs], axis=1)
    signals["temperature_a"] = _gas_temperatures(states["pressure_a"], params, fs, xp)
    signals["temperature_b"] = _gas_temperatures(states["pressure_b"], params, fs, xp)
    time = np.arange(n_samples) / fs
    t_in = xp.asarray(time)
    u = valve_command(t_in, params)
    u = u + 0.0 * states["position"]  # broadcast to (n_members, n_samples)
    outputs = {}
    if names:
        raw = {k: xp.to_numpy(val) for k, val in {**states, **signals}.items()}
        p_np = params if not params.is_torch else _detached(params)
        outputs = sensor_outputs(raw, p_np, fs, specs, names, seed)
    units = {**STATE_UNITS, **SIGNAL_UNITS, **SENSOR_UNITS, "valve_command": "-"}
    return PneumaticResponse(
        time,
        states=states,
        outputs=outputs,
        inputs={"valve_command": u},
        signals=signals,
        units=units,
        params=params,
        sensor_specs={k: specs[k] for k in names},
    )


def _detached(params: PneumaticParams) -> PneumaticParams:
    changes = {}
    for f in dataclasses.fields(params):
        v = getattr(params, f.name)
        if is_torch(v):
            arr = v.detach().cpu().numpy()
            changes[f.name] = float(arr) if arr.ndim == 0 else arr
    return dataclasses.replace(params, **changes)


def _check_finite(states, dt):
    for k, val in states.items():
        arr = val.detach().cpu().numpy() if is_torch(val) else val
        bad = ~np.all(np.isfinite(arr), axis=1)
        if k.startswith("pressure"):
            bad |= np.any(arr <= 0, axis=1)
        if np.any(bad):
            members = np.flatnonzero(bad)[:10].tolist()
            raise ModelError(
                f"simulate_piston: the integration diverged ({k} not finite/positive) for "
                f"members {members}; dt = {dt:g} s is too large for these parameters "
                "(very large valve coefficients, stiffer stops or tiny volumes). Use a "
                "smaller dt."
            )


def _switch_times(params: PneumaticParams, t_end: float) -> list[float]:
    """Times at which the delayed valve command jumps (for piecewise reference runs)."""
    start = float(params.cycle_start) + float(params.valve_delay)
    period = float(params.cycle_period)
    duty = float(params.cycle_duty)
    times = []
    k = 0
    while start + k * period < t_end:
        for t in (start + k * period, start + (k + duty) * period):
            if 0.0 < t < t_end and 0.0 < duty < 1.0:
                times.append(t)
        k += 1
    return sorted(times)


def simulate_piston_ivp(
    params: PneumaticParams | None = None,
    t_end: float = 10.0,
    fs: float = 1000.0,
    method: str = "LSODA",
    rtol: float = 1e-6,
    atol: float | ArrayLike | None = None,
) -> PneumaticResponse:
    """Reference solution of the same :func:`piston_rhs` with ``scipy.integrate.solve_ivp``.

    The recording is integrated piecewise between the jumps of the delayed valve
    command, so the adaptive solver never steps over a switch. One member at a time
    (scalar parameters, or each member of batched parameters in turn); states only.

    Parameters
    ----------
    params : PneumaticParams, optional
        Parameters; default ``PneumaticParams()``.
    t_end, fs : float
        Recording length (s) and output rate (Hz), as in :func:`simulate_piston`.
    method : str
        solve_ivp method ("LSODA", "Radau", "BDF", ...).
    rtol : float
        Relative tolerance.
    atol : float or array_like, optional
        Absolute tolerance; default tight per state: 1e-9 m, 1e-7 m/s, 1e-3 Pa, 1e-9.

    Returns
    -------
    PneumaticResponse
        With ``states`` only.

    Examples
    --------
    >>> from pdmkit.models import simulate_piston_ivp
    >>> ref = simulate_piston_ivp(t_end=0.4)
    >>> round(float(ref.states["position"][0, -1]), 2)   # at the top after 0.4 s
    0.16
    """
    from scipy.integrate import solve_ivp

    if params is None:
        params = PneumaticParams()
    if params.is_torch:
        params = _detached(params)
    n_samples, _, _ = _check_timing(t_end, fs, 1.0 / fs)
    if atol is None:
        atol = np.array([1e-9, 1e-7, 1e-3, 1e-3, 1e-3, 1e-9])
    t_eval = np.arange(n_samples) / fs
    members = (
        [params]
        if params.n_members is None
        else [params.member(i) for i in range(params.n_members)]
    )
    out = np.empty((len(members), len(STATE_NAMES), n_samples))
    for m, p in enumerate(members):
        edges = [0.0, *_switch_times(p, t_eval[-1]), t_eval[-1]]
        y = np.asarray(initial_state(p), dtype=np.float64)
        out[m, :, 0] = y
        for a, b in itertools.pairwise(edges):
            if b <= a:
                continue
            sel = (t_eval > a) & (t_eval <= b)
            te = t_eval[sel]
            if te.size == 0 or te[-1] != b:
                te = np.append(te, b)
            sol = solve_ivp(
                piston_rhs,
                (a, b),
                y,
                method=method,
                rtol=rtol,
                atol=atol,
                t_eval=te,
                args=(p,),
            )
            if not sol.success:
                raise ModelError(
                    f"simulate_piston_ivp: {method} failed on member {m} in [{a:g}, {b:g}] "
                    f"s: {sol.message}"
                )
            n_sel = int(sel.sum())
            out[m][:, sel] = sol.y[:, :n_sel]
            y = sol.y[:, -1]
    states = {k: out[:, i, :] for i, k in enumerate(STATE_NAMES)}
    return PneumaticResponse(
        t_eval,
        states=states,
        units=dict(STATE_UNITS),
        params=params,
        name="pneumatic piston (solve_ivp)",
    )
