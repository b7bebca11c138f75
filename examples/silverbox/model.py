"""Silverbox as a plain LINEAR mass-spring-damper (no cubic stiffness).

The Silverbox is an electronic circuit emulating  m*y'' + c*y' + k*y (+ k3*y**3) = gain*V1.
Here the cubic term is deliberately left out: finding it is pdmkit's job.

Units are those of the data: y = V2 (output voltage, V) plays the displacement, V1 the
input voltage (V).  The mass is normalised to m = 1, so k is omega0**2 (1/s**2), c is
2*zeta*omega0 (1/s) and gain/k is the static gain V2/V1.  Nominal values are rounded
from a quick look at the spectrum of the estimation record (resonance near 69 Hz,
damping ratio about 0.05, static gain about 0.9); k, c and gain are re-estimated.
"""

STATES = {"V2": "position", "v": "velocity"}  # displacement voltage and its rate (V/s)
INPUTS = {"V1": "voltage"}  # input voltage driving the "force"
OUTPUTS = ["V2"]
PARAMS = {
    "m": 1.0,  # normalised mass (trusted)
    "k": 1.8e5,  # stiffness per unit mass, (2*pi*67 Hz)**2, 1/s**2
    "c": 40.0,  # damping per unit mass, 1/s
    "gain": 1.6e5,  # input gain per unit mass, 1/s**2
}
FREE = ["k", "c", "gain"]
INITIAL = {"V2": 0.0, "v": 0.0}


def rhs(t, x, u, p):
    return {
        "V2": x["v"],
        "v": (p["gain"] * u["V1"] - p["c"] * x["v"] - p["k"] * x["V2"]) / p["m"],
    }
