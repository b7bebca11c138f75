"""Careful fit of `model_cubic.py` OUTSIDE pdmkit: the reference for the control.

numpy/scipy only, no pdmkit import.  The model is the one in `model_cubic.py` (mass
normalised to 1, the data's units):

    V2'' = gain V1 + b - c V2' - k V2 - k3 V2**3

with the force b = 0 unless `--offset` frees it (a DC offset of the input, gain*u0).
Simulated by its own fixed-step RK4 (`--substeps` steps per sample at the data's
610.35 Hz), V1 interpolated linearly between samples (the sampled continuous signal:
`pdmkit mismatch --input-hold auto` picks `foh` for it).  Fit: simulation error over
the whole estimation record (free run, not one-step prediction) with
`scipy.optimize.least_squares` (trust region reflective, forward-difference Jacobian)
on k, c, gain, k3 (and b) and the initial state (V2, V2'), from the model file's
nominal values, the same with k3 = 0, and `--starts - 2` random starts (fixed seed).
Validation (the arrow): the parameters are kept, the initial state is zero or fitted
on the first N samples (`--init-samples`), then the whole record is simulated and
scored.

Usage (after `python examples/silverbox/prepare.py DIR`)::

    python examples/silverbox/outside_fit.py DIR [--starts 6] [--json fit.json]
"""

import argparse
import json
import time
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.optimize import least_squares

PARAM_NAMES = ("k", "c", "gain", "k3", "b")
NOMINAL = np.array([1.8e5, 40.0, 1.6e5, 3.0e5, 0.0])  # model_cubic.py's PARAMS
SCALE = np.array([1.8e5, 40.0, 1.6e5, 3.0e5, 100.0, 0.05, 20.0])  # + V2 (V), V2' (V/s)
LOWER = np.array([0.0, 0.0, 0.0, -np.inf, -np.inf, -np.inf, -np.inf])


def simulate(u, dt, theta, substeps=4):
    """Free-run simulation; V1 is a straight line between samples.

    Parameters
    ----------
    u : numpy.ndarray
        Input voltage V1 at each sample, V.
    dt : float
        Sampling period, s.
    theta : sequence of float
        k (1/s**2), c (1/s), gain (1/s**2), k3 (1/(V**2 s**2)), b (V/s**2),
        V2(0) (V), V2'(0) (V/s).
    substeps : int
        RK4 steps per sample.

    Returns
    -------
    numpy.ndarray
        V2 at each sample time, V (the first is V2(0)).
    """
    k, c, gain, k3, b, y, v = (float(a) for a in theta)
    force = (gain * u + b).tolist()
    slope = (np.diff(gain * u, append=gain * u[-1])).tolist()
    h = dt / substeps
    fractions = [(j / substeps, (j + 0.5) / substeps) for j in range(substeps)]
    out = [0.0] * len(force)
    for i, f in enumerate(force):
        out[i] = y
        df = slope[i]
        for start, mid in fractions:
            fa, fm, fb = f + df * start, f + df * mid, f + df * (start + h / dt)
            a1 = fa - c * v - y * (k + k3 * y * y)
            y2, v2 = y + 0.5 * h * v, v + 0.5 * h * a1
            a2 = fm - c * v2 - y2 * (k + k3 * y2 * y2)
            y3, v3 = y + 0.5 * h * v2, v + 0.5 * h * a2
            a3 = fm - c * v3 - y3 * (k + k3 * y3 * y3)
            y4, v4 = y + h * v3, v + h * a3
            a4 = fb - c * v4 - y4 * (k + k3 * y4 * y4)
            y += h / 6.0 * (v + 2.0 * v2 + 2.0 * v3 + v4)
            v += h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
    return np.asarray(out)


class Problem:
    """Residual and forward-difference Jacobian of a simulation-error fit.

    Parameters
    ----------
    record : pandas.DataFrame
        Columns time (s), V1 (V), V2 (V).
    free : sequence of int
        Indices into (k, c, gain, k3, b, V2(0), V2'(0)) that are fitted.
    theta : numpy.ndarray
        Values of all seven; those not free stay at them.
    substeps : int
        RK4 steps per sample.
    """

    def __init__(self, record, free, theta, substeps=4):
        self.u = record["V1"].to_numpy()
        self.y = record["V2"].to_numpy()
        self.dt = float(record["time"].iloc[1] - record["time"].iloc[0])
        self.free, self.base, self.substeps = list(free), np.array(theta, float), substeps

    def theta(self, z):
        """All seven physical values from the scaled free unknowns."""
        theta = self.base.copy()
        theta[self.free] = np.asarray(z) * SCALE[self.free]
        return theta

    def residual(self, z):
        """Simulated minus measured V2 at every sample, V."""
        return simulate(self.u, self.dt, self.theta(z), self.substeps) - self.y

    def jacobian(self, z):
        """Forward-difference Jacobian of `residual` (one simulation per unknown)."""
        base = self.residual(z)
        jac = np.empty((base.size, len(z)))
        for j in range(len(z)):
            step = 1e-6 * max(1.0, abs(z[j]))
            dz = np.array(z, float)
            dz[j] += step
            jac[:, j] = (self.residual(dz) - base) / step
        return jac

    def solve(self):
        """Least-squares fit from the values given at construction."""
        z0 = self.base[self.free] / SCALE[self.free]
        return least_squares(
            self.residual,
            z0,
            jac=self.jacobian,
            bounds=(LOWER[self.free] / SCALE[self.free], np.inf),
            x_scale="jac",
            xtol=1e-10,
            ftol=1e-10,
            gtol=1e-10,
            max_nfev=100,
        )


