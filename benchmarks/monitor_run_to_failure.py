"""Condition monitoring on run-to-failure data nobody here made (issue 31).

For each run (IMS bearing tests 1-3, PRONOSTIA Bearing1_1, NASA Li-ion cells B0005,
B0006, B0007, B0018), every unit (an IMS bearing, the PRONOSTIA bearing, a cell) gets
its own baseline: the rows of the first 30 % of its run's life. A detector is fitted
on them and alarms on the rest (``persistence`` = 3 consecutive rows above its
threshold, latched). Reported per unit: the first alarm as a fraction of life (time
from the run's first to its last record; for cells, the discharge at end of life), or
``-`` when it never alarms.

Detectors, all on the same features and with the same persistence:

- ``rms6`` / ``rms3``: a plain threshold on the raw vibration level of each of the
  unit's channels (mean + k standard deviations of the baseline, any channel; for a
  cell the capacity below mean - k sd);
- ``iforest``: scikit-learn's ``IsolationForest`` fitted on all baseline rows,
  threshold the ``1 - alpha`` quantile of its baseline scores (in-sample);
- ``hm-<method>``: :class:`pdmkit.models.diagnosis.HealthModel` with ``method`` in
  ``pca``, ``mahalanobis``, ``isolation_forest``, ``symbolic``, everything at its
  defaults except ``false_alarm_rate``: fitted on the first 70 % of the baseline rows,
  threshold split-conformal on the last 30 %.

``alpha`` (``false_alarm_rate``) is 0.01 unless the calibration part is too small for
it (fewer than ``ceil(1 / alpha) - 1`` rows), then the smallest of 0.02, 0.05, 0.1,
0.2 it allows (the rule is fixed in advance, from the row counts only).

Features (``features``): per channel the value, its rolling mean and its rolling
standard deviation over the last ``WINDOW`` = 6 rows (causal: the row and the five
before it; the first five rows of a run are dropped). IMS: a bearing's mean absolute
vibration channel(s) (two in test 1, one in tests 2 and 3). PRONOSTIA: RMS, peak and
kurtosis of both axes. Cells: capacity, mean discharge voltage and temperature (not
the discharge time: at the constant 2 A discharge it repeats the capacity); end of life
at 1.4 Ah (30 % fade of the 2 Ah rating, NASA's convention, as
``pdmkit.ensembles.load_nasa_battery``), B0007 never reaches it and is censored at its
last discharge.

Failures (the datasets' documentation): IMS test 1 bearing 3 (inner race) and 4
(roller), test 2 bearing 1 (outer race), test 3 bearing 3 (outer race); PRONOSTIA
Bearing1_1 and the cells run to failure (end of life). The other IMS bearings are the
healthy neighbours on the same shaft.

Usage::

    .venv/bin/python benchmarks/monitor_run_to_failure.py [--runs ims1 ims2 ...]
        [--methods pca mahalanobis ...] [--csv out.csv]
"""

from __future__ import annotations

import argparse
import math
import time
import warnings

import numpy as np
import pandas as pd
from sklearn.ensemble import IsolationForest

from pdmkit import data_dir
from pdmkit.errors import DataError, ModelError
from pdmkit.models.diagnosis import HealthModel, persistent_alarm

WINDOW = 6
BASELINE = 0.3
PERSISTENCE = 3
CALIBRATION = 0.3
ALPHAS = (0.01, 0.02, 0.05, 0.1, 0.2)
SYMBOLIC_WINDOW = HealthModel().window
MARGINS = (1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0)
RUNS = ("ims1", "ims2", "ims3", "pronostia", "battery")
METHODS = ("pca", "mahalanobis", "isolation_forest", "symbolic")
IMS_FAILED = {1: (3, 4), 2: (1,), 3: (3,)}
CELLS = ("B0005", "B0006", "B0007", "B0018")
EOL_AH = 1.4


def features(raw: pd.DataFrame, window: int = WINDOW) -> pd.DataFrame:
    """Each column, its causal rolling mean and rolling std over ``window`` rows."""
    parts = {}
    for c in raw.columns:
        roll = raw[c].rolling(window, min_periods=window)
        parts[c] = raw[c]
        parts[f"{c} mean{window}"] = roll.mean()
        parts[f"{c} std{window}"] = roll.std()
    return pd.DataFrame(parts)


def _unit(run, name, raw, level, frac, failed, direction="upper"):
    X = features(raw)
    keep = X.notna().all(axis=1).to_numpy()
    return {
        "run": run,
        "unit": name,
        "failed": failed,
        "X": X[keep].reset_index(drop=True),
        "level": level[keep].reset_index(drop=True),
        "frac": np.asarray(frac)[keep],
        "direction": direction,
    }


