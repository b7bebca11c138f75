"""Cascaded tanks benchmark (Schoukens et al. 2016): Torricelli, no overflow.

u: pump voltage (V); y = h2: lower-tank level sensor (V). The upper-tank level h1 is in
the units the pump gain (fixed at 1) gives it. The water-level sensor and the pump are
taken as ideal; k1, k2, k3 are re-estimated.
"""

STATES = {"h1": "level", "h2": "level"}
INPUTS = {"u": "voltage"}
OUTPUTS = ["h2"]
PARAMS = {"k1": 0.2, "k2": 0.015, "k3": 0.09}
FREE = ["k1", "k2", "k3"]
INITIAL = {"h1": 150.0, "h2": 5.0}


def rhs(t, x, u, p):
    """The level derivatives: the pump fills tank 1, which drains into tank 2."""
    return {
        "h1": u["u"] - p["k1"] * abs(x["h1"]) ** 0.5,
        "h2": p["k2"] * abs(x["h1"]) ** 0.5 - p["k3"] * abs(x["h2"]) ** 0.5,
    }
