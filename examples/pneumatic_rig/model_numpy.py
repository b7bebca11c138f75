"""Batched (numpy) version of model_thesis.py: identical equations, every value
in x/u/p may be a float or a 1-D numpy array (members of a batch).
See model_thesis.py for the thesis references (chapter 4, eqs 4.13-4.38)."""

import math

import numpy as np

STATES = {"x": "position", "v": "velocity", "pA": "pressure", "pB": "pressure"}
INPUTS = {"outValveHP": "other", "outValveWP": "other"}
OUTPUTS = {"LeverPosition": "position", "FlowExtrusion": "flow", "FlowContraction": "flow"}

_P0 = 101325.0
PARAMS = {
    "kappa": 1.4,
    "n_poly": 1.4,
    "R": 287.1,
    "T": 296.0,
    "ps": _P0 + 6.0e5,
    "p0": _P0,
    "b": 0.5282817877171742,
    "r_lam": 0.999,
    "g": 9.81,
    "M": 6.7798462575453,
    "ML": 6.25,
    "dA": 0.020,
    "dS": 0.008,
    "L": 0.2,
    "V0A": math.pi * 0.020**2 / 4 * 0.015,
    "V0B": (math.pi * 0.020**2 / 4 - math.pi * 0.008**2 / 4) * 0.015,
    "C_A_in": 6.0242e-07,
    "C_A_out": 5.155e-07,
    "C_B_in": 1.7518e-07,
    "C_B_out": 9.1476e-07,
    "F_C": 0.0,
    "B_v": 0.0,
    "v_eps": 1e-3,
    "g_p": 0.19382,
    "g_n": 0.0,
    "K_hs": 1e7,
    "D_hs": 1e2,
    "b_up": 1543.1,
    "b_bot": 2596.5,
    "x_up": 0.18123,
    "x_bot": 0.01054,
    "rho_n": 1.2,
}
FREE = ["C_A_in", "C_A_out", "C_B_in", "C_B_out", "b_up", "b_bot", "F_C"]
INITIAL = {"x": 0.0, "v": 0.0, "pA": _P0, "pB": _P0 + 6.0e5}


def psi(r, kappa, b, r_lam):
    rc = np.clip(r, b, r_lam)
    val = np.sqrt(
        kappa / (kappa - 1.0) * (rc ** (2.0 / kappa) - rc ** ((kappa + 1.0) / kappa))
    )
    lin = val * np.maximum(1.0 - r, 0.0) / (1.0 - r_lam)
    return np.where(r >= r_lam, lin, val)


def mass_flow(p1, p2, C, T1, p):
    return (
        C * p1 * np.sqrt(2.0 / (p["R"] * T1)) * psi(p2 / p1, p["kappa"], p["b"], p["r_lam"])
    )


def valve_command(u):
    return u["outValveWP"] - u["outValveHP"]


def chamber_flow(uc, pc, C_in, C_out, p):
    fill = uc * mass_flow(p["ps"], pc, C_in, p["T"], p)
    empty = uc * mass_flow(pc, p["p0"], C_out, p["T"], p)
    return np.where(uc > 0, fill, np.where(uc < 0, empty, 0.0))


def areas(p):
    SA = np.pi * p["dA"] ** 2 / 4.0
    S0 = np.pi * p["dS"] ** 2 / 4.0
    return SA, SA - S0, S0


def rhs(t, x, u, p):
    pos, vel, pA, pB = x["x"], x["v"], x["pA"], x["pB"]
    SA, SB, S0 = areas(p)
    uc = valve_command(u)
    mA = chamber_flow(uc, pA, p["C_A_in"], p["C_A_out"], p)
    mB = chamber_flow(-uc, pB, p["C_B_in"], p["C_B_out"], p)
    VA = SA * pos + p["V0A"]
    VB = SB * (p["L"] - pos) + p["V0B"]
    dpA = p["n_poly"] / VA * (-pA * SA * vel + p["R"] * p["T"] * mA)
    dpB = p["n_poly"] / VB * (pB * SB * vel + p["R"] * p["T"] * mB)
    m_tot = p["M"] + p["ML"]
    F_p = pA * SA - pB * SB - p["p0"] * S0
    F_g = m_tot * p["g"]
    F_f = p["F_C"] * np.tanh(vel / p["v_eps"]) + p["B_v"] * vel
    F_hs = np.where(
        pos >= p["g_p"],
        p["K_hs"] * (pos - p["g_p"]) + p["D_hs"] * np.maximum(vel, 0.0),
        np.where(
            pos <= p["g_n"],
            p["K_hs"] * (pos - p["g_n"]) + p["D_hs"] * np.minimum(vel, 0.0),
            0.0,
        ),
    )
    F_d = np.where(
        (pos >= p["x_up"]) & (vel > 0),
        p["b_up"] * vel,
        np.where((pos <= p["x_bot"]) & (vel < 0), p["b_bot"] * vel, 0.0),
    )
    acc = (F_p - F_d - F_g - F_hs - F_f) / m_tot
    return {"x": vel + 0.0 * acc, "v": acc, "pA": dpA, "pB": dpB}


def outputs(t, x, u, p):
    uc = valve_command(u)
    mA = chamber_flow(uc, x["pA"], p["C_A_in"], p["C_A_out"], p)
    q = mA / p["rho_n"] * 60000.0
    return {
        "LeverPosition": x["x"] + 0.0 * q,
        "FlowExtrusion": np.maximum(q, 0.0),
        "FlowContraction": np.maximum(-q, 0.0),
    }
