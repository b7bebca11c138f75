"""Double-acting vertical pneumatic piston rig -- first-principle model written
as the thesis writes it (scalar style).

Source: thesis /work/shared/seeds/001_335ae2076e497459.txt, chapter 4
(A. Voronin, Brno 2021), with the numeric constants of its attachment
``models/params.m`` (datasheet values and the author's healthy-case estimates).

Equations used (thesis numbering):
  (4.14)-(4.16)  outflow function psi, choked below the critical ratio b
  (4.13),(4.31)  mass flow  mdot = u * C * p1 * sqrt(2/(R T1)) * psi(p2/p1)
  (4.32),(4.33)  5/2 valve: u=+1 fills the chamber from p_s, u=-1 empties it to p_0
  (4.21)-(4.26)  adiabatic chamber pressures  pA' , pB'  (exponent n_poly = kappa;
                 n_poly = 1 gives the isothermal (4.19))
  (4.35),(4.36)  (M+M_L) x'' + F_d + F_g + F_hs + F_f = F_p,  F_p = pA SA - pB SB - p0 S0
  (4.37)         F_f = F_C sign(x') + B_v x'
  (4.38)         hard stop: one-sided spring + damper at g_n, g_p
  4.5.3          end dampers: one-sided dampers (coefficient only) from x_bot / x_up
  4.6            flow sensors: mass flow [kg/s] -> l/min (normal density rho_n)

Deviations (numerical / interpretive, documented in RESULTS.md):
  * (4.16) is printed with a typo (p1/rho1 inside the root); the standard
    dimensionless Saint-Venant form is used, whose maximum 0.484 (4.15) matches.
  * psi is linearised for p2/p1 > r_lam (=0.999, params.m's B_lam idea) so that
    its infinite slope at p2/p1 -> 1 does not make the ODE needlessly stiff.
  * sign(v) in (4.37) is regularised as tanh(v / v_eps), v_eps = 1 mm/s.
  * valve command u = outValveWP - outValveHP (WP: chamber A filled, B emptied;
    HP: A emptied, B filled), the thesis's u in {-1, +1} of (4.27).
  * x is the lever position (encoder), taken 1:1 as the piston position.
"""

import math

STATES = {"x": "position", "v": "velocity", "pA": "pressure", "pB": "pressure"}
INPUTS = {"outValveHP": "other", "outValveWP": "other"}
OUTPUTS = {"LeverPosition": "position", "FlowExtrusion": "flow", "FlowContraction": "flow"}

_P0 = 101325.0
PARAMS = {
    # gas (4.1), (4.2), params.m 1.0
    "kappa": 1.4,  # [-] heat capacity ratio
    "n_poly": 1.4,  # [-] exponent of the chamber pressure eqs (4.20): kappa = adiabatic
    "R": 287.1,  # [J/kg/K]
    "T": 296.0,  # [K] air temperature (measured cylinder temp ~23 C)
    "ps": _P0 + 6.0e5,  # [Pa abs] supply: 6 bar gauge (AirPressure sensor ~6.0)
    "p0": _P0,  # [Pa abs] atmosphere
    "b": 0.5282817877171742,  # [-] critical pressure ratio (2/(k+1))^(k/(k-1)) (4.14)
    "r_lam": 0.999,  # [-] psi linearised above this ratio (numerics)
    # mechanics, params.m 1.1.1
    "g": 9.81,
    "M": 6.7798462575453,  # [kg] moving mass (author's estimate)
    "ML": 6.25,  # [kg] load mass
    "dA": 0.020,  # [m] piston diameter
    "dS": 0.008,  # [m] rod diameter
    "L": 0.2,  # [m] stroke
    "V0A": math.pi * 0.020**2 / 4 * 0.015,  # [m^3]
    "V0B": (math.pi * 0.020**2 / 4 - math.pi * 0.008**2 / 4) * 0.015,  # [m^3]
    # valve coefficients C = S_max*C_d [m^2] (4.31), author's healthy estimate
    "C_A_in": 6.0242e-07,
    "C_A_out": 5.155e-07,
    "C_B_in": 1.7518e-07,
    "C_B_out": 9.1476e-07,
    # friction (4.37): author found it negligible
    "F_C": 0.0,  # [N] Coulomb
    "B_v": 0.0,  # [N s/m] viscous
    "v_eps": 1e-3,  # [m/s] sign() regularisation
    # hard stop (4.38), params.m 1.3
    "g_p": 0.19382,
    "g_n": 0.0,
    "K_hs": 1e7,
    "D_hs": 1e2,
    # small end dampers (4.5.3), params.m 2.1 (healthy estimates)
    "b_up": 1543.1,
    "b_bot": 2596.5,  # [N s/m]
    "x_up": 0.18123,
    "x_bot": 0.01054,  # [m] damper engagement points
    # flow sensor (4.6): l/min = mdot / rho_n * 60000
    "rho_n": 1.2,
}

