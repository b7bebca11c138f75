# ruff: noqa  (an independent outside reference, kept as its author wrote it)
"""Simulation helpers (scipy only) for the pneumatic rig model.

simulate(p, rec, t_eval, effects) integrates the scalar model_thesis.rhs with
scipy.integrate.solve_ivp(method="Radau") (4x faster here than the batched
model_numpy.rhs with vectorized=True), restarting the integrator at every
switch of the 0/1 valve commands; outputs are then evaluated in one batch with
model_numpy.outputs (same equations, see check_styles.py).

Optional extra effects (not in the thesis's healthy base model):
  "deadtime":  valve/line transport delay tau (the e^{-tau s} of eq. 4.28):
               every command switch acts tau seconds late      (param "tau")
  "spool":     first-order spool lag 1/(T s + 1) of eq. 4.28 on the command
               u = WP - HP, extra state s                     (param "T_sp")
  "supply":    measured supply sag: p_s(t) = p0 + AirPressure(t) [bar g], the
               recording's reservoir pressure, 50 ms moving average
  "polytropic": exponent n_poly of the chamber pressure equations (4.19)/(4.20)
               re-estimated (1 = isothermal, 1.4 = adiabatic)       (param "n_poly")
  "deadvol":   dead volumes V0A, V0B re-estimated (params "V0A", "V0B")
  "linevol":   the same, started from 20 cm^3 per side (line volumes)
"""

import os
import sys

import numpy as np
import pandas as pd
from scipy.integrate import solve_ivp

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import model_numpy as M
import model_thesis as MT

DATA = "/work/shared/data/pneumatic_rig/"
SKEYS = list(M.STATES)


def load(name):
    d = pd.read_csv(DATA + name + ".csv")
    rec = {
        c: d[c].to_numpy(float)
        for c in [
            "time",
            "outValveHP",
            "outValveWP",
            "LeverPosition",
            "FlowExtrusion",
            "FlowContraction",
            "AirPressure",
        ]
    }
    k = 50
    ap = np.convolve(
        np.pad(rec["AirPressure"], (k // 2, k - 1 - k // 2), mode="edge"),
        np.ones(k) / k,
        mode="valid",
    )
    rec["AirPressure_f"] = ap
    return rec


def switch_segments(rec, tau=0.0):
    """[(t_start, t_end, HP, WP)] with constant commands, switches delayed by tau."""
    t, hp, wp = rec["time"], rec["outValveHP"], rec["outValveWP"]
    idx = np.where((np.diff(hp) != 0) | (np.diff(wp) != 0))[0] + 1
    starts = [t[0]] + [t[i] + tau for i in idx]
    vals = [(hp[0], wp[0])] + [(hp[i], wp[i]) for i in idx]
    ends = starts[1:] + [t[-1]]
    return [(a, b, v[0], v[1]) for a, b, v in zip(starts, ends, vals) if b > a]


def simulate(p, rec, t_eval, effects=(), rtol=1e-5, max_step=np.inf):
    p = dict(p)
    spool = "spool" in effects
    supply = "supply" in effects
    tau = p.get("tau", 0.0) if "deadtime" in effects else 0.0
    keys = SKEYS + (["s"] if spool else [])
    y0 = np.array([M.INITIAL[k] for k in SKEYS] + ([0.0] if spool else []), float)
    # initial command: home position -> s = WP - HP
    if spool:
        y0[-1] = rec["outValveWP"][0] - rec["outValveHP"][0]
    atol = np.array([1e-7, 1e-5, 1.0, 1.0] + ([1e-6] if spool else []))
    tt, ap = rec["time"], rec["AirPressure_f"]
    Y = np.full((len(keys), len(t_eval)), np.nan)
    U = np.zeros((2, len(t_eval)))
    nfev = 0
    for ta, tb, hp, wp in switch_segments(rec, tau):
        ucmd = wp - hp

        u0 = {"outValveHP": hp, "outValveWP": wp}

        def f(t, y):
            x = {"x": y[0], "v": y[1], "pA": y[2], "pB": y[3]}
            pp = p
            if supply:
                pp = dict(p)
                pp["ps"] = p["p0"] + 1e5 * float(np.interp(t, tt, ap))
            if spool:
                u = {"outValveHP": 0.0, "outValveWP": y[4]}
            else:
                u = u0
            d = MT.rhs(t, x, u, pp)
            out = [d["x"], d["v"], d["pA"], d["pB"]]
            if spool:
                out.append((ucmd - y[4]) / p["T_sp"])
            return out

        m = (t_eval >= ta) & ((t_eval < tb) | (tb >= t_eval[-1]))
        te = t_eval[m]
        ext = te.size == 0 or te[-1] < tb
        te_i = np.append(te, tb) if ext else te
        sol = solve_ivp(
            f,
            (ta, tb),
            y0,
            method="Radau",
            t_eval=te_i,
            rtol=rtol,
            atol=atol,
            max_step=max_step,
        )
        nfev += sol.nfev
        if not sol.success:
            raise RuntimeError(sol.message)
        Y[:, m] = sol.y[:, : te.size]
        if spool:
            U[:, m] = np.vstack([0.0 * sol.y[-1, : te.size], sol.y[-1, : te.size]])
        else:
            U[:, m] = np.array([[hp], [wp]])
        y0 = sol.y[:, -1].copy()
    X = {k: Y[i] for i, k in enumerate(SKEYS)}
    pp = dict(p)
    if supply:
        pp["ps"] = p["p0"] + 1e5 * np.interp(t_eval, tt, ap)
    out = M.outputs(t_eval, X, {"outValveHP": U[0], "outValveWP": U[1]}, pp)
    out["_states"] = X
    out["_nfev"] = nfev
    return out


def rmse(a, b):
    m = np.isfinite(a) & np.isfinite(b)
    return float(np.sqrt(np.mean((a[m] - b[m]) ** 2)))
