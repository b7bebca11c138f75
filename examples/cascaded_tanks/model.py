"""Cascaded tanks: two tanks in series, Torricelli outflow, pump input.
No overflow of the upper tank, ideal (non-saturating) level sensor: finding what is
missing is pdmkit's job.

    h1' = -k1*sqrt(h1) + k4*u          upper tank, fed by the pump
    h2' =  k2*sqrt(h1) - k3*sqrt(h2)   lower tank, fed by the upper one

Levels are in the sensor's volts (the data gives only the lower-tank sensor, 0-10 V),
u is the pump voltage (V), time in seconds (Ts = 4 s).  k1 and k2 differ because the
areas of the tanks may differ.  abs() keeps sqrt defined if a level dips below zero
during the fit.  Nominal values: time constants of a few hundred seconds around a level
of 5 V with a pump voltage of about 4 V; all four are re-estimated.
"""

STATES = {"h1": "level", "h2": "level"}
INPUTS = {"u": "voltage"}
OUTPUTS = ["h2"]
PARAMS = {"k1": 0.05, "k2": 0.05, "k3": 0.05, "k4": 0.03}
FREE = ["k1", "k2", "k3", "k4"]
INITIAL = {"h1": 5.0, "h2": 5.0}


def rhs(t, x, u, p):
    return {
        "h1": -p["k1"] * abs(x["h1"]) ** 0.5 + p["k4"] * u["u"],
        "h2": p["k2"] * abs(x["h1"]) ** 0.5 - p["k3"] * abs(x["h2"]) ** 0.5,
    }
