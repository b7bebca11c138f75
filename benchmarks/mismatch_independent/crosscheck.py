"""Fit a named structure to a case with this benchmark's own simulator (no pdmkit).

Used to tell a pdmkit miss from a case that is ambiguous by physics: each structure
(the true one, or another written ``name:target:key=value,...`` with its starting
values) is fitted to the estimation record (the file's free parameters, the effect's
values and the initial state; scipy ``least_squares`` started at the true free
parameters and initial state) with the same continuous input the case was made with.
Residual RMS is given as a multiple of the noise std: about 1 means "explains it".

    .venv/bin/python benchmarks/mismatch_independent/crosscheck.py /tmp/indep_cases \\
        msd_stribeck truth coulomb_friction:v:Fc=0.8,v_width=0.002
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

sys.path.insert(0, str(Path(__file__).resolve().parent))
from generate import CASES, Effect, integrate, plant_for, sensor_reading
from plants import PLANTS

FIXED = {"v_width", "w_width", "k_weir", "h_ref"}  # shape constants, not fitted


def read_csv(path):
    """Columns of a case CSV as arrays."""
    data = np.genfromtxt(path, delimiter=",", names=True)
    return {name: data[name] for name in data.dtype.names}


def simulate_reading(plant, params, effect, signals, n, x0):
    """The sensor's reading from initial model state x0 (extra states at rest)."""
    z0 = list(x0)
    if effect is not None and effect.name == "hysteresis":
        z0.append(0.0)
    if effect is not None and effect.name == "input_lag":
        z0.append(float(signals[effect.target].samples[0]))
    if effect is not None and effect.name == "sensor_lag":
        z0.append(x0[list(plant.states).index(plant.output)])
    t, z = integrate(plant, params, effect, signals, n, z0=np.array(z0), rtol=1e-7)
    y = sensor_reading(plant, effect, t, z)
    if effect is not None and effect.name == "sensor_saturation":
        s = effect.strength
        y = np.clip(y, s.get("low", -np.inf), s.get("high", np.inf))
    return y


def fit_structure(plant, effect, signals, y, sigma, x0):
    """Least-squares fit; returns (rms/noise, fitted params, fitted effect values)."""
    fitted = [] if effect is None else [k for k in effect.strength if k not in FIXED]
    scale_x = np.array([plant.scales[k] for k in plant.states])
    theta0 = np.r_[
        np.log([plant.true_params[k] for k in plant.free]),
        [effect.strength[k] for k in fitted] if effect else [],
        np.asarray(x0) / scale_x,
    ]
    n_free, n_eff = len(plant.free), len(fitted)

    def unpack(theta):
        p = dict(plant.true_params)
        p.update(
            {k: float(np.exp(v)) for k, v in zip(plant.free, theta[:n_free], strict=True)}
        )
        eff = None
        if effect is not None:
            values = dict(effect.strength)
            values.update(dict(zip(fitted, theta[n_free : n_free + n_eff], strict=True)))
            eff = Effect(effect.name, effect.target, effect.kind, values)
        return p, eff, theta[n_free + n_eff :] * scale_x

    def residual(theta):
        p, eff, z0 = unpack(theta)
        try:
            return (simulate_reading(plant, p, eff, signals, len(y), z0) - y) / sigma
        except (RuntimeError, ValueError):
            return np.full(len(y), 1e3)

    fit = least_squares(residual, theta0, diff_step=1e-4, max_nfev=80, x_scale="jac")
    p, eff, _ = unpack(fit.x)
    return float(np.sqrt(np.mean(fit.fun**2))), p, eff


def parse_effect(text, plant_name):
    """``name:target:key=value,...`` -> Effect (kind from the target's role)."""
    name, target, values = [*text.split(":"), ""][:3]
    plant = PLANTS[plant_name]  # only its input names are read
    kind = "input" if target in plant.inputs else "state"
    if name.startswith("sensor_"):
        kind = "sensor"
    strength = {k: float(v) for k, v in (kv.split("=") for kv in values.split(",") if kv)}
    return Effect(name, target, kind, strength)


def main(argv=None):
    """Command line: one case, one or more structures (``none`` for the nominal)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("cases_dir")
    parser.add_argument("case")
    parser.add_argument("structures", nargs="+", help="'truth', 'none' or name:target:k=v")
    args = parser.parse_args(argv)
    spec = next(c for c in CASES if c.case_id == args.case)
    plant = plant_for(spec)
    truth = {
        c["case"]: c for c in json.loads(Path(args.cases_dir, "cases.json").read_text())
    }
    sigma = truth[args.case]["noise_std"]
    rng = np.random.default_rng(spec.seed)
    from generate import nominal_params

    nominal_params(plant, rng)  # advance the generator's random stream as it did
    sig_est = plant.excite(rng, plant.n_est)
    cols = read_csv(Path(args.cases_dir, args.case, "est.csv"))
    y = cols[plant.output]
    x0 = [
        float(v) for v in integrate(plant, plant.true_params, spec.effect, sig_est, 2)[1][0]
    ]
    x0 = x0[: len(plant.states)]
    for text in args.structures:
        effect = spec.effect if text == "truth" else None
        if text not in ("truth", "none"):
            effect = parse_effect(text, spec.plant)
        rms, p, eff = fit_structure(plant, effect, sig_est, y, sigma, x0)
        shown = {k: round(v, 6) for k, v in (eff.strength if eff else {}).items()}
        free = {k: float(f"{p[k]:.4g}") for k in plant.free}
        print(f"{args.case} {text}: est RMS/noise {rms:.3f} free {free} effect {shown}")


if __name__ == "__main__":
    main()
