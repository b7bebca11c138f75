"""Mass-spring-damper driven by a force (pdmkit showcase model file).

The damping c and the mass m are trusted; the stiffness k is re-estimated.
"""

STATES = {"x": "position", "v": "velocity"}
INPUTS = {"F": "force"}
OUTPUTS = ["x"]
PARAMS = {"m": 1.0, "c": 4.0, "k": 400.0}
FREE = ["k"]
INITIAL = {"x": 0.0, "v": 0.0}


def rhs(t, x, u, p):
    """The state derivatives: the force, the spring and the damper accelerate the mass."""
    return {"x": x["v"], "v": (u["F"] - p["c"] * x["v"] - p["k"] * x["x"]) / p["m"]}
