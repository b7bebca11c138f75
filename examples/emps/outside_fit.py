"""Careful fit of `model_coulomb.py` OUTSIDE pdmkit: the reference for the control.

numpy/scipy only, no pdmkit import.  The model is the one in `model_coulomb.py`:

    M q'' = F - Fv q' - Fc tanh(q' / v_smooth) - offset

simulated by its own fixed-step RK4 at the data's rate (1 kHz, `--substeps` steps per
sample), the force F held over each sample (the rig's 1 kHz controller holds its
command; `pdmkit mismatch --input-hold zoh`).  Fit: simulation error (free run over
the whole estimation record, not one-step prediction), `scipy.optimize.least_squares`
(trust region reflective, forward-difference Jacobian) on M, Fv, Fc, offset and the
initial state (q0, v0), from the description's IDIM-LS values and `--starts - 1`
random starts (fixed seed).  Validation (the pulses record): the parameters are kept,
the initial state is either at rest at the first measured position (q0 = qm[0],
v0 = 0) or fitted on the first N samples for each N in `--init-samples` (2337: the
first piece, as `pdmkit mismatch` did on this record), then the whole record is
simulated and scored.  For this integrator the score depends strongly on that rule.

Usage (after `python examples/emps/prepare.py DIR`)::

    python examples/emps/outside_fit.py DIR [--starts 8] [--json fit.json]
"""

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.optimize import least_squares

PARAM_NAMES = ("M", "Fv", "Fc", "offset")
DESCRIPTION = np.array([95.1, 203.5, 20.4, -3.16])  # IDIM-LS values (description)
SCALE = np.array([95.0, 200.0, 20.0, 5.0, 0.01, 0.01])  # params, q0 (m), v0 (m/s)
LOWER = np.array([1.0, 0.0, 0.0, -np.inf, -np.inf, -np.inf])


def simulate(force, dt, theta, v_smooth, substeps=1):
    """Free-run simulation of the axis; the force is held over each sample.

    Parameters
    ----------
    force : list of float
        Force on the load at each sample, N (held until the next sample).
    dt : float
        Sampling period, s.
    theta : sequence of float
        M (kg), Fv (N s/m), Fc (N), offset (N), q0 (m), v0 (m/s).
    v_smooth : float
        Speed over which sign(q') is smoothed by tanh, m/s.
    substeps : int
        RK4 steps per sample.

    Returns
    -------
    numpy.ndarray
        Position at each sample time, m (the first is q0).
    """
    mass, fv, fc, offset, q, v = (float(a) for a in theta)
    h = dt / substeps
    tanh = math.tanh
    out = [0.0] * len(force)
    for i, f in enumerate(force):
        out[i] = q
        for _ in range(substeps):
            a1 = (f - fv * v - fc * tanh(v / v_smooth) - offset) / mass
            v2 = v + 0.5 * h * a1
            a2 = (f - fv * v2 - fc * tanh(v2 / v_smooth) - offset) / mass
            v3 = v + 0.5 * h * a2
            a3 = (f - fv * v3 - fc * tanh(v3 / v_smooth) - offset) / mass
            v4 = v + h * a3
            a4 = (f - fv * v4 - fc * tanh(v4 / v_smooth) - offset) / mass
            q += h / 6.0 * (v + 2.0 * v2 + 2.0 * v3 + v4)
            v += h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
    return np.asarray(out)


class Problem:
    """Residual and forward-difference Jacobian of a simulation-error fit.

    Parameters
    ----------
    record : pandas.DataFrame
        Columns time (s), F (N), q (m).
    v_smooth : float
        Smoothing speed of the Coulomb term, m/s.
    substeps : int
        RK4 steps per sample.
    fixed : numpy.ndarray or None
        When given, the four model parameters are held at these values and only the
        initial state (q0, v0) is fitted.
    """

    def __init__(self, record, v_smooth, substeps=1, fixed=None):
        self.force = record["F"].to_list()
        self.q = record["q"].to_numpy()
        self.dt = float(record["time"].iloc[1] - record["time"].iloc[0])
        self.v_smooth, self.substeps, self.fixed = v_smooth, substeps, fixed
        self.scale = SCALE if fixed is None else SCALE[4:]

    def theta(self, z):
        """Physical values (M, Fv, Fc, offset, q0, v0) from the scaled unknowns."""
        x = np.asarray(z) * self.scale
        return x if self.fixed is None else np.r_[self.fixed, x]

    def residual(self, z):
        """Simulated minus measured position at every sample, m."""
        sim = simulate(self.force, self.dt, self.theta(z), self.v_smooth, self.substeps)
        return sim - self.q

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

    def solve(self, theta0, lower):
        """Least-squares fit from physical start values; returns the result."""
        z0 = np.asarray(theta0, float) / self.scale
        return least_squares(
            self.residual,
            z0,
            jac=self.jacobian,
            bounds=(lower / self.scale, np.inf),
            x_scale="jac",
            xtol=1e-10,
            ftol=1e-10,
            gtol=1e-10,
            max_nfev=200,
        )


def rmse(r):
    """Root mean square of a residual."""
    return float(np.sqrt(np.mean(np.square(r))))


