"""The RUL workflow on run-to-failure tables: C-MAPSS FD001 or the user's (train, test).

:func:`run_tables` is what ``run_rul`` runs for every dataset but the simulated air-leak
units (:mod:`pdmkit.experiments._rul_leak`) and the NASA cells
(:mod:`pdmkit.experiments._rul_battery`), in four steps: the model is trained on the
training units and predicts each test unit's RUL at its last observed time
(:func:`_fit_predict`); the checks of :mod:`pdmkit.experiments._rul_checks` run and the
predictions are scored against the true RULs (:func:`_check_and_score`); the summary,
the predictions table and the report are registered with the output run.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from pdmkit.ensembles import load_cmapss, read_table
from pdmkit.errors import DataError, DataWarning
from pdmkit.experiments._report import Report, _readable_float
from pdmkit.experiments._rul_checks import (
    cap_text,
    default_time_unit,
    input_checks,
    interval_checks,
    sample_checks,
)
from pdmkit.experiments._rul_models import (
    RUL_MODELS,
    _calibration,
    _finish,
    _fit_pipeline,
    _indicator_plot,
    _save_pipeline,
    _time_col,
    coverage_warning,
)
from pdmkit.rul import rul_metrics

__all__ = [
    "read_tables",
    "run_tables",
    "with_true_rul",
]

_CMAPSS_SENSORS = [f"sensor_{i}" for i in range(1, 22)]


def default_features(train: pd.DataFrame) -> list:
    """The model's input columns of a user's table.

    Every numeric column but the keys, the labels and ``setting*``.
    """
    skip = {"unit", "time", "cycle", "rul", "rul_true_final", "failed"}
    return [
        c
        for c in train.columns
        if c not in skip
        and not str(c).startswith("setting")
        and pd.api.types.is_numeric_dtype(train[c])
    ]


def read_tables(dataset, features):
    """Return (name, train, test, true RUL per test unit, feature columns)."""
    if isinstance(dataset, str):
        key = dataset.lower().replace("_", "-")
        if key not in ("cmapss-fd001", "cmapss"):
            raise DataError(
                f"dataset {dataset!r} is not known to the RUL workflow; use "
                "'cmapss-fd001', 'pneumatic-leak', 'nasa-battery' or pass "
                "(train_table, test_table)"
            )

        train = load_cmapss("FD001", "train")
        test = load_cmapss("FD001", "test")
        name = "cmapss-fd001"
        default = _CMAPSS_SENSORS
    else:
        try:
            train, test = dataset
        except (TypeError, ValueError):
            raise DataError(
                "dataset must be a name ('cmapss-fd001') or a pair (train_table, "
                "test_table) of long tables"
            ) from None
        if not isinstance(train, pd.DataFrame) or not isinstance(test, pd.DataFrame):
            raise DataError("dataset tables must be pandas DataFrames")
        name = "tables"
        default = default_features(train)
    for part, table in (("train", train), ("test", test)):
        if "unit" not in table.columns:
            raise DataError(f"the {part} table has no 'unit' column")
    if "rul_true_final" not in test.columns:
        raise DataError(
            "the test table needs a 'rul_true_final' column: each test unit's true RUL "
            "after its last row"
        )
    true = test.groupby("unit", sort=False)["rul_true_final"].first()
    cols = list(features) if features is not None else default
    return name, train, test, true, cols


def with_true_rul(test: pd.DataFrame, path) -> pd.DataFrame:
    r"""The test table with ``rul_true_final`` from a true-RUL file (``--test-rul``).

    The file (CSV / text / Parquet, a header line or none) holds one true RUL per test
    unit: the RUL after the unit's last row. One column: line ``i`` belongs to the
    ``i``-th test unit in order of appearance (C-MAPSS's ``RUL_FD001.txt``: line ``i``,
    unit ``i``); numeric unit ids must then appear in ascending order, else which line
    is which unit is ambiguous. Two columns ``unit`` and another: a value per unit id.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import pandas as pd
    >>> from pdmkit.experiments._rul_tables import with_true_rul
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "RUL.txt"
    >>> _ = path.write_text("RUL\n112\n98\n")
    >>> test = pd.DataFrame({"unit": [1, 1, 2], "cycle": [1, 2, 1], "s1": 0.0})
    >>> with_true_rul(test, path)["rul_true_final"].tolist()
    [112, 112, 98]
    """
    if "rul_true_final" in test.columns:
        raise DataError(
            f"--test-rul {path}: the --test table has its own rul_true_final column; "
            "give the true RULs once (drop the column or --test-rul)"
        )
    with warnings.catch_warnings():  # a bare column of numbers is the expected form
        warnings.filterwarnings("ignore", "(?s).*holds only numbers", DataWarning)
        table = read_table(path)
    units = pd.unique(test["unit"])
    named = {str(c).strip().lower(): c for c in table.columns}
    if "unit" in named and table.shape[1] == 2:
        value = next(c for c in table.columns if c != named["unit"])
        values = pd.Series(table[value].to_numpy(), index=table[named["unit"]])
        if values.index.has_duplicates:
            raise DataError(f"--test-rul {path}: a unit is listed twice")
        missing = [u for u in units if u not in values.index]
        if missing:
            raise DataError(
                f"--test-rul {path}: no true RUL for test unit(s) {missing[:5]} "
                f"(the file lists {len(values)} units)"
            )
        true = values.reindex(units)
    elif table.shape[1] == 1:
        true = _true_rul_in_order(table.iloc[:, 0], units, path)
    else:
        raise DataError(
            f"--test-rul {path}: expected one column of true RULs (one line per test "
            f"unit) or two, unit and RUL; found {table.shape[1]} columns "
            f"{list(table.columns)[:6]}"
        )
    numbers = pd.to_numeric(true, errors="coerce")
    bad = ~np.isfinite(numbers.to_numpy(dtype=float)) | (numbers.to_numpy() < 0)
    if bad.any():
        raise DataError(
            f"--test-rul {path}: the true RUL of unit {true.index[bad][0]!r} is "
            f"{true[bad].iloc[0]!r}; expected a number >= 0"
        )
    return test.assign(rul_true_final=test["unit"].map(numbers))


def _true_rul_in_order(column: pd.Series, units, path) -> pd.Series:
    """One true RUL per test unit, line ``i`` for the ``i``-th unit (see above)."""
    if len(column) != len(units):
        raise DataError(
            f"--test-rul {path} gives {len(column)} true RULs for {len(units)} test "
            "units; expected one line per test unit, in unit order"
        )
    ids = pd.to_numeric(pd.Series(units), errors="coerce")
    if ids.notna().all() and not ids.is_monotonic_increasing:
        raise DataError(
            f"--test-rul {path}: the test units appear in the order "
            f"{', '.join(map(str, units[:4]))}, ... (not ascending), so which line of "
            "the file is which unit is ambiguous; sort the test table by unit, or give "
            "the file two columns, unit and RUL"
        )
    return pd.Series(column.to_numpy(), index=units)


@dataclass(frozen=True)
class _Job:
    """What the run was asked for: the model and its settings, the data and its unit."""

    model: str
    seed: int
    cap: float | None
    cap_source: str
    options: dict | None
    calibrate: bool
    unit: str
    n_trajectories: int
    name: str
    train: pd.DataFrame
    test: pd.DataFrame
    true: pd.Series
    cols: list

    @property
    def n_train(self) -> int:
        """Training units."""
        return int(self.train["unit"].nunique())


@dataclass(frozen=True)
class _Fit:
    """The fitted pipeline, the transformed test table and the test units' predictions."""

    pipeline: Any
    test_in: pd.DataFrame
    pred: Any
    fit_seconds: float
    predict_seconds: float