def ims_units(test: int) -> list[dict]:
    """The four bearings of IMS test ``test`` (1, 2 or 3), each a unit."""
    file = data_dir("ims_bearing_features") / f"merged_dataset_BearingTest_{test}.csv"
    table = pd.read_csv(file, index_col=0, parse_dates=True).sort_index()
    secs = (table.index - table.index[0]).total_seconds().to_numpy()
    frac = secs / secs[-1]
    out = []
    for b in range(1, 5):
        cols = [c for c in table.columns if c.startswith(f"Bearing {b}")]
        raw = table[cols].reset_index(drop=True)
        failed = b in IMS_FAILED[test]
        out.append(_unit(f"ims{test}", f"bearing {b}", raw, raw, frac, failed))
    return out


def pronostia_units() -> list[dict]:
    """PRONOSTIA Bearing1_1 (life by snapshot: one every 10 s)."""
    file = data_dir("femto_pronostia_bearing1_1") / "Bearing1_1_acc_features.csv"
    table = pd.read_csv(file)
    cols = ["rms_h_g", "rms_v_g", "peak_h_g", "peak_v_g", "kurt_h", "kurt_v"]
    raw = table[cols]
    frac = np.arange(len(raw)) / (len(raw) - 1)
    return [_unit("pronostia", "Bearing1_1", raw, raw[cols[:2]], frac, True)]


def battery_units() -> list[dict]:
    """NASA cells, end of life at 1.4 Ah (B0007 censored at its last discharge)."""
    out = []
    for cell in CELLS:
        file = data_dir("nasa_battery") / f"{cell}_cycle_summary.csv"
        table = pd.read_csv(file)
        cap = table["capacity"].to_numpy()
        below = np.flatnonzero(cap < EOL_AH)
        end = below[0] if below.size else len(table) - 1
        table = table.iloc[: end + 1].reset_index(drop=True)
        raw = table[["capacity", "voltage", "temperature"]]
        cycle = table["discharge"].to_numpy(dtype=float)
        frac = cycle / cycle[-1]
        name = cell if below.size else f"{cell} (censored)"
        out.append(_unit("battery", name, raw, raw[["capacity"]], frac, True, "lower"))
    return out


def load_runs(runs=RUNS) -> list[dict]:
    """The units of the named runs."""
    loaders = {
        "ims1": lambda: ims_units(1),
        "ims2": lambda: ims_units(2),
        "ims3": lambda: ims_units(3),
        "pronostia": pronostia_units,
        "battery": battery_units,
    }
    return [u for r in runs for u in loaders[r]()]


def choose_alpha(n_baseline: int) -> float:
    """The smallest of ALPHAS the calibration part of ``n_baseline`` rows allows."""
    n_cal = round(CALIBRATION * n_baseline)
    return next(a for a in ALPHAS if n_cal >= math.ceil(1 / a) - 1)


def persistence(detector: str) -> int:
    """Rows above threshold that raise the alarm: PERSISTENCE beyond the rows that one
    recording can push over by itself (it enters WINDOW rows of the rolling features,
    and the symbolic measure's windows of 20 rows on top)."""
    if detector.startswith("rms"):
        return PERSISTENCE
    extra = WINDOW - 1 + (SYMBOLIC_WINDOW - 1 if detector == "hm-symbolic" else 0)
    return PERSISTENCE + extra


def _first(alarm: np.ndarray, frac: np.ndarray) -> float:
    hit = np.flatnonzero(alarm)
    return float(frac[hit[0]]) if hit.size else np.nan


def detect(unit: dict, detector: str, margin: float = 1.0) -> float | str:
    """First alarm (fraction of life) of ``detector`` on ``unit``; NaN if none, a
    string ``n/a (why)`` if the detector cannot be fitted on the baseline."""
    X, frac = unit["X"], unit["frac"]
    base = frac <= BASELINE
    alpha = choose_alpha(int(base.sum()))
    if detector.startswith("rms"):
        k = float(detector[3:])
        lv = unit["level"].to_numpy()
        mu, sd = lv[base].mean(axis=0), lv[base].std(axis=0)
        sign = 1 if unit["direction"] == "upper" else -1
        exceed = (sign * (lv - mu) > k * sd).any(axis=1)
    elif detector == "iforest":
        forest = IsolationForest(random_state=0).fit(X[base].to_numpy())
        s = -forest.score_samples(X.to_numpy())
        exceed = s > np.quantile(s[base], 1 - alpha)
    else:
        model = HealthModel(method=detector[3:], false_alarm_rate=alpha, margin=margin)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)
                model.fit(X[base])
        except (DataError, ModelError) as exc:  # too few baseline rows for it
            return f"n/a ({exc})"
        s = model.score(X)
        exceed = np.nan_to_num(s, nan=-np.inf) > model.threshold_
    after = ~base
    alarm = persistent_alarm(exceed[after], persistence(detector))
    return _first(alarm, frac[after])


