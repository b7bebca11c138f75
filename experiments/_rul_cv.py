"""Cross-validation by unit: every unit predicted by a model that never saw it.

One code path for the NASA cells' leave-one-cell-out
(:mod:`pdmkit.experiments._rul_battery`) and ``run_rul(table, model, cv="units" | K)``
(``pdmkit rul --train T --cv units|K``) on a user's own run-to-failure table: the
units that failed are split into folds (:func:`unit_folds`: one unit per fold, or K
groups drawn with the seed); for each fold a fresh model is trained on every other unit
(censored ones included) and follows the fold's units through their lives
(:func:`cross_validate`, ``predict_trajectory``). The scores are over the predictions
in the last half of each held-out unit's life, as for the cells and the air-leak runs,
and the empirical coverage of the intervals there is checked against their level
(:func:`pdmkit.rul.coverage_check`, counting units, not predictions). The model saved
beside the scores is trained on all units.

A unit's life is counted from time 0 when every unit's first time is within one
sampling step of 0 (cycles counted from 1, times from 0), else from its own first row
(timestamps): ``life`` in the predictions is then the unit's length, and ``time`` stays
the table's.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import pandas as pd

from pdmkit.errors import DataError
from pdmkit.experiments._report import Report, _readable_float
from pdmkit.experiments._rul_checks import cap_text, default_time_unit, sample_checks
from pdmkit.experiments._rul_models import (
    RUL_MODELS,
    _calibration,
    _finish,
    _save_pipeline,
    _time_col,
    _trajectory_coverage,
    _trajectory_plot,
    _trajectory_scores,
    make_rul_model,
)
from pdmkit.experiments._rul_tables import default_features, keep_training_info
from pdmkit.rul import ConformalRUL, RULPipeline

__all__ = ["cross_validate", "unit_folds"]

#: Predictions per held-out unit the trajectory aims at (``every`` is chosen for it).
CV_POINTS = 60


def unit_folds(units, cv: str | int, seed: int = 0) -> list[list]:
    """The folds of ``units``: one unit each (``"units"``), or ``K`` groups by unit.

    ``K`` groups are drawn at random with ``seed`` and differ in size by one at most.

    Examples
    --------
    >>> from pdmkit.experiments._rul_cv import unit_folds
    >>> unit_folds(["a", "b", "c"], "units")
    [['a'], ['b'], ['c']]
    >>> sorted(len(f) for f in unit_folds(range(7), 3))
    [2, 2, 3]
    """
    units = list(units)
    text = cv.strip().lower() if isinstance(cv, str) else None
    if text in ("units", "unit", "loo"):
        folds = [[u] for u in units]
    else:
        if text is not None and text.isdigit():
            cv = int(text)
        if isinstance(cv, bool) or not isinstance(cv, int | np.integer):
            raise DataError(
                f"cv must be 'units' (leave one unit out) or a number of folds, got {cv!r}"
            )
        k = int(cv)
        if not 2 <= k <= len(units):
            raise DataError(
                f"cv={k} folds need 2 to {len(units)} folds (one unit at least in "
                f"each); the table has {len(units)} units that failed"
            )
        order = np.random.default_rng(seed).permutation(len(units))
        folds = [[units[i] for i in sorted(part)] for part in np.array_split(order, k)]
    if len(folds) < 2:
        raise DataError(
            f"cross-validation needs at least 2 run-to-failure units; the table has "
            f"{len(units)}"
        )
    return folds


def cross_validate(
    data: pd.DataFrame,
    folds: list[list],
    make_pipeline: Callable[[], Any],
    *,
    every: int = 1,
) -> tuple[pd.DataFrame, float, float]:
    """Each fold's units followed through their lives by a model trained without them.

    Returns the predictions of every held-out unit in one table (with its ``fold``),
    the seconds spent fitting, and the intervals' level.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from pdmkit.rul import LinearDegradationModel
    >>> from pdmkit.experiments._rul_cv import cross_validate
    >>> t = np.arange(0.0, 21.0)
    >>> data = pd.concat([pd.DataFrame({"unit": u, "time": t * s, "hi": t / 20})
    ...                   for u, s in enumerate([1.0, 1.1, 0.9])], ignore_index=True)
    >>> table, _, level = cross_validate(
    ...     data, [[0], [1], [2]], lambda: LinearDegradationModel(threshold=1.0), every=5)
    >>> sorted(table["fold"].unique().tolist()), level
    ([0, 1, 2], 0.9)
    """
    paths, fit_seconds, level = [], 0.0, 0.9
    for i, fold in enumerate(folds):
        held = data["unit"].isin(fold).to_numpy()
        pipeline = make_pipeline()
        start = time.perf_counter()
        pipeline.fit(data[~held])
        fit_seconds += time.perf_counter() - start
        path = pipeline.predict_trajectory(data[held], every=every)
        level = float(path.level)
        paths.append(path.to_pandas().assign(fold=i))
    return pd.concat(paths, ignore_index=True), fit_seconds, level


def _pipeline_maker(model, cols, seed, rul_cap, options, calibrate):
    """A function making fresh, unfitted pipelines of the workflow model ``model``."""
    make_rul_model(model, cols, seed=seed, rul_cap=rul_cap, options=options)  # checks

    def make():
        indicator, estimator = make_rul_model(
            model, cols, seed=seed, rul_cap=rul_cap, options=options
        )
        if calibrate:
            estimator = ConformalRUL(estimator, random_state=seed)
        return RULPipeline(indicator, estimator)

    return make


def _median_step(times: pd.Series) -> float:
    """The median step between a unit's sorted times (0 for a single row)."""
    values = np.sort(times.to_numpy(dtype=float))
    return float(np.median(np.diff(values))) if len(values) > 1 else 0.0


