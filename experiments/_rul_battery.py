"""The RUL workflow on real degradation data: NASA Li-ion cells fading to 1.4 Ah.

``run_rul("nasa-battery", model)`` reads the four cells of
:func:`pdmkit.ensembles.load_nasa_battery` (capacity per discharge; B0005, B0006 and
B0018 reach the 1.4 Ah end of life after 125, 109 and 97 discharges, B0007 never does
and is right-censored) and, for each cell that failed, trains the model on the three
others (the censored one included) and follows the held-out cell through its life,
reading its capacity directly (``threshold=1.4``, ``direction="decreasing"``). The
scores are over the predictions in the last half of each held-out cell's life, as for
the air-leak runs. Only the one-indicator degradation models apply: four cells are too
few for the similarity, survival and learned models.
"""

from __future__ import annotations

from typing import Any

import pandas as pd

from pdmkit.ensembles import BATTERY_EOL_AH, load_nasa_battery
from pdmkit.errors import DataError
from pdmkit.experiments._report import Report
from pdmkit.experiments._rul_cv import cross_validate, unit_folds
from pdmkit.experiments._rul_models import (
    RUL_MODELS,
    _calibration,
    _finish,
    _save_pipeline,
    _trajectory_coverage,
    _trajectory_plot,
    _trajectory_scores,
    make_rul_model,
)
from pdmkit.rul import ConformalRUL, RULPipeline

#: Workflow models that read the capacity directly.
BATTERY_MODELS = (
    "linear-degradation",
    "degradation",
    "exponential-degradation",
    "wiener",
    "wiener-noisy",
    "gamma-process",
)


def _battery_estimator(model, seed, rul_cap, options, calibrate):
    """A fresh pipeline reading the capacity directly (degradation models only)."""
    if model not in BATTERY_MODELS:
        raise DataError(
            f"model {model!r} does not apply to 'nasa-battery' (four cells, one "
            f"indicator); use one of {list(BATTERY_MODELS)}"
        )
    settings = {
        "indicator": "capacity",
        "threshold": BATTERY_EOL_AH,
        "direction": "decreasing",
        **dict(options or {}),
    }
    _, estimator = make_rul_model(
        model, ["capacity"], seed=seed, rul_cap=rul_cap, options=settings
    )
    if calibrate:
        estimator = ConformalRUL(estimator, random_state=seed)
    return RULPipeline(None, estimator)


def _capacity_plot(data: pd.DataFrame, threshold: float, ax=None):
    """Capacity against discharge of each cell, with the end-of-life threshold."""
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(7, 3.5))
    for name, part in data.groupby("unit", sort=False):
        state = "fails" if part["failed"].any() else "censored"
        ax.plot(part["cycle"], part["capacity"], label=f"{name} ({state})")
    ax.axhline(threshold, color="k", linestyle="--", linewidth=0.8, label="end of life")
    ax.set_xlabel("discharge (cycles)")
    ax.set_ylabel("capacity (Ah)")
    ax.legend(fontsize="small")
    return ax


def _at_discharges(table: pd.DataFrame, cell, discharges=(40, 60, 80)) -> dict:
    """A held-out cell's predicted and true RUL at a few discharges."""
    part = table[table["unit"] == cell].set_index("time")
    return {
        str(k): {
            "rul": float(part.loc[k, "rul"]),
            "lower": float(part.loc[k, "lower"]),
            "upper": float(part.loc[k, "upper"]),
            "rul_true": float(part.loc[k, "rul_true"]),
        }
        for k in discharges
        if k in part.index
    }


def run_battery(
    model,
    sink,
    seed,
    *,
    rul_cap,
    options,
    calibrate,
    time_unit: str = "cycles",
) -> dict[str, Any]:
    """Leave-one-cell-out RUL on the NASA cells (see the module notes).

    The files are registered with ``sink`` (a :class:`pdmkit._outputs.OutputRun` or a
    sub-folder of one) and written when the caller commits it.
    """
    data = load_nasa_battery()
    failed = [u for u, part in data.groupby("unit", sort=False) if part["failed"].any()]
    # each failed cell followed through its life by a model trained on the others
    path, fit_seconds, level = cross_validate(
        data,
        unit_folds(failed, "units"),
        lambda: _battery_estimator(model, seed, rul_cap, options, calibrate),
    )
    life = data[data["unit"].isin(failed)].groupby("unit", sort=False)["cycle"].max()
    table, metrics, acc, fractions = _trajectory_scores(path, life, rul_cap)
    check = _trajectory_coverage(table, rul_cap, level, [], len(failed))
    at = {cell: _at_discharges(table, cell) for cell in failed}
    final = _battery_estimator(model, seed, rul_cap, options, calibrate).fit(data)
    final.time_unit_ = time_unit
    summary: dict[str, Any] = {
        "model": model,
        "dataset": "nasa-battery",
        "rmse": metrics["rmse"],
        "mae": metrics["mae"],
        "phm08_score": metrics["phm08_score"],
        "coverage": metrics["coverage"],
        "n_units": len(failed),
        "n_predictions": metrics["n"],
        "bias": metrics["bias"],
        "mean_interval_width": metrics["mean_width"],
        "level": float(
            getattr(final.model, "level_", None) or getattr(final.model, "level", 0.9)
        ),
        "within_10pct": fractions,
        "coverage_check": check,
        "per_cell": {
            str(u): {
                "life": float(life[u]),
                "mae_last_half": float(acc.loc[u, "mae"]),
                "at_discharge": at[u],
            }
            for u in failed
        },
        "eol_capacity_ah": BATTERY_EOL_AH,
        "censored_cells": sorted(set(data["unit"]) - set(failed)),
        "rul_cap": rul_cap,
        "time_unit": time_unit,
        "seed": seed,
        "fit_seconds": round(fit_seconds, 2),
        "estimator": repr(final.model),
        **_calibration(final),
    }
    _save_pipeline(final, sink, summary)
    sink.add_parquet("predictions.parquet", table.copy())
    report = Report(f"pdmkit rul: {model} on the NASA Li-ion cells")
    report.add_text(
        f"Model: {RUL_MODELS[model]} ({summary['estimator']}), reading the capacity per "
        f"discharge directly; end of life at {BATTERY_EOL_AH} Ah. Each cell that reached "
        f"it ({', '.join(failed)}) is held out in turn and predicted at every "
        "discharge by the model trained on the other three cells (the censored "
        f"{', '.join(summary['censored_cells'])} included). Scores over the last half "
        "of each held-out cell's life."
    )
    report.add_figure(
        _capacity_plot(data, BATTERY_EOL_AH), caption="Capacity fade of the four cells"
    )
    report.add_figure(
        _trajectory_plot(table, failed, time_unit=time_unit),
        caption="RUL against discharge for each held-out cell (true RUL dashed; "
        "dotted: the model's interval; shaded: within 10 % of the cell's life over its "
        "last half)",
    )
    report.add_table(acc, caption="Per held-out cell, over the last half of its life")
    return _finish(report, summary, sink)
