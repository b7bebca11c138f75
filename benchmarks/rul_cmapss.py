"""C-MAPSS FD001: pdmkit's learned RUL models beside a plain scikit-learn baseline.

Issue 15's targets on this machine: ``pdmkit rul --model boosting`` RMSE <= 12.5 in
<= 30 s wall, the neural model RMSE <= 12.0 in <= 60 s, both with calibrated 90 %
intervals (coverage 0.85-0.95 on the 100 test engines). Scores are against the true
RULs capped at 125 cycles, the literature's convention for this dataset.

Three rows, timed in one run:

- ``baseline``: scikit-learn's ``HistGradientBoostingRegressor`` with its defaults on
  the last 30 cycles of the 15 sensors that vary (flattened, 450 columns; histories
  shorter than 30 cycles padded with their first row), trained on every 30-cycle
  window of the training engines, targets capped at 125 (no intervals);
- ``boosting``: ``run_rul("cmapss-fd001", "boosting")``, the whole workflow (fit,
  predictions, checks, report, model file);
- ``neural``: ``run_rul("cmapss-fd001", "neural")``.

Each row gives the RMSE, the interval coverage, the median wall time over
``--repeats`` runs and the median CPU time of this process (user + system, all
threads; above the wall time means more than one core was busy), with the load
average before and after; then the ratios to the baseline. Every fit uses one thread
(``torch.set_num_threads(1)``, OpenMP limited to 1): the machine is shared.

Usage::

    .venv/bin/python benchmarks/rul_cmapss.py [--repeats 3] [--neural-repeats 1]
        [--skip-neural] [--json results.json]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time

import numpy as np


def _timed(fn, repeats: int):
    """(last result, wall times, CPU times) of ``repeats`` calls of ``fn``."""
    walls, cpus, out = [], [], None
    for _ in range(repeats):
        c0, w0 = time.process_time(), time.perf_counter()
        out = fn()
        walls.append(time.perf_counter() - w0)
        cpus.append(time.process_time() - c0)
    return out, walls, cpus


def _baseline(train, test, sensors, cap=125.0, window=30):
    """Plain HistGradientBoostingRegressor on flattened last-30-cycle windows."""
    from sklearn.ensemble import HistGradientBoostingRegressor

    def windows(part):
        x = part[sensors].to_numpy(float)
        if len(x) < window:
            x = np.vstack([np.repeat(x[:1], window - len(x), axis=0), x])
        view = np.lib.stride_tricks.sliding_window_view(x, window, axis=0)
        return view.reshape(len(view), -1)

    X, y = [], []
    for _, part in train.groupby("unit", sort=False):
        w = windows(part)
        X.append(w)
        y.append(np.minimum(part["rul"].to_numpy(float)[-len(w) :], cap))
    model = HistGradientBoostingRegressor(random_state=0).fit(
        np.vstack(X), np.concatenate(y)
    )
    last = np.vstack([windows(part)[-1] for _, part in test.groupby("unit", sort=False)])
    pred = np.clip(model.predict(last), 0, cap)
    truth = test.groupby("unit", sort=False)["rul_true_final"].first().to_numpy(float)
    return {"rmse": float(np.sqrt(np.mean((pred - np.minimum(truth, cap)) ** 2)))}


def _workflow(model: str, seed: int):
    from pdmkit.experiments._rul import run_rul

    with tempfile.TemporaryDirectory() as out:
        summary = run_rul("cmapss-fd001", model, out, seed=seed, n_trajectories=0)
    return {
        "rmse": summary["rmse"],
        "coverage": summary["coverage"],
        "fit_seconds": summary["fit_seconds"],
        "rul_cap": summary["rul_cap"],
        "warnings": summary.get("warnings", []),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3, help="runs of baseline, boosting")
    ap.add_argument("--neural-repeats", type=int, default=1, help="runs of neural (1)")
    ap.add_argument("--skip-neural", action="store_true")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", help="also write the rows here")
    a = ap.parse_args(argv)

    import torch
    from threadpoolctl import threadpool_limits

    from pdmkit.ensembles import load_cmapss

    torch.set_num_threads(1)
    train = load_cmapss("FD001", "train")
    test = load_cmapss("FD001", "test")
    sensors = [c for c in train.columns if c.startswith("sensor_")]
    sensors = [c for c in sensors if train[c].std() > 1e-9 * max(train[c].abs().mean(), 1)]
    print(
        f"C-MAPSS FD001: {train['unit'].nunique()} training, {test['unit'].nunique()} "
        f"test engines, {len(sensors)} varying sensors; cap 125 cycles; "
        f"{os.cpu_count()} cores; python {sys.version.split()[0]}"
    )
    load_before = os.getloadavg()
    rows = {}
    with threadpool_limits(1, user_api="openmp"):
        jobs = [
            ("baseline", lambda: _baseline(train, test, sensors), a.repeats),
            ("boosting", lambda: _workflow("boosting", a.seed), a.repeats),
        ]
        if not a.skip_neural:
            jobs.append(("neural", lambda: _workflow("neural", a.seed), a.neural_repeats))
        for name, fn, repeats in jobs:
            result, walls, cpus = _timed(fn, max(1, repeats))
            rows[name] = {
                **result,
                "wall_median_s": statistics.median(walls),
                "wall_s": walls,
                "cpu_median_s": statistics.median(cpus),
                "repeats": len(walls),
            }
            cov = result.get("coverage")
            print(
                f"{name:9s} RMSE {result['rmse']:6.2f}  coverage "
                f"{'   -' if cov is None else f'{cov:4.2f}'}  wall median "
                f"{rows[name]['wall_median_s']:6.1f} s  CPU median "
                f"{rows[name]['cpu_median_s']:6.1f} s  ({len(walls)} run(s): "
                + ", ".join(f"{w:.1f}" for w in walls)
                + " s)",
                flush=True,
            )
    load_after = os.getloadavg()
    base = rows["baseline"]
    for name in [n for n in rows if n != "baseline"]:
        r = rows[name]
        print(
            f"{name} / baseline: RMSE ratio {r['rmse'] / base['rmse']:.3f}, wall ratio "
            f"{r['wall_median_s'] / base['wall_median_s']:.2f}"
        )
    targets = {"boosting": (12.5, 30.0), "neural": (12.0, 60.0)}
    ok = True
    for name, (rmse_max, wall_max) in targets.items():
        if name not in rows:
            continue
        r = rows[name]
        met = (
            r["rmse"] <= rmse_max
            and r["wall_median_s"] <= wall_max
            and 0.85 <= r["coverage"] <= 0.95
        )
        ok = ok and met
        print(
            f"target {name}: RMSE <= {rmse_max:g}, wall <= {wall_max:g} s, coverage "
            f"0.85-0.95: {'met' if met else 'NOT met'}"
        )
    print(
        "load average (1, 5, 15 min) before "
        + ", ".join(f"{v:.2f}" for v in load_before)
        + "; after "
        + ", ".join(f"{v:.2f}" for v in load_after)
    )
    if a.json:
        with open(a.json, "w", encoding="utf-8") as fh:
            json.dump(
                {"rows": rows, "load_before": load_before, "load_after": load_after},
                fh,
                indent=2,
            )
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