@dataclass(frozen=True)
class _Scores:
    """The checks' findings and the scores against the true RULs (capped and not)."""

    found: list[str]
    notes: Any
    intervals: dict
    ood: pd.Series
    endings: Any
    truth: np.ndarray
    capped: np.ndarray
    headline: dict
    raw: dict
    coverage: dict


def run_tables(
    sink,
    model,
    seed,
    *,
    dataset,
    features,
    rul_cap,
    cap_source,
    options,
    n_trajectories,
    calibrate,
    time_unit,
    key,
) -> dict[str, Any]:
    """``run_rul`` on C-MAPSS or a pair of tables; files registered with ``sink``.

    ``key`` is the dataset's name as ``run_rul`` reads it (None for tables); the time
    unit defaults to the dataset's (:func:`default_time_unit`).
    """
    name, train, test, true, cols = read_tables(dataset, features)
    unit = time_unit or default_time_unit(key, train)
    job = _Job(
        model, seed, rul_cap, cap_source, options, calibrate, unit, n_trajectories,
        name, train, test, true, cols,
    )  # fmt: skip
    fit = _fit_predict(job)
    scores = _check_and_score(job, fit)
    summary = _summary(job, fit, scores)
    _save_pipeline(fit.pipeline, sink, summary)
    table = _predictions_table(fit, scores)
    sink.add_parquet("predictions.parquet", table.copy())
    report = _report_opening(job, fit, scores, summary)
    _add_trajectories(report, job, fit)
    if fit.pipeline.indicator is not None:
        report.add_figure(
            _indicator_plot(
                fit.pipeline.transform(job.train), fit.pipeline.model, job.unit
            ),
            caption="Health indicator of ten training units",
        )
    report.add_table(
        table.drop(columns=[c for c in ("nearest",) if c in table]),
        caption="Predictions per test unit (ood_score above 1: outside the training data)",
    )
    return _finish(report, summary, sink)


