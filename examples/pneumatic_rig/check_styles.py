"""Self-check: model_thesis.py (scalar) and model_numpy.py (batched) give the
same derivatives and outputs. Run: python check_styles.py"""

import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import model_numpy as mn
import model_thesis as mt

assert mt.STATES == mn.STATES and mt.INPUTS == mn.INPUTS
assert mt.OUTPUTS == mn.OUTPUTS and mt.FREE == mn.FREE and mt.INITIAL == mn.INITIAL
assert mt.PARAMS.keys() == mn.PARAMS.keys()
assert all(abs(mt.PARAMS[k] - mn.PARAMS[k]) <= 1e-15 * abs(mt.PARAMS[k]) for k in mt.PARAMS)

rng = np.random.default_rng(0)
N = 4000
P0, PS = mt.PARAMS["p0"], mt.PARAMS["ps"]
X = {
    "x": rng.uniform(-1e-4, 0.1942, N),
    "v": rng.uniform(-0.7, 0.5, N),
    "pA": rng.uniform(0.9 * P0, 1.02 * PS, N),
    "pB": rng.uniform(0.9 * P0, 1.02 * PS, N),
}
# include exact edge values (stops, dampers, v = 0, p at supply / atmosphere)
X["x"][:8] = [
    0.0,
    mt.PARAMS["g_p"],
    mt.PARAMS["x_up"],
    mt.PARAMS["x_bot"],
    -5e-5,
    0.1939,
    0.1,
    0.0,
]
X["v"][:8] = [0.0, 0.0, 0.1, -0.1, 0.0, 0.01, 0.0, -0.01]
X["pA"][8:12] = [P0, PS, PS * 0.9995, P0 / mt.PARAMS["b"]]
HP = rng.integers(0, 2, N).astype(float)
U = {"outValveHP": HP, "outValveWP": np.where(rng.random(N) < 0.9, 1.0 - HP, HP)}
# random parameter perturbation (+-30 %) of the free parameters
Pb = dict(mn.PARAMS)
for k in mn.FREE:
    Pb[k] = mn.PARAMS[k] * rng.uniform(0.7, 1.3, N) + (
        rng.uniform(0, 5, N) if k == "F_C" else 0.0
    )

dn = mn.rhs(0.0, X, U, Pb)
yn = mn.outputs(0.0, X, U, Pb)
worst_d = {k: 0.0 for k in mt.STATES}
worst_y = {k: 0.0 for k in mt.OUTPUTS}
for i in range(N):
    xi = {k: float(X[k][i]) for k in X}
    ui = {k: float(U[k][i]) for k in U}
    pi = {k: (float(v[i]) if isinstance(v, np.ndarray) else v) for k, v in Pb.items()}
    ds = mt.rhs(0.0, xi, ui, pi)
    ys = mt.outputs(0.0, xi, ui, pi)
    for k in ds:
        e = abs(ds[k] - dn[k][i]) / max(
            abs(ds[k]), 1e-12 * max(1.0, abs(dn[k]).max()), 1e-300
        )
        worst_d[k] = max(worst_d[k], e)
    for k in ys:
        e = abs(ys[k] - yn[k][i]) / max(abs(ys[k]), 1e-9)
        worst_y[k] = max(worst_y[k], e)
print("max relative difference, derivatives:", {k: f"{v:.2e}" for k, v in worst_d.items()})
print("max relative difference, outputs:    ", {k: f"{v:.2e}" for k, v in worst_y.items()})
ok = max(list(worst_d.values()) + list(worst_y.values())) < 1e-12
print("OK" if ok else "MISMATCH")
sys.exit(0 if ok else 1)
