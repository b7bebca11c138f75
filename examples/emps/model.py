"""EMPS prismatic axis, OPEN LOOP: mass + viscous friction only.

Direct dynamic model of the EMPS description (Janot, Gautier, Brunot 2019, eq. 3)
WITHOUT the Coulomb friction Fc*sign(q') and the constant force offset:

    M q'' = F - Fv q'

Input F is the force on the load side, F = gtau * vir with the drive gain
gtau = 35.15 N/V from the description (eq. 7) and vir the measured control voltage;
prepare.py writes that product into the column F.  Output q = qm (m).
Nominal M and Fv are the IDIM-LS estimates printed in the description
(M = 95.1 kg, Fv = 203.5 N s/m); both are re-estimated.  The axis is a pure
integrator, so open-loop simulation of the position drifts with any force error: the
description calls this case hard (74.6 % relative error for a linear transfer function).
"""

STATES = {"q": "position", "v": "velocity"}  # m, m/s
INPUTS = {"F": "force"}  # N, gtau * vir
OUTPUTS = ["q"]
PARAMS = {"M": 95.0, "Fv": 200.0}  # kg, N s/m
FREE = ["M", "Fv"]
INITIAL = {"q": 0.0, "v": 0.0}


def rhs(t, x, u, p):
    return {"q": x["v"], "v": (u["F"] - p["Fv"] * x["v"]) / p["M"]}