FREE = ["C_A_in", "C_A_out", "C_B_in", "C_B_out", "b_up", "b_bot", "F_C"]

# valve in home position at t=0: A vented, B at supply, lever resting on the
# bottom stop (x=0 in all three recordings)
INITIAL = {"x": 0.0, "v": 0.0, "pA": _P0, "pB": _P0 + 6.0e5}


def psi(r, kappa, b, r_lam):
    """Outflow function (4.16) of the pressure ratio r = p2/p1."""
    if r <= b:
        # choked (overcritical) flow: psi_max (4.15)
        rc = b
    elif r < r_lam:
        rc = r
    else:
        rc = r_lam
    val = math.sqrt(
        kappa / (kappa - 1.0) * (rc ** (2.0 / kappa) - rc ** ((kappa + 1.0) / kappa))
    )
    if r >= r_lam:
        # linear (laminar-like) end of the characteristic, zero at r = 1
        val = val * max(1.0 - r, 0.0) / (1.0 - r_lam)
    return val


def mass_flow(p1, p2, C, T1, p):
    """(4.13)/(4.31) without the sign: flow from p1 to p2 (>= 0)."""
    return (
        C
        * p1
        * math.sqrt(2.0 / (p["R"] * T1))
        * psi(p2 / p1, p["kappa"], p["b"], p["r_lam"])
    )


def valve_command(u):
    """u in {-1, 0, +1}: +1 = work position (A filling), -1 = home (A emptying)."""
    return u["outValveWP"] - u["outValveHP"]


def chamber_flow(uc, pc, C_in, C_out, p):
    """(4.32)/(4.33): mass flow into a chamber at pressure pc for command uc."""
    if uc > 0:
        return uc * mass_flow(p["ps"], pc, C_in, p["T"], p)
    elif uc < 0:
        return uc * mass_flow(pc, p["p0"], C_out, p["T"], p)
    else:
        return 0.0


def areas(p):
    SA = math.pi * p["dA"] ** 2 / 4.0
    S0 = math.pi * p["dS"] ** 2 / 4.0
    return SA, SA - S0, S0


def rhs(t, x, u, p):
    pos, vel, pA, pB = x["x"], x["v"], x["pA"], x["pB"]
    SA, SB, S0 = areas(p)
    uc = valve_command(u)
    mA = chamber_flow(uc, pA, p["C_A_in"], p["C_A_out"], p)
    mB = chamber_flow(-uc, pB, p["C_B_in"], p["C_B_out"], p)

    # chamber pressures (4.25), (4.26)
    VA = SA * pos + p["V0A"]
    VB = SB * (p["L"] - pos) + p["V0B"]
    dpA = p["n_poly"] / VA * (-pA * SA * vel + p["R"] * p["T"] * mA)
    dpB = p["n_poly"] / VB * (pB * SB * vel + p["R"] * p["T"] * mB)

    # forces (4.35)-(4.38)
    m_tot = p["M"] + p["ML"]
    F_p = pA * SA - pB * SB - p["p0"] * S0
    F_g = m_tot * p["g"]
    F_f = p["F_C"] * math.tanh(vel / p["v_eps"]) + p["B_v"] * vel
    if pos >= p["g_p"]:
        F_hs = p["K_hs"] * (pos - p["g_p"]) + p["D_hs"] * vel * (1.0 if vel >= 0 else 0.0)
    elif pos <= p["g_n"]:
        F_hs = p["K_hs"] * (pos - p["g_n"]) + p["D_hs"] * vel * (1.0 if vel <= 0 else 0.0)
    else:
        F_hs = 0.0
    if pos >= p["x_up"] and vel > 0:
        F_d = p["b_up"] * vel
    elif pos <= p["x_bot"] and vel < 0:
        F_d = p["b_bot"] * vel
    else:
        F_d = 0.0
    acc = (F_p - F_d - F_g - F_hs - F_f) / m_tot
    return {"x": vel, "v": acc, "pA": dpA, "pB": dpB}


def outputs(t, x, u, p):
    uc = valve_command(u)
    mA = chamber_flow(uc, x["pA"], p["C_A_in"], p["C_A_out"], p)
    q = mA / p["rho_n"] * 60000.0  # kg/s -> l/min (normal)
    return {
        "LeverPosition": x["x"],
        "FlowExtrusion": max(q, 0.0),
        "FlowContraction": max(-q, 0.0),
    }
