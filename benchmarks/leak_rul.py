"""Air-leak RUL on the pneumatic twin: the done-when table of issue 6, in one run.

For each walk shape (the roughness of the leak coefficient's random walk; 16 is the
twin's default, 4 the rough case), simulates ``--train`` training and ``--test`` test units
(:func:`pdmkit.experiments._rul.simulate_leak_dataset`, cached under ``--cache``) and
runs ``run_rul("pneumatic-leak", model)`` for the linear degradation, Wiener-process
(plain and with measurement noise),
gamma-process, residual similarity and pairwise similarity models on the best-ranked
indicator, plus linear degradation on the seed's indicator (the flow shape factor). Each
row reports RMSE and MAE over the last half of the test units' lives and the fraction of
test units within 10 % under each reading of
:func:`pdmkit.experiments._rul.leak_accuracy`; the ``true_leak`` columns are the same
model fed the true ``log10 C_al`` (what the random walk alone allows). ``--paths N``
(default 1500) also draws N leak paths per walk shape without simulating the twin and
scores predictors of the failing cycle on them under the every-cycle 10 %-of-life
reading: a least-squares line through the true ``log C_al`` so far, an oracle that knows
the unit's rate and extrapolates from the current value (the ceiling of any predictor
that does not see the future steps), and the Wiener and gamma-process models fitted on
200 further paths (which, like any real predictor, must learn each unit's rate from its
own increments).

Usage::

    .venv/bin/python benchmarks/leak_rul.py [--train 20] [--test 40] [--shapes 4 16]
        [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from pdmkit.ensembles._pneumatic_leak import _leak_path
from pdmkit.experiments._rul import leak_accuracy, run_rul
from pdmkit.rul import GammaProcessDegradationModel, WienerDegradationModel

MODELS = (
    "linear-degradation",
    "wiener",
    "wiener-noisy",
    "gamma-process",
    "similarity",
    "pairwise",
)
SEED_INDICATOR = "FlowExtrusion/stats/ShapeFactor"


def _draw_paths(rng, n_paths, shape, max_cycles):
    """``n_paths`` true ``log C_al`` paths (cycle 0 to the failing cycle) and their
    rates, drawn exactly as :func:`pdmkit.ensembles.simulate_leak_runs` draws them (its
    ``_leak_path``). The unit's rate follows from its target life, the generator's first
    draw: the state is saved, the target drawn, and the state restored so that
    ``_leak_path`` draws the same target.
    """
    lo, hi = np.log(1e-10), np.log(1e-6)
    out = []
    for _ in range(n_paths):
        state = rng.bit_generator.state
        target = int(rng.integers(int(0.4 * max_cycles), max_cycles + 1))
        rng.bit_generator.state = state  # _leak_path draws the same target again
        path = np.log(_leak_path(rng, max_cycles, 1e-10, 1e-6, shape))
        out.append((path, (hi - lo) / target))
    return out


def _path_table(paths, first_unit=0):
    return pd.DataFrame(
        {
            "unit": np.concatenate(
                [np.full(len(p), first_unit + i) for i, (p, _) in enumerate(paths)]
            ),
            "cycle": np.concatenate([np.arange(len(p), dtype=float) for p, _ in paths]),
            "hi": np.concatenate([p for p, _ in paths]),
        }
    )


def process_ceiling(
    n_paths: int, shape: float, seed: int = 0, max_cycles: int = 60, n_train: int = 200
):
    """Fraction of leak paths whose every last-half prediction is within 10 % of life.

    Predictors of the failing cycle from the true ``log C_al`` so far: a least-squares
    line, an oracle that knows the unit's rate and extrapolates from the current value
    (the ceiling of any predictor that does not see the future steps), and the Wiener
    and gamma-process models fitted on ``n_train`` further paths (they must learn each
    unit's rate from its own increments, as any real predictor must). For the models,
    also the coverage of their 90 % intervals over the last-half predictions.
    """
    rng = np.random.default_rng(seed)
    hi = np.log(1e-6)
    paths = _draw_paths(rng, n_paths, shape, max_cycles)
    ok = {"least_squares": [], "known_rate": []}
    for path, rate in paths:
        life = len(path) - 1
        good = {k: True for k in ok}
        for k in range(int(np.ceil(life / 2)), life):
            t = np.arange(k + 1.0)
            b, a = np.polyfit(t, path[: k + 1], 1)
            pred = {
                "least_squares": (hi - a) / b - k,
                # the failing cycle is the first one past the crossing: +0.5 on average
                "known_rate": (hi - path[k]) / rate + 0.5,
            }
            for key, value in pred.items():
                good[key] &= abs(value - (life - k)) <= 0.1 * life
        for key in ok:
            ok[key].append(good[key])
    result = {k: float(np.mean(v)) for k, v in ok.items()}
    test = _path_table(paths)
    life = test.groupby("unit")["cycle"].max()
    train = _path_table(_draw_paths(rng, n_train, shape, max_cycles), first_unit=n_paths)
    for key, model in (
        ("wiener", WienerDegradationModel()),
        ("gamma_process", GammaProcessDegradationModel()),
    ):
        pred = model.fit(train).predict_trajectory(test).to_pandas()
        acc = leak_accuracy(pred["unit"], pred["time"], pred["rul"], life)
        true = life.reindex(pred["unit"]).to_numpy() - pred["time"].to_numpy()
        last = (pred["time"].to_numpy() >= (true + pred["time"].to_numpy()) / 2) & (
            true > 0
        )
        inside = (pred["lower"] <= true) & (true <= pred["upper"])
        result[key] = float(acc["of_life"].mean())
        result[f"{key}_mean_of_life"] = float(acc["mean_of_life"].mean())
        result[f"{key}_coverage"] = float(inside[last].mean())
    return result


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--train", type=int, default=20)
    parser.add_argument("--test", type=int, default=40)
    parser.add_argument("--shapes", type=float, nargs="+", default=[4.0, 16.0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--cache", type=Path, default=Path("results/leak_rul_cache"))
    parser.add_argument("--paths", type=int, default=1500)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    ceilings = {}
    for shape in args.shapes:
        if args.paths > 0:
            ceilings[shape] = process_ceiling(args.paths, shape, seed=args.seed)
            c = ceilings[shape]
            print(
                f"shape {shape:>4g} true leak paths ({args.paths}), units every-cycle "
                f"within 10 % of life: least-squares line {c['least_squares']:.3f}, "
                f"known rate {c['known_rate']:.3f}, Wiener {c['wiener']:.3f} "
                f"(coverage {c['wiener_coverage']:.3f}), gamma process "
                f"{c['gamma_process']:.3f} (coverage {c['gamma_process_coverage']:.3f})",
                flush=True,
            )
    rows = []
    out = Path(tempfile.mkdtemp())
    for shape in args.shapes:
        opts = {
            "n_train": args.train,
            "n_test": args.test,
            "walk_shape": shape,
            "cache_dir": args.cache,
        }
        runs = [(m, None) for m in MODELS] + [("linear-degradation", [SEED_INDICATOR])]
        for model, features in runs:
            start = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                s = run_rul(
                    "pneumatic-leak",
                    model,
                    out / "run",
                    seed=args.seed,
                    features=features,
                    dataset_options=opts,
                    n_trajectories=0,
                )
            row = {
                "walk_shape": shape,
                "model": model,
                "indicator": s["indicator"],
                "rmse": round(s["rmse"], 2),
                "mae": round(s["mae"], 2),
                "phm08_score": round(s["phm08_score"], 1),
                "n_predictions": s["n_predictions"],
                "coverage": round(s["coverage"], 3),
                "n_units": s["n_units"],
                **{k: round(v, 3) for k, v in s["within_10pct"].items()},
                "true_leak_mae": round(s["true_leak"]["mae"], 2),
                **{
                    f"true_leak_{k}": round(v, 3)
                    for k, v in s["true_leak"]["within_10pct"].items()
                },
                "seconds": round(time.perf_counter() - start, 1),
            }
            rows.append(row)
            print(
                f"shape {shape:>4g} {model:18s} {s['indicator']!s:32s} "
                f"RMSE {row['rmse']:5.2f} MAE {row['mae']:5.2f} | units within 10 %: "
                f"of life {row['of_life']:.2f}, mean of life {row['mean_of_life']:.2f}, "
                f"of RUL {row['of_rul']:.2f}, alpha-lambda {row['alpha_lambda']:.2f} | "
                f"true leak: of life {row['true_leak_of_life']:.2f}, mean "
                f"{row['true_leak_mean_of_life']:.2f} ({row['seconds']:.0f} s)",
                flush=True,
            )
    result = {
        "train": args.train,
        "test": args.test,
        "seed": args.seed,
        "rows": rows,
        "process_ceiling": {str(k): v for k, v in ceilings.items()},
    }
    if args.json:
        args.json.write_text(json.dumps(result, indent=2) + "\n")
    return result


if __name__ == "__main__":
    main()
