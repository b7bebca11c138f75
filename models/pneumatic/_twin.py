"""Physics of the double-acting pneumatic piston (Voronin's thesis, chapters 3, 4 and 8).

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
from typing import Any

import numpy as np

from pdmkit.errors import ModelError
from pdmkit.models._xp import get_namespace, is_torch
from pdmkit.models.pneumatic._params import (
    PneumaticParams,
    _values,
    piston_areas,
    stack_params,
)

#: A float, numpy array or torch tensor: the twin's functions work on all three.
ArrayOrTensor = Any

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
    r.s_a, r.s_b = piston_areas(p.bore, p.rod_diameter)
    r.s_rod = r.s_a - r.s_b
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


def outflow_function(
    pressure_ratio: ArrayOrTensor, kappa: float = 1.4, laminar_ratio: float = 0.99
) -> ArrayOrTensor:
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
    c: ArrayOrTensor,
    p_up: ArrayOrTensor,
    p_down: ArrayOrTensor,
    t_up: ArrayOrTensor = 293.15,
    kappa: float = 1.4,
    r_gas: float = 287.1,
    laminar_ratio: float = 0.99,
) -> ArrayOrTensor:
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


def valve_command(t: float | ArrayOrTensor, params: PneumaticParams) -> ArrayOrTensor:
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


def piston_rhs(
    t: float | ArrayOrTensor, state: ArrayOrTensor, params: PneumaticParams
) -> ArrayOrTensor:
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
    _, s_b = piston_areas(p.bore, p.rod_diameter)
    load = (p.p_supply - p.p_ambient) * s_b + (p.mass_piston + p.mass_load) * p.gravity
    k_hs, k_ld, k_sd = p.stop_stiffness, p.damper_large_stiffness, p.damper_small_stiffness
    dl, ds = p.damper_large_travel, p.damper_small_travel
    pre = k_ld * dl + k_sd * ds  # spring force of both dampers at x = 0
    x_stop = (pre - load) / (k_hs + k_ld + k_sd)  # on the hard stop (x <= 0)
    x_large = (pre - load) / (k_ld + k_sd + 1e-300)  # within the large damper
    x_small = ds - load / (k_sd + 1e-300)  # within the small damper only
    x = xp.where(load >= pre, x_stop, xp.where(load >= k_sd * (ds - dl), x_large, x_small))
    return xp.minimum(x, ds)


def initial_state(params: PneumaticParams, n_members: int | None = None) -> ArrayOrTensor:
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