def _training_sample(train: pd.DataFrame, cols, n: int = 5000) -> pd.DataFrame:
    """Up to ``n`` training rows, kept in the model file.

    The rows hold the unit, the time and the model's columns, so that ``--trained`` can
    score how far new histories lie from them.
    """
    keys = [c for c in ("unit", "time", "cycle") if c in train.columns][:2]
    usable = [c for c in cols if c in train.columns and c not in keys]
    sample = train[[*keys, *usable]]
    if len(sample) > n:
        sample = sample.iloc[np.linspace(0, len(sample) - 1, n).astype(int)]
    return sample.rename(columns={keys[-1]: "time"}).reset_index(drop=True)


def keep_training_info(pipeline, train: pd.DataFrame, cols, time_unit: str) -> None:
    """What ``--trained`` needs of the training run, kept on the fitted pipeline."""
    pipeline.time_unit_ = time_unit
    # the training table's columns, in order: a header-less history of the same width
    # (the raw C-MAPSS text files) gets these names by position (see _predict_rul)
    pipeline.table_columns_ = [str(c) for c in train.columns if c != "rul_true_final"]
    pipeline.training_sample_ = _training_sample(train, cols)


def _fit_predict(job: _Job) -> _Fit:
    """Train on the training units; predict each test unit at its last observed time."""
    pipeline, fit_seconds = _fit_pipeline(
        job.model,
        job.cols,
        job.train,
        seed=job.seed,
        rul_cap=job.cap,
        options=job.options,
        calibrate=job.calibrate,
    )
    keep_training_info(pipeline, job.train, job.cols, job.unit)
    test_in = pipeline.transform(job.test)
    start = time.perf_counter()
    pred = pipeline.model.predict(test_in)
    predict_seconds = time.perf_counter() - start
    pred.time_unit = job.unit
    return _Fit(pipeline, test_in, pred, fit_seconds, predict_seconds)


def _check_and_score(job: _Job, fit: _Fit) -> _Scores:
    """Run the checks a model cannot make itself, then score the answered test units."""
    found: list[str] = []
    pred = fit.pred
    sample_checks(
        job.model, fit.pipeline.model, job.calibrate, job.n_train, len(pred), found
    )
    ood, endings = input_checks(job.train, job.test, job.cols, job.unit, found)
    notes, interval_counts = interval_checks(pred, job.cap, job.unit, found)
    truth = job.true.reindex(pred.unit).to_numpy(dtype=float)
    capped = np.minimum(truth, np.inf if job.cap is None else job.cap)
    answered = ~np.isnan(pred.estimate)
    if not answered.any():
        raise DataError(
            f"the model ({job.model}) gives no estimate for any test unit ({notes[0]}); "
            "nothing to score - check the indicator's direction and threshold"
        )
    part = (pred.estimate[answered], pred.lower[answered], pred.upper[answered])
    headline = rul_metrics(capped[answered], *part)
    raw = rul_metrics(truth[answered], *part)
    coverage = coverage_warning(capped[answered], *part[1:], pred.level, found)
    return _Scores(
        found, notes, interval_counts, ood, endings, truth, capped, headline, raw,
        coverage,
    )  # fmt: skip


def _summary(job: _Job, fit: _Fit, scores: _Scores) -> dict[str, Any]:
    """The run's ``summary.json`` (before the paths of its files are added)."""
    headline, raw, ood = scores.headline, scores.raw, scores.ood
    indicator, estimator = fit.pipeline.indicator, fit.pipeline.model
    return {
        "model": job.model,
        "dataset": job.name,
        "time_unit": job.unit,
        "rmse": headline["rmse"],
        "mae": headline["mae"],
        "phm08_score": headline["phm08_score"],
        "coverage": headline["coverage"],
        "n_units": headline["n"],
        "bias": headline["bias"],
        "mean_interval_width": headline["mean_width"],
        "rmse_uncapped": raw["rmse"],
        "mae_uncapped": raw["mae"],
        "phm08_score_uncapped": raw["phm08_score"],
        "coverage_uncapped": raw["coverage"],
        "level": fit.pred.level,
        "rul_cap": job.cap,
        "rul_cap_source": job.cap_source,
        "seed": job.seed,
        "n_train_units": job.n_train,
        "n_test_units": len(fit.pred),
        "intervals": scores.intervals,
        "coverage_check": scores.coverage,
        "ood": {
            "max": float(ood.max()) if len(ood) else 0.0,
            "n_outside": int((ood > 1.0).sum()),
            "threshold": 1.0,
        },
        "shutdown_endings": scores.endings,
        "checks": list(scores.found),
        "fit_seconds": round(fit.fit_seconds, 2),
        "predict_seconds": round(fit.predict_seconds, 2),
        "estimator": repr(estimator),
        **_calibration(fit.pipeline),
        "features": list(indicator.selected_)
        if indicator is not None
        else list(getattr(estimator, "features_", job.cols)),
    }


