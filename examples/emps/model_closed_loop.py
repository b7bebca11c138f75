"""EMPS prismatic axis in its CLOSED LOOP: the description's PD position controller
inside the model, mass + viscous friction plant, no Coulomb friction, no force offset.

Controller (description eq. 6-7), the two nested loops:
    nu = kp*kv*(qr - q) - kv*q' + pulse      control voltage, V
    F  = gtau * nu                           force on the load, N
with kp = 160.18 1/s, kv = 243.45 V/(m/s), gtau = 35.15 N/V (trusted, not re-estimated).
The real controller differentiates a 2-tap averaged encoder position; here it uses the
velocity state directly.  The 10 V command saturation of the rig is left out (the
recorded command stays within +-9.1 V).

`pulse` is the force-pulse command of the validation record (DATA_EMPS_PULSES,
variable pulses_N).  In the data it steps between 0 and 5 and the recorded command vir
jumps by the same 5 V at each step, so it is added to the control voltage here.  It is
zero throughout the estimation record.

Plant (description eq. 3 without Coulomb and offset):  M q'' = F - Fv q'.
Inputs: reference position qr = qg (m) and pulse (V).  Output q = qm (m).
"""

STATES = {"q": "position", "v": "velocity"}  # m, m/s
INPUTS = {"qr": "position", "pulse": "voltage"}
OUTPUTS = ["q"]
PARAMS = {
    "M": 95.0,  # kg
    "Fv": 200.0,  # N s/m
    "kp": 160.18,  # 1/s
    "kv": 243.45,  # V/(m/s)
    "gtau": 35.15,  # N/V
}
FREE = ["M", "Fv"]
INITIAL = {"q": 0.0, "v": 0.0}


def rhs(t, x, u, p):
    nu = p["kp"] * p["kv"] * (u["qr"] - x["q"]) - p["kv"] * x["v"] + u["pulse"]
    force = p["gtau"] * nu
    return {"q": x["v"], "v": (force - p["Fv"] * x["v"]) / p["M"]}