def run(
    runs=RUNS,
    methods=METHODS,
    baselines=("rms6", "rms3", "iforest"),
    margins: dict | None = None,
) -> pd.DataFrame:
    """One row per unit: first-alarm fraction of life per detector (NaN: none).

    ``margins`` (method -> margin) adds a column ``hm-<method> xM`` per method with
    the HealthModel at that margin.
    """
    detectors = [(d, 1.0) for d in baselines] + [(f"hm-{m}", 1.0) for m in methods]
    detectors += [(f"hm-{m}", g) for m, g in (margins or {}).items()]
    rows = []
    for unit in load_runs(runs):
        row = {"run": unit["run"], "unit": unit["unit"], "failed": unit["failed"]}
        row["alpha"] = choose_alpha(int((unit["frac"] <= BASELINE).sum()))
        for d, g in detectors:
            row[d if g == 1.0 and d not in row else f"{d} x{g:g}"] = detect(unit, d, g)
        rows.append(row)
    return pd.DataFrame(rows)


def select_margin(method: str, dev_run: str = "ims3", grid=MARGINS) -> tuple[float, bool]:
    """The smallest margin of ``grid`` at which no healthy unit of ``dev_run`` alarms
    before 85 % of its life, and whether one did (else the largest of ``grid``). The
    selection sees the development run only."""
    units = [u for u in load_runs([dev_run]) if not u["failed"]]
    for g in grid:
        first = [detect(u, f"hm-{method}", g) for u in units]
        early = [a for a in first if isinstance(a, float) and a < 0.85]
        if not early:
            return g, True
    return grid[-1], False


def verdict(table: pd.DataFrame, detector: str) -> pd.DataFrame:
    """Per failed unit: alarmed before 85 % of life, not before 50 %, and before
    every healthy unit of its run (healthy units that never alarm count as later)."""
    out = []
    num = table.assign(a=pd.to_numeric(table[detector], errors="coerce"))
    for _, r in num[num["failed"]].iterrows():
        healthy = num[(num["run"] == r["run"]) & ~num["failed"]]["a"]
        a = r["a"]
        out.append(
            {
                "run": r["run"],
                "unit": r["unit"],
                "alarm": a,
                "before_85": bool(a < 0.85),
                "not_before_50": bool(not a < 0.5),
                "before_healthy": bool(np.all(np.nan_to_num(healthy, nan=2.0) > a)),
            }
        )
    return pd.DataFrame(out)


def _fmt(v) -> str:
    if isinstance(v, float) and np.isnan(v):
        return "-"
    if isinstance(v, str) and v.startswith("n/a"):
        return "n/a"
    return f"{v:.3f}" if isinstance(v, float) else str(v)


def markdown(table: pd.DataFrame) -> str:
    """The table as Markdown, fractions with three decimals."""
    cols = list(table.columns)
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for _, r in table.iterrows():
        lines.append("| " + " | ".join(_fmt(r[c]) for c in cols) + " |")
    return "\n".join(lines)


TARGETS = {("ims1", "bearing 3"), ("ims1", "bearing 4"), ("ims2", "bearing 1")}


def summary(table: pd.DataFrame) -> pd.DataFrame:
    """Per detector: the issue's targets met, alarms of failed and healthy units."""
    out = []
    for d in [c for c in table.columns if c.startswith(("rms", "iforest", "hm-"))]:
        v = verdict(table, d)
        ok = v["before_85"] & v["not_before_50"] & v["before_healthy"]
        target = [(r, u) in TARGETS for r, u in zip(v["run"], v["unit"], strict=True)]
        healthy = pd.to_numeric(table[~table["failed"]][d], errors="coerce")
        n_a = int(table[table["failed"]][d].astype(str).str.startswith("n/a").sum())
        out.append(
            {
                "detector": d,
                "targets met": f"{int(ok[target].sum())}/{sum(target)}",
                "failed: alarm < 0.85": f"{int(v['before_85'].sum())}/{len(v)}",
                "failed: alarm < 0.5": int((~v["not_before_50"]).sum()),
                "failed: missed": int(v["alarm"].isna().sum()) - n_a,
                "failed: n/a": n_a,
                "healthy: alarm < 0.85": f"{int((healthy < 0.85).sum())}/{len(healthy)}",
            }
        )
    return pd.DataFrame(out)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", nargs="+", default=list(RUNS), choices=RUNS)
    parser.add_argument("--methods", nargs="+", default=list(METHODS))
    parser.add_argument(
        "--no-margin", action="store_true", help="skip the margins selected on ims3"
    )
    parser.add_argument("--csv", default=None)
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    margins = None
    if not args.no_margin:
        chosen = {m: select_margin(m) for m in args.methods}
        margins = {m: g for m, (g, _) in chosen.items()}
        unmet = [m for m, (_, ok) in chosen.items() if not ok]
        print(f"margins selected on ims3 (its healthy bearings): {margins}")
        print(f"  no margin up to {MARGINS[-1]:g} met the criterion for: {unmet}\n")
    table = run(args.runs, args.methods, margins=margins)
    print(markdown(table))
    print(
        "\ntargets (ims1 bearings 3, 4, ims2 bearing 1): alarm in [0.5, 0.85) of life"
        " and before every healthy neighbour"
    )
    print(markdown(summary(table)))
    print(f"\n({time.perf_counter() - t0:.1f} s)")
    if args.csv:
        table.to_csv(args.csv, index=False)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
