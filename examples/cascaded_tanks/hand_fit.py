"""Hand fits of the Cascaded Tanks structures outside pdmkit (a check on its verdict).

Numpy RK4 (2 steps per 4 s sample) batched over a forward-difference Jacobian,
``scipy.optimize.least_squares`` on the estimation record (both initial levels fitted),
then the validation RMSE with the validation initial state (a) fitted on the whole
record (as pdmkit does), (b) equal to the estimation record's (the benchmark: both
start from the same state), (c) fitted on the first 5 samples, scored from sample 5
(the ``nonlinear_benchmarks`` rule).  The upper tank's overflow is an exact projection
at its rim (level scale fixed by rim = 10) with a fraction ``f`` of the spill reaching
the lower tank; the sensor clips at exactly 10 V.  Run ``python prepare.py`` first;
about a minute per structure on one core.

    python examples/cascaded_tanks/hand_fit.py
"""

from pathlib import Path

import numpy as np
import pandas as pd
from scipy.optimize import least_squares

HERE = Path(__file__).resolve().parent
TS, NSUB, RIM = 4.0, 2, 10.0


def simulate(P, u, x0, deadzone, area, clip=True):
    """Lower-tank reading ``(B, N)`` for parameter rows ``P`` (dict of ``(B,)``)."""
    h1, h2 = (np.array(v, float, copy=True) for v in x0)
    k1, k2, k3, k4, f = P["k1"], P["k2"], P["k3"], P["k4"], P["f"]
    off, u0, c2 = P.get("off", 0.0), P.get("u0", 0.0), P.get("c2", 0.0)
    dt = TS / NSUB

    def rhs(a, b, uu):
        pump = k4 * 0.05 * np.logaddexp(0.0, (uu - u0) / 0.05) if deadzone else k4 * uu
        out1 = np.sqrt(np.maximum(a, 1e-9))
        d1 = pump - k1 * out1
        d2 = k2 * out1 - k3 * np.sqrt(np.maximum(b, 1e-9))
        return d1, d2 / (1.0 + c2 * (b - 5.0)) if area else d2

    Y = np.empty((h1.size, u.size))
    for i, uu in enumerate(u):
        Y[:, i] = np.minimum(h2 + off, 10.0) if clip else h2 + off
        for _ in range(NSUB):
            a1, b1 = rhs(h1, h2, uu)
            a2, b2 = rhs(h1 + 0.5 * dt * a1, h2 + 0.5 * dt * b1, uu)
            a3, b3 = rhs(h1 + 0.5 * dt * a2, h2 + 0.5 * dt * b2, uu)
            a4, b4 = rhs(h1 + dt * a3, h2 + dt * b3, uu)
            h1 = h1 + dt / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
            h2 = h2 + dt / 6 * (b1 + 2 * b2 + 2 * b3 + b4)
            spill = np.maximum(h1 - RIM, 0.0)  # the upper tank overflows at its rim
            h1, h2 = np.maximum(h1 - spill, 0.0), np.maximum(h2 + f * spill, 0.0)
    return Y


def fit(names, th0, lo, hi, rec, opts, mask=None):
    u, y = rec.u.to_numpy(), rec.h2.to_numpy()
    mask = np.ones(y.size, bool) if mask is None else mask

    def sim(TH):
        P = {n: TH[:, j] for j, n in enumerate(names) if not n.startswith("x0")}
        return simulate(P, u, (TH[:, -2], TH[:, -1]), **opts)[:, mask]

    def res(th):
        return sim(th[None])[0] - y[mask]

    def jac(th):
        h = 1e-6 * np.maximum(np.abs(th), 1e-3)
        TH = np.vstack([th, th + np.diag(h)])
        Y = sim(TH)
        return ((Y[1:] - Y[0]) / h[:, None]).T

    return least_squares(res, th0, jac=jac, bounds=(lo, hi), x_scale="jac", max_nfev=300).x


def rmse(names, th, rec, opts, start=0):
    P = {n: np.array([th[j]]) for j, n in enumerate(names) if not n.startswith("x0")}
    e = simulate(P, rec.u.to_numpy(), ([th[-2]], [th[-1]]), **opts)[0] - rec.h2.to_numpy()
    return float(np.sqrt(np.mean(e[start:] ** 2)))


BOUNDS = {
    "k1": (1e-4, 2), "k2": (1e-4, 2), "k3": (1e-4, 2), "k4": (1e-4, 2), "f": (0, 3),
    "off": (-5, 5), "u0": (-2, 2.5), "c2": (-0.15, 0.5), "x0_1": (0, 10), "x0_2": (0, 20),
}  # fmt: skip
START = {
    "k1": 0.05, "k2": 0.03, "k3": 0.03, "k4": 0.055, "f": 0.7, "off": 0.0, "u0": 0.7,
    "c2": -0.1, "x0_1": 4.4, "x0_2": 5.3,
}  # fmt: skip
STRUCTURES = {
    "overflow + 10 V clip": ([], {}),
    "+ sensor offset": (["off"], {}),
    "+ pump dead zone": (["u0"], {"deadzone": True}),
    "+ pump dead zone + lower-tank cross-section (pdmkit's verdict)": (
        ["u0", "c2"],
        {"deadzone": True, "area": True},
    ),
}


def main():
    est = pd.read_csv(HERE / "data" / "estimation.csv")
    val = pd.read_csv(HERE / "data" / "validation.csv")
    for label, (extra, opts) in STRUCTURES.items():
        opts = {"deadzone": False, "area": False, **opts}
        names = ["k1", "k2", "k3", "k4", "f", *extra, "x0_1", "x0_2"]
        lo, hi = (np.array([BOUNDS[n][i] for n in names], float) for i in (0, 1))
        th = fit(names, np.array([START[n] for n in names]), lo, hi, est, opts)
        same = rmse(names, th, val, opts)  # (b) the estimation record's initial state
        lo_v, hi_v = np.nextafter(th, -np.inf), np.nextafter(th, np.inf)
        lo_v[-2:], hi_v[-2:] = lo[-2:], hi[-2:]
        start = np.clip(th, lo_v, hi_v)
        whole = rmse(names, fit(names, start, lo_v, hi_v, val, opts), val, opts)
        first5 = np.arange(len(val)) < 5
        th5 = fit(names, start, lo_v, hi_v, val, opts, mask=first5)
        print(
            f"{label}: estimation {rmse(names, th, est, opts):.3f} V, validation "
            f"(a) {whole:.3f} (b) {same:.3f} (c) {rmse(names, th5, val, opts, 5):.3f} V; "
            + ", ".join(f"{n} {v:.3g}" for n, v in zip(names, th, strict=True)),
            flush=True,
        )


if __name__ == "__main__":
    main()