def _predictions_table(fit: _Fit, scores: _Scores) -> pd.DataFrame:
    """One row per test unit: the prediction, its notes and the true RUL."""
    table = fit.pred.to_pandas()
    table["interval_note"] = scores.notes
    table["ood_score"] = scores.ood.reindex(fit.pred.unit).to_numpy(dtype=float)
    table["rul_true"] = scores.truth
    table["rul_true_capped"] = scores.capped
    if "nearest" in table.columns:
        table["nearest"] = table["nearest"].map(lambda v: ",".join(map(str, v)))
    return table


def _report_opening(job: _Job, fit: _Fit, scores: _Scores, summary: dict) -> Report:
    """The report's opening: the run in words, its warnings, the scores and their plot."""
    u, cap, pred = job.unit, job.cap, fit.pred
    cap_phrase = cap_text(cap, u, job.cap_source)
    report = Report(f"pdmkit rul: {job.model} on {job.name}")
    report.add_text(
        f"Model: {RUL_MODELS[job.model]} ({summary['estimator']}). Trained on "
        f"{job.n_train} run-to-failure units; each of the {len(pred)} test units is "
        f"predicted at its last observed time. Time unit: {u}. {cap_phrase[0].upper()}"
        f"{cap_phrase[1:]}"
        + (" (predictions and true RULs capped for the headline scores)" if cap else "")
        + f"; intervals are {100 * pred.level:g} %. Seed {job.seed}; fit "
        f"{fit.fit_seconds:.1f} s."
    )
    if scores.found:
        report.add_heading("Warnings")
        for message in scores.found:
            report.add_text(message)
    rows = ("rmse", "mae", "phm08_score", "coverage", "bias")
    table = pd.DataFrame(
        {
            (f"capped at {cap:g} {u}" if cap else "scores"): [
                scores.headline[k] for k in rows
            ],
            **({"uncapped": [scores.raw[k] for k in rows]} if cap else {}),
        },
        index=[
            f"RMSE ({u})",
            f"MAE ({u})",
            "PHM08 score",
            "interval coverage",
            f"bias, pred - true ({u})",
        ],
    )
    table = table.map(lambda v: _readable_float(v) if abs(v) >= 1e6 else v)
    report.add_table(table, caption="Scores on the test units")
    report.add_figure(
        pred.plot(true=scores.capped, time_unit=u),
        caption=f"Predicted against true RUL ({u}"
        + (f", capped at {cap:g})" if cap else ")"),
    )
    return report


def _add_trajectories(report: Report, job: _Job, fit: _Fit) -> None:
    """RUL against time for test units from the median history length to the longest."""
    pred, test, true = fit.pred, job.test, job.true
    lengths = test.groupby("unit").size().reindex(pred.unit).to_numpy()
    order = np.argsort(lengths, kind="stable")
    picks = np.unique(
        np.linspace(len(order) // 2, len(order) - 1, job.n_trajectories).round()
    )
    shown = [pred.unit[order[int(i)]] for i in picks] if job.n_trajectories > 0 else []
    if not shown:
        return
    subset = fit.test_in[fit.test_in["unit"].isin(shown)]
    path = fit.pipeline.model.predict_trajectory(subset, every=5)
    end = {v: test.loc[test.unit == v, _time_col(test)].max() + true[v] for v in shown}
    top = np.inf if job.cap is None else job.cap
    path_true = np.minimum(
        [end[v] - t for v, t in zip(path.unit, path.time, strict=True)], top
    )
    report.add_figure(
        path.plot(true=path_true, units=shown, time_unit=job.unit),
        caption="RUL against time for test units with histories from the median "
        "length to the longest (true RUL dashed" + (", capped)" if job.cap else ")"),
    )