def rmse(r):
    """Root mean square of a residual."""
    return float(np.sqrt(np.mean(np.square(r))))


def starts(n, seed=0):
    """The file's nominal values, the same with k3 = 0, then n - 2 random starts."""
    rng = np.random.default_rng(seed)
    rows = [NOMINAL.copy(), NOMINAL * [1, 1, 1, 0, 0]]
    for _ in range(n - 2):
        rows.append(
            np.array(
                [
                    rng.uniform(1.6e5, 2.1e5),
                    rng.uniform(10, 100),
                    rng.uniform(1.0e5, 2.2e5),
                    rng.uniform(-5e5, 2e6),
                    0.0,
                ]
            )
        )
    return [np.r_[row, 0.0, 0.0] for row in rows[:n]]


def fit_estimation(est, args):
    """Fit from every start; returns (best theta, rows describing every start)."""
    free = [0, 1, 2, 3] + ([4] if args.offset else []) + [5, 6]
    rows, best = [], None
    for n, theta0 in enumerate(starts(args.starts)):
        t0 = time.process_time()
        problem = Problem(est, free, theta0, args.substeps)
        res = problem.solve()
        theta = problem.theta(res.x)
        row = {
            "start": dict(zip(PARAM_NAMES, theta0[:5].tolist(), strict=True)),
            "fitted": dict(zip(PARAM_NAMES, theta[:5].tolist(), strict=True)),
            "initial_state": theta[5:].tolist(),
            "rmse_estimation_V": rmse(res.fun),
            "nfev": int(res.nfev),
            "cpu_s": time.process_time() - t0,
        }
        rows.append(row)
        print(
            f"start {n}: "
            + ", ".join(f"{p} {v:.5g}" for p, v in row["fitted"].items())
            + f"; est. RMSE {row['rmse_estimation_V'] * 1e3:.4f} mV"
            + f" ({row['nfev']} evals, {row['cpu_s']:.0f} CPU s)",
            flush=True,
        )
        if best is None or row["rmse_estimation_V"] < best[1]:
            best = (theta, row["rmse_estimation_V"])
    return best[0], rows


def validate(val, theta, args):
    """Validation RMSE (V) under several rules for the record's initial state.

    Returns ``{rule: {"rmse_V", "initial_state"}}``: "zero" starts at rest; "first N"
    fits (V2, V2') on the first N samples, then simulates the whole record.
    """
    rest = np.r_[theta[:5], 0.0, 0.0]
    dt = float(val["time"].iloc[1] - val["time"].iloc[0])
    states = {"zero": rest}
    for n in args.init_samples:
        head = Problem(val.iloc[:n], [5, 6], rest, args.substeps)
        states[f"first {n}"] = head.theta(head.solve().x)
    out = {}
    for rule, full in states.items():
        sim = simulate(val["V1"].to_numpy(), dt, full, args.substeps)
        out[rule] = {
            "rmse_V": rmse(sim - val["V2"].to_numpy()),
            "initial_state": full[5:].tolist(),
        }
    return out


def main(argv=None):
    """Fit on DIR/estimation.csv, score on DIR/validation.csv, print and save."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", help="folder with estimation.csv and validation.csv")
    ap.add_argument("--substeps", type=int, default=4, help="RK4 steps per sample")
    ap.add_argument("--starts", type=int, default=6, help="number of starts")
    ap.add_argument("--offset", action="store_true", help="also fit a constant force b")
    ap.add_argument("--init-samples", default="400,2000")
    ap.add_argument(
        "--evaluate",
        help="k,c,gain,k3[,b]: score these values (e.g. pdmkit's fit) instead of "
        "fitting; the estimation initial state is still fitted",
    )
    ap.add_argument("--json", help="write the results here")
    a = ap.parse_args(argv)
    a.init_samples = [int(n) for n in a.init_samples.split(",")]
    est = pd.read_csv(Path(a.data) / "estimation.csv")
    val = pd.read_csv(Path(a.data) / "validation.csv")
    t0 = time.process_time()
    if a.evaluate:
        given = np.zeros(7)
        values = [float(x) for x in a.evaluate.split(",")]
        given[: len(values)] = values
        problem = Problem(est, [5, 6], given, a.substeps)
        res = problem.solve()
        theta, rows = problem.theta(res.x), [{"rmse_estimation_V": rmse(res.fun)}]
        print(f"given values: est. RMSE {rmse(res.fun) * 1e3:.4f} mV")
    else:
        theta, rows = fit_estimation(est, a)
    out = {
        "model": "V2'' = gain V1 + b - c V2' - k V2 - k3 V2**3",
        "substeps": a.substeps,
        "best": dict(zip(PARAM_NAMES, theta[:5].tolist(), strict=True)),
        "starts": rows,
        "validation": validate(val, theta, a),
        "cpu_s": time.process_time() - t0,
    }
    print("best: " + ", ".join(f"{p} {v:.6g}" for p, v in out["best"].items()))
    for rule, r in out["validation"].items():
        print(f"validation RMSE {r['rmse_V'] * 1e3:.4f} mV (initial state: {rule})")
    print(f"{out['cpu_s']:.0f} CPU s")
    if a.json:
        Path(a.json).write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
