"""Double-acting pneumatic piston with a proportional valve and a load spring (showcase).

A reduced form of pdmkit's pneumatic twin (:mod:`pdmkit.models.pneumatic._twin`) in the
model-file contract: the piston (position x from mid-stroke, velocity v) pushes a spring
load; chambers A (cap end) and B (rod end) are filled from the supply and vented to
ambient through a 5/3 proportional valve with underlap, commanded by u in [-1, 1]
(+1: A to supply, B to ambient). Mass flows are laminar (proportional to the pressure
difference, conductance G); the chamber gas is compressed adiabatically. Measured:
position and both chamber pressures (absolute, Pa), like the twin's sensors. SI units.
The valve conductance G is re-estimated; the rest is from the datasheet.
"""

STATES = {"x": "position", "v": "velocity", "pa": "pressure", "pb": "pressure"}
INPUTS = {"u": "voltage"}
OUTPUTS = ["x", "pa", "pb"]
PARAMS = {
    "m": 2.0,  # moving mass, kg
    "k": 3000.0,  # load spring, N/m
    "c": 60.0,  # viscous friction, N s/m
    "area_a": 4.91e-4,  # piston area, cap end (25 mm bore), m^2
    "area_b": 4.12e-4,  # annulus area, rod end (10 mm rod), m^2
    "half_stroke": 0.15,  # m
    "v_dead": 1.0e-5,  # dead volume of each chamber and its line, m^3
    "p_supply": 6.0e5,  # Pa (absolute)
    "p_ambient": 1.0e5,  # Pa
    "G": 2.0e-9,  # valve conductance, kg/(s Pa)
    "kappa": 1.4,  # heat capacity ratio of air
    "RT": 8.41e4,  # gas constant of air times 293 K, J/kg
}
FREE = ["G"]
INITIAL = {"x": 0.0, "v": 0.0, "pa": 3.5e5, "pb": 3.5e5}


def rhs(t, x, u, p):
    """The state derivatives: valve flows fill and vent the chambers, moving the piston."""
    fill = 0.5 * (1.0 + u["u"])  # opening towards supply for A, towards ambient for B
    vent = 0.5 * (1.0 - u["u"])
    ps, p0, G = p["p_supply"], p["p_ambient"], p["G"]
    qa = G * (fill * (ps - x["pa"]) - vent * (x["pa"] - p0))  # kg/s into A
    qb = G * (vent * (ps - x["pb"]) - fill * (x["pb"] - p0))  # kg/s into B
    vol_a = p["v_dead"] + p["area_a"] * (p["half_stroke"] + x["x"])
    vol_b = p["v_dead"] + p["area_b"] * (p["half_stroke"] - x["x"])
    force = (
        x["pa"] * p["area_a"]
        - x["pb"] * p["area_b"]
        - p0 * (p["area_a"] - p["area_b"])
        - p["k"] * x["x"]
        - p["c"] * x["v"]
    )
    return {
        "x": x["v"],
        "v": force / p["m"],
        "pa": p["kappa"] * (p["RT"] * qa - x["pa"] * p["area_a"] * x["v"]) / vol_a,
        "pb": p["kappa"] * (p["RT"] * qb + x["pb"] * p["area_b"] * x["v"]) / vol_b,
    }
