"""EMPS prismatic axis, OPEN LOOP, WITH its known Coulomb friction and force offset.

The direct dynamic model of the EMPS description (Janot, Gautier, Brunot 2019, eq. 3),
in full:

    M q'' = F - Fv q' - Fc sign(q') - offset

This file already holds what `model.py` leaves out (the Coulomb friction Fc and the
constant force offset), so the right verdict of `pdmkit mismatch` on it is `none`, or
at most a minor effect the data support.  It is the "real control" of
examples/README.md, "Controls: the known effect already in the file".

sign(q') is smoothed as tanh(q' / v_smooth) with v_smooth = 2 mm/s (trusted): the axis
moves at 1.5-12.5 cm/s for 95 % of the estimation record, and the smoothing keeps the
friction's time constant M v_smooth / Fc near 10 ms, resolved at the record's 1 kHz.
Input F = gtau * vir (gtau = 35.15 N/V, written by prepare.py), output q = qm (m).
Nominal values are the IDIM-LS estimates printed in the description (M = 95.1 kg,
Fv = 203.5 N s/m, Fc = 20.4 N, offset = -3.16 N, i.e. a constant +3.16 N pushes the
load); M, Fv, Fc and the offset are re-estimated.
"""

import numpy as np

STATES = {"q": "position", "v": "velocity"}  # m, m/s
INPUTS = {"F": "force"}  # N, gtau * vir
OUTPUTS = ["q"]
PARAMS = {
    "M": 95.1,  # moving mass, kg
    "Fv": 203.5,  # viscous friction, N s/m
    "Fc": 20.4,  # Coulomb friction, N
    "offset": -3.16,  # constant force offset of the description's model, N
    "v_smooth": 0.002,  # speed over which sign(q') is smoothed, m/s (trusted)
}
FREE = ["M", "Fv", "Fc", "offset"]
INITIAL = {"q": 0.0, "v": 0.0}


def rhs(t, x, u, p):
    friction = p["Fv"] * x["v"] + p["Fc"] * np.tanh(x["v"] / p["v_smooth"])
    return {"q": x["v"], "v": (u["F"] - friction - p["offset"]) / p["M"]}