def starts(record, n, seed=0):
    """The description's values, then n - 1 random starts (M, Fv, Fc, offset, q0, v0)."""
    rng = np.random.default_rng(seed)
    q0 = float(record["q"].iloc[0])
    rows = [np.r_[DESCRIPTION, q0, 0.0]]
    for _ in range(n - 1):
        rows.append(
            np.r_[
                rng.uniform(60, 130),
                rng.uniform(50, 350),
                rng.uniform(0, 40),
                rng.uniform(-10, 10),
                q0,
                0.0,
            ]
        )
    return rows


def fit_estimation(est, args):
    """Fit from every start; returns (best theta, rows describing every start)."""
    problem = Problem(est, args.v_smooth, args.substeps)
    rows, best = [], None
    for k, theta0 in enumerate(starts(est, args.starts)):
        t0 = time.process_time()
        res = problem.solve(theta0, LOWER)
        theta = problem.theta(res.x)
        row = {
            "start": dict(zip(PARAM_NAMES, theta0[:4].round(3).tolist(), strict=True)),
            "fitted": dict(zip(PARAM_NAMES, theta[:4].tolist(), strict=True)),
            "q0": float(theta[4]),
            "v0": float(theta[5]),
            "rmse_estimation_m": rmse(res.fun),
            "nfev": int(res.nfev),
            "cpu_s": time.process_time() - t0,
        }
        rows.append(row)
        print(
            f"start {k}: "
            + ", ".join(f"{n} {v:.4g}" for n, v in row["fitted"].items())
            + f"; est. RMSE {row['rmse_estimation_m'] * 1e3:.3f} mm"
            + f" ({row['nfev']} evals, {row['cpu_s']:.1f} CPU s)",
            flush=True,
        )
        if best is None or row["rmse_estimation_m"] < best[1]:
            best = (theta, row["rmse_estimation_m"])
    return best[0], rows


def evaluate(est, params, args):
    """Given parameters: fit only the estimation initial state; (theta, rows)."""
    problem = Problem(est, args.v_smooth, args.substeps, fixed=params)
    res = problem.solve(np.array([float(est["q"].iloc[0]), 0.0]), LOWER[4:])
    theta = problem.theta(res.x)
    row = {
        "given": dict(zip(PARAM_NAMES, params.tolist(), strict=True)),
        "q0": float(theta[4]),
    }
    row["rmse_estimation_m"] = rmse(res.fun)
    print(f"given values: est. RMSE {row['rmse_estimation_m'] * 1e3:.3f} mm")
    return theta, [row]


def validate(val, theta, args):
    """Validation RMSE (m) under several rules for the record's initial state.

    Returns ``{rule: {"rmse_m", "q0", "v0"}}``: "rest" starts at the first measured
    position with zero speed; "first N" fits (q0, v0) on the first N samples (N from
    `args.init_samples`), then simulates the whole record.
    """
    full = Problem(val, args.v_smooth, args.substeps, fixed=theta[:4])
    q0 = float(val["q"].iloc[0])
    states = {"rest": np.array([q0, 0.0])}
    for n in args.init_samples:
        head = Problem(val.iloc[:n], args.v_smooth, args.substeps, fixed=theta[:4])
        res = head.solve(np.array([q0, 0.0]), LOWER[4:])
        states[f"first {n}"] = res.x * SCALE[4:]
    return {
        rule: {
            "rmse_m": rmse(full.residual(state / SCALE[4:])),
            "q0": float(state[0]),
            "v0": float(state[1]),
        }
        for rule, state in states.items()
    }


def main(argv=None):
    """Fit on DIR/estimation.csv, score on DIR/validation.csv, print and save."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", help="folder with estimation.csv and validation.csv")
    ap.add_argument("--v-smooth", type=float, default=0.002, help="m/s (file: 0.002)")
    ap.add_argument("--substeps", type=int, default=1, help="RK4 steps per sample")
    ap.add_argument("--starts", type=int, default=8, help="number of starts")
    ap.add_argument(
        "--init-samples",
        default="2000,2337,4000,24841",
        help="comma-separated window lengths for the validation initial state "
        "(2337: the first piece pdmkit fitted it on, fit.pieces.samples)",
    )
    ap.add_argument(
        "--evaluate",
        help="M,Fv,Fc,offset: score these values (e.g. pdmkit's fit) instead of "
        "fitting; the estimation initial state is still fitted",
    )
    ap.add_argument("--json", help="write the results here")
    a = ap.parse_args(argv)
    a.init_samples = [int(n) for n in a.init_samples.split(",")]
    est = pd.read_csv(Path(a.data) / "estimation.csv")
    val = pd.read_csv(Path(a.data) / "validation.csv")
    t0 = time.process_time()
    if a.evaluate:
        theta, rows = evaluate(est, np.array(a.evaluate.split(","), float), a)
    else:
        theta, rows = fit_estimation(est, a)
    out = {
        "model": "M q'' = F - Fv q' - Fc tanh(q'/v_smooth) - offset",
        "v_smooth": a.v_smooth,
        "substeps": a.substeps,
        "best": dict(zip(PARAM_NAMES, theta[:4].tolist(), strict=True)),
        "starts": rows,
        "validation": validate(val, theta, a),
        "cpu_s": time.process_time() - t0,
    }
    print("best: " + ", ".join(f"{n} {v:.4g}" for n, v in out["best"].items()))
    for rule, r in out["validation"].items():
        print(f"validation RMSE {r['rmse_m'] * 1e3:.3f} mm (initial state: {rule})")
    print(f"{out['cpu_s']:.0f} CPU s")
    if a.json:
        Path(a.json).write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