def _origins(table: pd.DataFrame, tcol: str) -> tuple[pd.Series, str]:
    """Each unit's start of life on the time axis, and the rule that gave it."""
    times = table.groupby("unit", sort=False)[tcol]
    first = times.min().astype(float)
    step = times.agg(_median_step)
    if (first <= step + 1e-9).all():
        return first * 0.0, "time 0"
    return first, "each unit's first row"


def _failed_units(table: pd.DataFrame) -> list:
    """Units run to failure (all, unless a ``failed`` column marks the censored)."""
    if "failed" not in table.columns:
        return list(pd.unique(table["unit"]))
    ended = table.groupby("unit", sort=False)["failed"].any()
    return [u for u, f in ended.items() if f]


def run_cv(
    sink,
    table: pd.DataFrame,
    model: str,
    seed: int,
    *,
    cv,
    features,
    rul_cap,
    cap_source,
    options,
    calibrate,
    time_unit,
) -> dict[str, Any]:
    """``run_rul(table, model, cv=...)``: files registered with ``sink`` (module notes)."""
    if not isinstance(table, pd.DataFrame) or "unit" not in table.columns:
        raise DataError(
            "cross-validation takes one long table of run-to-failure units with a "
            "'unit' column"
        )
    tcol = _time_col(table)
    cols = list(features) if features is not None else default_features(table)
    unit = time_unit or default_time_unit(None, table)
    failed = _failed_units(table)
    folds = unit_folds(failed, cv, seed)
    make = _pipeline_maker(model, cols, seed, rul_cap, options, calibrate)
    length = table.groupby("unit", sort=False).size()
    every = max(1, math.ceil(float(length.median()) / CV_POINTS))
    path, fit_seconds, level = cross_validate(table, folds, make, every=every)
    origin, counted = _origins(table, tcol)
    ends = table.groupby("unit", sort=False)[tcol].max().astype(float)
    life = (ends - origin)[failed]
    shift = origin.reindex(path["unit"]).to_numpy()
    scored, metrics, acc, fractions = _trajectory_scores(
        path.assign(time=path["time"] - shift), life, rul_cap
    )
    scored["time"] = scored["time"] + shift
    found: list[str] = []
    final = make()
    n_all = int(table["unit"].nunique())
    n_train = n_all - max(map(len, folds))
    sample_checks(model, final.model, calibrate, n_train, len(failed), found)
    check = _trajectory_coverage(scored, rul_cap, level, found, len(failed))
    final.fit(table)
    keep_training_info(final, table, cols, unit)
    fold_of = {u: i for i, fold in enumerate(folds) for u in fold}
    summary = {
        "model": model,
        "dataset": "tables",
        "time_unit": unit,
        "cv": {
            "scheme": "leave one unit out"
            if all(len(f) == 1 for f in folds)
            else f"{len(folds)} folds by unit",
            "n_folds": len(folds),
            "folds": [
                {"fold": i, "units": list(f), "n_train_units": n_all - len(f)}
                for i, f in enumerate(folds)
            ],
            "every": every,
            "life_counted_from": counted,
            "scored": "predictions in the last half of each held-out unit's life",
        },
        **_cv_scores(metrics, fractions, level, check, len(failed)),
        "per_unit": {
            str(u): {
                "fold": fold_of[u],
                "life": float(life[u]),
                "mae_last_half": float(acc.loc[u, "mae"]),
            }
            for u in failed
        },
        "censored_units": [u for u in pd.unique(table["unit"]) if u not in fold_of],
        "rul_cap": rul_cap,
        "rul_cap_source": cap_source,
        "seed": seed,
        "fit_seconds": round(fit_seconds, 2),
        "estimator": repr(final.model),
        **_calibration(final),
        "features": list(final.indicator.selected_)
        if final.indicator is not None
        else list(getattr(final.model, "features_", cols)),
        "checks": list(found),
    }
    _save_pipeline(final, sink, summary)
    sink.add_parquet("predictions.parquet", scored.copy())
    report = _cv_report(summary, scored, acc.assign(fold=acc.index.map(fold_of)), found)
    return _finish(report, summary, sink)


