"""Silverbox WITH its known cubic spring: a control for `pdmkit mismatch`.

The Silverbox is an electronic Duffing oscillator (Wigren & Schoukens, ECC 2013):

    m y'' + c y' + k y + k3 y**3 = gain * V1

This file already holds the cubic stiffness k3 that `model.py` leaves out, so the right
verdict of `pdmkit mismatch` on it is `none` (nothing left to explain), or at most a
minor effect the data support (a DC offset, say).  It is the "real control" of
examples/README.md, "Controls: the known effect already in the file".

Units are those of the data, as in `model.py`: y = V2 (output voltage, V) plays the
displacement, V1 (V) the force; the mass is normalised to m = 1, so k is omega0**2
(1/s**2), c is 2*zeta*omega0 (1/s), gain/k the static gain and k3 is in 1/(V**2 s**2).
k, c and gain start from `model.py`'s values.  k3 starts from a rough guess made
before any fit: a spring about 10 % stiffer at the largest estimation amplitude
(|V2| ~ 0.23 V), k3 = 0.1 * k / 0.23**2 ~ 3e5; all four are re-estimated.
"""

STATES = {"V2": "position", "v": "velocity"}  # displacement voltage and its rate (V/s)
INPUTS = {"V1": "voltage"}  # input voltage driving the "force"
OUTPUTS = ["V2"]
PARAMS = {
    "m": 1.0,  # normalised mass (trusted)
    "k": 1.8e5,  # linear stiffness per unit mass, (2*pi*67 Hz)**2, 1/s**2
    "c": 40.0,  # damping per unit mass, 1/s
    "gain": 1.6e5,  # input gain per unit mass, 1/s**2
    "k3": 3.0e5,  # cubic stiffness per unit mass, 1/(V**2 s**2)
}
FREE = ["k", "c", "gain", "k3"]
INITIAL = {"V2": 0.0, "v": 0.0}


def rhs(t, x, u, p):
    spring = p["k"] * x["V2"] + p["k3"] * x["V2"] ** 3
    return {
        "V2": x["v"],
        "v": (p["gain"] * u["V1"] - p["c"] * x["v"] - spring) / p["m"],
    }
