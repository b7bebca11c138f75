"""RUL kept in the health history, on real run-to-failure cells (issue 31).

The documented commands of ``docs/monitoring.md`` ("RUL in the history"), run in
process on NASA's Li-ion cells (Saha & Goebel 2007; ``../shared/data/nasa_battery``),
leave one cell out: of the three cells that reach end of life (1.4 Ah: B0005, B0006,
B0018), each is the asset in service once, the other two are the fleet that ran to
failure before it.

Per fold:

1. ``monitor fit`` on the two training cells (features per discharge: capacity, mean
   discharge voltage and temperature, each with its causal 6-discharge rolling mean
   and standard deviation, as ``benchmarks/monitor_run_to_failure.py``), healthy =
   the first 30 % of each cell's life, method ``mahalanobis``, false alarms 0.1 per
   row;
2. ``monitor score`` of the training cells into their own history, ``monitor export``;
3. a linear degradation model of ``health_index`` (decreasing) trained on the export
   and saved (``pdmkit rul --train`` would hold one of the two cells out);
4. the test cell's discharges arrive in files of 10, each scored with ``--rul`` into a
   fresh history;
5. compared with the true remaining life (end-of-life discharge minus the current one)
   and with the standard direct route: a linear degradation model of the capacity
   itself (threshold 1.4 Ah, known) trained on the same two cells.

Prints per cell the RUL error at the files nearest 50 %, 70 % and 90 % of life, the
share of files whose interval holds the true RUL, and the wall and CPU seconds.

Usage::

    .venv/bin/python benchmarks/monitor_rul_history.py [--out DIR]
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from pdmkit import data_dir, save_model
from pdmkit.experiments._cli import main as pdmkit
from pdmkit.experiments._monitor_history import HealthHistory
from pdmkit.rul import LinearDegradationModel

sys.path.insert(0, str(Path(__file__).resolve().parent))
from monitor_run_to_failure import EOL_AH, features

CELLS = ("B0005", "B0006", "B0018")  # B0007 never reaches 1.4 Ah: no true RUL
FILE_ROWS = 10
AT = (0.5, 0.7, 0.9)


def cell_table(cell: str) -> pd.DataFrame:
    """One cell's discharges to end of life: unit, discharge, features."""
    table = pd.read_csv(data_dir("nasa_battery") / f"{cell}_cycle_summary.csv")
    end = int(np.flatnonzero(table["capacity"].to_numpy() < EOL_AH)[0])
    table = table.iloc[: end + 1].reset_index(drop=True)
    X = features(table[["capacity", "voltage", "temperature"]])
    X.insert(0, "discharge", table["discharge"].astype(float))
    X.insert(0, "unit", cell)
    return X.dropna().reset_index(drop=True)


def _run(args: list[str]) -> None:
    with contextlib.redirect_stderr(io.StringIO()) as err:
        code = pdmkit(args)
    if code != 0:
        raise SystemExit(f"pdmkit {' '.join(args[:2])} failed: {err.getvalue()}")


def fold(test: str, d: Path) -> pd.DataFrame:
    """Leave ``test`` out: its RUL after each file, both routes, with the truth."""
    train = pd.concat([cell_table(c) for c in CELLS if c != test])
    train.to_csv(d / "train.csv", index=False)
    keys = ["--unit", "unit", "--time", "discharge"]
    _run(["monitor", "fit", "--features", str(d / "train.csv"), *keys, "--healthy-first",
          "0.3", "--method", "mahalanobis", "--false-alarms", "0.1", "--out",
          str(d / "mon"), "--quiet"])  # fmt: skip
    model = str(d / "mon" / "model.pdmkit")
    _run(["monitor", "score", "--model", model, "--features", str(d / "train.csv"),
          *keys, "--db", str(d / "train.sqlite"), "--out", str(d / "train_out"),
          "--quiet"])  # fmt: skip
    _run(["monitor", "export", "--db", str(d / "train.sqlite"), "--csv",
          str(d / "history.csv")])  # fmt: skip
    # two training cells: `pdmkit rul --train` would hold one out, so the same model
    # is trained and saved here in Python (the command's own estimator and file)
    history = pd.read_csv(d / "history.csv")
    hi_model = LinearDegradationModel(indicator="health_index", direction="decreasing")
    save_model(hi_model.fit(history), d / "rul.pdmkit")
    cells = cell_table(test)
    for k, start in enumerate(range(0, len(cells), FILE_ROWS)):
        part = cells.iloc[start : start + FILE_ROWS]
        part.to_csv(d / f"file{k:03d}.csv", index=False)
        _run(["monitor", "score", "--model", model, "--features",
              str(d / f"file{k:03d}.csv"), *keys, "--db", str(d / "test.sqlite"),
              "--rul", str(d / "rul.pdmkit"), "--out", str(d / f"o{k}"),
              "--quiet"])  # fmt: skip
    with HealthHistory(d / "test.sqlite", read_only=True) as h:
        ruls = h.rul_history()
    end = float(cells["discharge"].iloc[-1])
    first = float(cells["discharge"].iloc[0])
    ruls["true"] = end - ruls["time"]
    ruls["frac"] = (ruls["time"] - first) / (end - first)
    # the direct route: capacity to 1.4 Ah, the same two cells
    direct = LinearDegradationModel(
        indicator="capacity", threshold=EOL_AH, direction="decreasing", time="discharge"
    ).fit(train)
    rows = []
    for t in ruls["time"]:
        seen = cells[cells["discharge"] <= t]
        rows.append(direct.predict(seen).to_pandas()["rul"].iloc[-1])
    ruls["direct"] = rows
    ruls["cell"] = test
    return ruls


def report(all_folds: pd.DataFrame) -> pd.DataFrame:
    out = []
    for cell, r in all_folds.groupby("cell"):
        row = {"cell": cell, "files": len(r)}
        for a in AT:
            k = int(np.argmin(np.abs(r["frac"].to_numpy() - a)))
            row[f"err@{a:.0%} hist"] = float(r["rul"].iloc[k] - r["true"].iloc[k])
            row[f"err@{a:.0%} capacity"] = float(r["direct"].iloc[k] - r["true"].iloc[k])
        lo = r["lower"].fillna(-np.inf)
        hi = r["upper"].fillna(np.inf)
        row["covered"] = float(((lo <= r["true"]) & (r["true"] <= hi)).mean())
        row["mae hist"] = float((r["rul"] - r["true"]).abs().mean())
        row["mae capacity"] = float((r["direct"] - r["true"]).abs().mean())
        out.append(row)
    return pd.DataFrame(out)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, help="keep the folds' files here")
    args = p.parse_args(argv)
    t0, c0 = time.time(), time.process_time()
    base = args.out or Path(tempfile.mkdtemp(prefix="monitor_rul_"))
    folds = []
    for cell in CELLS:
        d = base / cell
        d.mkdir(parents=True, exist_ok=True)
        folds.append(fold(cell, d))
    table = report(pd.concat(folds, ignore_index=True))
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(table.round(2).to_string(index=False))
    load = os.getloadavg()[0]
    print(f"{time.time() - t0:.0f} s wall, {time.process_time() - c0:.0f} s CPU, "
          f"load {load:.1f}; files in {base}")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
