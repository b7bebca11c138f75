"""Two cascaded tanks fed by a pump, both levels measured (pdmkit showcase).

The pump delivers b * u; each tank drains through an orifice (Torricelli: outflow
proportional to the square root of the level); tank 1 drains into tank 2.
"""

STATES = {"h1": "level", "h2": "level"}
INPUTS = {"u": "voltage"}
OUTPUTS = ["h1", "h2"]
PARAMS = {"b": 0.002, "k1": 0.015, "k2": 0.015}
FREE = ["b"]
INITIAL = {"h1": 0.1, "h2": 0.1}


def rhs(t, x, u, p):
    """The level derivatives: the pump fills tank 1, which drains into tank 2."""
    q1 = p["k1"] * abs(x["h1"]) ** 0.5
    q2 = p["k2"] * abs(x["h2"]) ** 0.5
    return {"h1": p["b"] * u["u"] - q1, "h2": q1 - q2}