def _cv_scores(metrics, fractions, level, check, n_units) -> dict[str, Any]:
    """The headline scores of a cross-validation for the summary."""
    return {
        "rmse": metrics["rmse"],
        "mae": metrics["mae"],
        "phm08_score": metrics["phm08_score"],
        "coverage": metrics["coverage"],
        "n_units": n_units,
        "n_predictions": metrics["n"],
        "bias": metrics["bias"],
        "mean_interval_width": metrics["mean_width"],
        "level": level,
        "coverage_check": check,
        "within_10pct": fractions,
    }


def _cv_report(summary: dict, scored: pd.DataFrame, acc: pd.DataFrame, found) -> Report:
    """The cross-validation report: the run in words, warnings, scores, trajectories."""
    u, cv = summary["time_unit"], summary["cv"]
    report = Report(f"pdmkit rul: {summary['model']} cross-validated by unit")
    report.add_text(
        f"Model: {RUL_MODELS[summary['model']]} ({summary['estimator']}). "
        f"Cross-validation, {cv['scheme']}: each of the {summary['n_units']} units that "
        f"failed is held out once ({cv['n_folds']} folds) and followed through its life "
        f"(every {cv['every']} sample(s)) by a model trained on the other units only. "
        f"Scores over the predictions in the last half of each held-out unit's life "
        f"(life counted from {cv['life_counted_from']}); "
        f"{cap_text(summary['rul_cap'], u, summary['rul_cap_source'])}; intervals "
        f"{100 * summary['level']:g} %. The saved model is trained on all units."
    )
    if found:
        report.add_heading("Warnings")
        for message in found:
            report.add_text(message)
    rows = {
        f"RMSE ({u})": summary["rmse"],
        f"MAE ({u})": summary["mae"],
        "PHM08 score": summary["phm08_score"],
        "interval coverage": summary["coverage"],
        f"bias, pred - true ({u})": summary["bias"],
        "predictions scored": summary["n_predictions"],
    }
    table = pd.DataFrame({"held-out units": list(rows.values())}, index=list(rows))
    report.add_table(
        table.map(lambda v: _readable_float(v) if abs(v) >= 1e6 else v),
        caption="Cross-validated scores",
    )
    shown = list(acc.sort_values("life").index)
    step = max(1, len(shown) // 4)
    report.add_figure(
        _trajectory_plot(scored, shown[::step][:4], time_unit=u),
        caption="RUL against time for held-out units (true RUL dashed; dotted: the "
        "model's interval; shaded: within 10 % of the unit's life over its last half)",
    )
    report.add_table(acc, caption="Per held-out unit, over the last half of its life")
    return report
