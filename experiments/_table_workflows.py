"""The feature-table workflows: indicators, ranking, classifiers, sensors.

Each ``run_*`` reads its members or indicators from a :class:`TableSource`, does its
work, and writes its files, its JSON summary and an HTML report into ``out_dir`` (all
at once, beside what the folder holds; see :mod:`pdmkit._outputs`), as the
``pdmkit features / rank / classify / sensors`` commands do.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Sequence
from pathlib import Path

import pandas as pd

from pdmkit._outputs import OutputRun
from pdmkit.errors import DataError, DataWarning, did_you_mean
from pdmkit.experiments._messages import finish, say
from pdmkit.experiments._report import Report
from pdmkit.experiments._sensor_costs import load_sensor_costs
from pdmkit.experiments._sources import (
    TableSource,
    extraction_input,
    feature_table,
    order_column,
    parse_sensors,
    require_label,
)

__all__ = ["run_features", "run_rank", "run_sensors"]

PathLike = str | os.PathLike


def run_features(
    source: TableSource,
    *,
    out_dir: PathLike,
    json_path: PathLike | None = None,
    batch_size: int = 512,
    workers: int | None = None,
    scheduler: str | None = None,
    fresh: bool = False,
    strict: bool = False,
) -> dict:
    """Extract condition indicators; write ``features.parquet``, the errors and a report.

    A resumable run: every batch of ``batch_size`` members is committed to
    ``out_dir/run`` as soon as it is done, so a run started again after a crash
    computes only what is missing (see :func:`extract_features_run`).

    Parameters
    ----------
    source : TableSource
        A dataset, ensemble or member files (not a feature table).
    out_dir : path
        Receives ``features.parquet``, ``errors.parquet``, ``summary.json`` and
        ``report.html``.
    json_path : path, optional
        Also write the summary here.
    batch_size : int, default 512
        Members per partition.
    workers : int, optional
        Run on a local Dask cluster of this many worker processes.
    scheduler : str, optional
        Run on the Dask cluster at this address.
    fresh : bool, default False
        Discard the partitions a previous run left and start over.
    strict : bool, default False
        Stop at the first member with bad data (default: leave it out, say so).

    Returns
    -------
    dict
        The summary: ``n_members``, ``n_features``, ``features``, ``conditions``,
        ``n_skipped`` and the ``errors`` rows, the paths written.

    Examples
    --------
    >>> import tempfile, numpy as np, pandas as pd
    >>> from pdmkit.experiments import TableSource, run_features
    >>> folder, out = tempfile.mkdtemp(), tempfile.mkdtemp()
    >>> t = np.arange(512) / 512.0
    >>> for i in range(4):
    ...     x = np.sin(2 * np.pi * (5 + i) * t)
    ...     pd.DataFrame({"time": t, "v": x}).to_csv(f"{folder}/m{i}.csv", index=False)
    >>> source = TableSource(members=[folder], groups=["stats"], quiet=True)
    >>> summary = run_features(source, out_dir=out)
    >>> summary["n_members"], summary["n_features"], summary["n_skipped"]
    (4, 11, 0)
    """
    from pdmkit.experiments._runs import extract_features_run, mark_run

    on_error = "raise" if strict else "skip"
    with OutputRun(
        out_dir, "features", inputs=source.input_paths(), json_path=json_path
    ) as run:
        ensemble, groups, options, _, _, _, read_errors = extraction_input(
            source, on_error, json_path
        )
        out = Path(out_dir)
        where = (
            f"on the Dask scheduler {scheduler}"
            if scheduler
            else f"on {workers} local Dask workers"
            if workers
            else "in-process"
        )
        size = f"{len(ensemble)} members" if not isinstance(ensemble, str) else ensemble
        say(f"extracting {', '.join(groups)} indicators from {size} {where}")
        run.open()  # hold OUT while its partition store (OUT/run) fills
        table, errors = extract_features_run(
            ensemble,
            out / "run",
            signals=source.signals,
            groups=groups,
            batch_size=batch_size,
            on_error=on_error,
            fresh=fresh,
            client=scheduler or workers,
            replace_stale=True,  # other settings: a failed run, or one saved, goes
            progress=source.progress,
            **options,
        )
        if read_errors is not None and len(read_errors):
            errors = pd.concat([read_errors, errors], ignore_index=True)
        run.add_parquet("features.parquet", table)
        run.add_parquet("errors.parquet", errors)
        summary = _features_summary(table, errors, out)

        def saved() -> None:  # under OUT's lock: the store's results are in OUT now
            mark_run(out / "run", "saved", run.id)

        finish(run, summary, _features_report(table, errors, summary), saved)
    return summary


def _features_summary(table: pd.DataFrame, errors: pd.DataFrame, out: Path) -> dict:
    feature_cols = [c for c in table.columns if "/" in str(c)]
    return {
        "n_members": len(table),
        "n_features": len(feature_cols),
        "features": feature_cols,
        "conditions": [c for c in table.columns if c not in feature_cols],
        "path": str(out / "features.parquet"),
        "n_skipped": int(errors["member"].nunique()),
        "errors": errors.to_dict(orient="records"),
        "errors_path": str(out / "errors.parquet"),
    }


def _features_report(table: pd.DataFrame, errors: pd.DataFrame, summary: dict) -> Report:
    report = Report("pdmkit features")
    report.add_text(
        f"{summary['n_members']} members, {summary['n_features']} condition indicators."
    )
    if len(errors):
        report.add_text(
            f"{summary['n_skipped']} member(s) were left out for bad input; "
            "see the table below (also in errors.parquet)."
        )
        report.add_table(errors, caption="Members left out")
    described = table[summary["features"]].describe().T
    report.add_table(described, caption="Indicator statistics")
    return report


def _ranking(table: pd.DataFrame, label: str, method: str, features: list[str]):
    from pdmkit.features import rank_features

    return rank_features(table, table[label], method=method, features=features)


def _clock_columns(table, ranked, unit: str | None, order: str | None) -> None:
    """Warn about top-ranked columns that step with the row order itself.

    A clock or a counter (a snapshot's time of day, a cycle count) is monotonic before
    any smoothing, which no noisy health indicator is: the same monotonicity, on the raw
    rows, at 0.98 or more (99 % of the steps one way).
    """
    from pdmkit.features import rank_features

    top = [f for f in ranked["feature"].head(10) if f != order]
    raw = rank_features(table, method="monotonicity", features=top, unit=unit, time=order)
    for row in raw.to_pandas().itertuples():
        if row.score >= 0.98:
            warnings.warn(
                f"{row.feature!r} is monotonic in the raw rows ordered by "
                f"{order or 'the row number'!r} (monotonicity {row.score:.3f} before "
                "smoothing): a clock or a counter, not a health indicator; leave it out "
                "with --features",
                DataWarning,
                stacklevel=2,
            )


def run_rank(
    source: TableSource,
    *,
    out_dir: PathLike,
    json_path: PathLike | None = None,
    method: str = "fisher",
    unit: str | None = None,
    order: str | None = None,
    window: int | None = None,
    top: int = 20,
    stability_folds: int | None = None,
    group: str | None = None,
) -> dict:
    """Rank the condition indicators; write ``ranking.parquet`` and a report.

    Parameters
    ----------
    source : TableSource
        Members (indicators are extracted) or a feature table.
    out_dir : path
        Receives ``ranking.parquet``, ``summary.json`` and ``report.html``.
    json_path : path, optional
        Also write the summary here.
    method : str, default "fisher"
        Separate the label's classes: ``fisher`` (Fisher's discriminant ratio),
        ``kruskal`` (Kruskal-Wallis H), ``anova``, ``auc`` (one-vs-rest ROC AUC) or
        ``bhattacharyya``; or track degradation over each unit's rows:
        ``monotonicity``, ``trendability``, ``prognosability``. The default was
        ``kruskal`` before: H (and the AUC, for two classes) is the same for every
        indicator that separates the classes completely, Fisher's ratio keeps growing
        with the gap between them.
    unit : str, optional
        Prognostic methods: the column telling run-to-failure units apart (default
        ``unit`` when the table has one).
    order : str, optional
        Prognostic methods: the column ordering each unit's rows (default: the
        source's ``time``, else a column named time/timestamp/date/cycle).
    window : int, optional
        Prognostic methods: smooth each unit's path over this many rows first.
    top : int, default 20
        Rows of the ranking in the summary.
    stability_folds : int, optional
        Class methods: also rank on the training rows of this many cross-validation
        folds (:func:`pdmkit.features.ranking_stability`); ``ranking.parquet`` gains
        ``mean_rank``, ``rank_std`` and ``in_top_k`` (top 10), the summary a
        ``stability`` entry (mean Spearman and Kendall between the folds).
    group : str, optional
        With ``stability_folds``: the column whose rows stay on one side of every
        split (e.g. the recording that frames were cut from).

    Returns
    -------
    dict
        ``method``, the label or unit/time columns used, the top ``ranking`` rows.

    Examples
    --------
    >>> import tempfile, numpy as np, pandas as pd
    >>> from pdmkit.experiments import TableSource, run_rank
    >>> rng = np.random.default_rng(0)
    >>> fault = np.repeat(["healthy", "worn"], 30)
    >>> table = pd.DataFrame({"acc/stats/RMS": rng.normal(size=60) + 3 * (fault == "worn"),
    ...                       "mic/stats/RMS": rng.normal(size=60), "fault": fault})
    >>> path = f"{tempfile.mkdtemp()}/table.csv"
    >>> table.to_csv(path, index=False)
    >>> source = TableSource(features=path, label="fault")
    >>> summary = run_rank(source, out_dir=tempfile.mkdtemp(), stability_folds=3)
    >>> summary["method"], summary["ranking"][0]["feature"]
    ('fisher', 'acc/stats/RMS')
    >>> summary["ranking"][0]["in_top_k"], summary["stability"]["n_splits"]
    (1.0, 3)
    """
    from pdmkit.features import CLASS_METHODS, rank_features, ranking_stability

    with OutputRun(
        out_dir, "rank", inputs=source.input_paths(), json_path=json_path
    ) as run:
        table, label, _, features = feature_table(source)
        if group is not None and stability_folds is None:
            raise DataError(
                "--group keeps a group's rows in one fold of --stability-folds N; "
                "add --stability-folds"
            )
        if group is not None and group not in table.columns:
            conditions = [str(c) for c in table.columns if "/" not in str(c)]
            raise DataError(
                f"--group {group!r} is not a column of the feature table; its columns "
                f"without '/' are {conditions}{did_you_mean(group, conditions)}"
            )
        if method in CLASS_METHODS:
            for flag, value in (("unit", unit), ("window", window)):
                if value is not None:
                    raise DataError(
                        f"--{flag} is for the prognostic methods (monotonicity, "
                        f"trendability, prognosability), not --method {method}"
                    )
            label = require_label(table, label)
            ranking = _ranking(table, label, method, features)
            described: dict = {"label": label}
        else:
            if stability_folds is not None:
                raise DataError(
                    f"--stability-folds is for the class methods {list(CLASS_METHODS)}, "
                    f"not --method {method}"
                )
            unit, order, described = _prognostic_keys(table, source, method, unit, order)
            described["window"] = window
            say(
                described.pop("said") + (f", smoothed over {window} rows" if window else "")
            )
            ranking = rank_features(
                table,
                method=method,
                features=features or None,
                unit=unit,
                time=order,
                window=window,
            )
            _clock_columns(table, ranking.to_pandas(), unit, order)
        ranked = ranking.to_pandas()
        stability = None
        if stability_folds is not None:
            stability = ranking_stability(
                table,
                table[label],
                method=method,
                features=list(ranking.features),
                groups=None if group is None else table[group],
                n_splits=stability_folds,
            )
            folds = stability.to_pandas()[["feature", "mean_rank", "rank_std", "in_top_k"]]
            ranked = ranked.merge(folds, on="feature", how="left")
        run.add_parquet("ranking.parquet", ranked)
        summary = {"method": method, **described}
        summary["ranking"] = ranked.head(top).to_dict(orient="records")
        report = Report(f"pdmkit rank ({method})")
        report.add_figure(ranking.plot(k=min(top, 30)), caption="Ranked indicators")
        report.add_table(ranked.head(top), caption=f"Top {top} indicators")
        if stability is not None:
            said = ("n_splits", "splitter", "k", "spearman", "kendall")
            summary["stability"] = {"group": group}
            summary["stability"].update({a: getattr(stability, a) for a in said})
            caption = f"Rank on the training rows of each fold: {stability!r}"
            report.add_figure(stability.plot(k=min(top, 30)), caption=caption)
        finish(run, summary, report)
    return summary


def _prognostic_keys(table, source, method, unit, order) -> tuple:
    """(unit column, order column, what the summary says about them) for a ranking."""
    if unit is not None and unit not in table.columns:
        conditions = [str(c) for c in table.columns if "/" not in str(c)]
        raise DataError(
            f"--unit {unit!r} is not a column of the feature table; its "
            f"columns without '/' are {conditions}{did_you_mean(unit, conditions)}"
        )
    if unit is None and "unit" in table.columns:
        unit = "unit"
    order = order_column(table, source, order)
    units = table[unit].nunique() if unit is not None else 1
    by = f"{order!r}"
    if order is not None and order.startswith("Unnamed: "):
        by = "the unnamed first column (timestamps)"
    said = (
        f"{method}: {units} unit(s)"
        + (f" told apart by {unit!r}" if unit is not None else " (no --unit column)")
        + (f", rows ordered by {by}" if order else ", rows in the order given")
    )
    return unit, order, {"unit": unit, "time": order, "n_units": int(units), "said": said}


def run_sensors(
    source: TableSource,
    *,
    out_dir: PathLike,
    json_path: PathLike | None = None,
    sensors: Sequence[str] | None = None,
    costs: PathLike | None = None,
    model: str = "knn",
    top_k: int = 5,
    seed: int = 0,
    group: str | None = None,
) -> dict:
    """Compare sensors by cross-validated accuracy and cost; write a report.

    Parameters
    ----------
    source : TableSource
        Members (indicators are extracted) or a feature table, with ``label``.
    out_dir : path
        Receives ``summary.json`` and ``report.html``.
    json_path : path, optional
        Also write the summary here.
    sensors : sequence of str, optional
        ``"NAME=SIG[,SIG]"``: a sensor and the signals it owns; default one sensor per
        signal (or the dataset's sensors).
    costs : path, optional
        TOML file of sensor costs (see :func:`load_sensor_costs`).
    model, top_k, group : see :func:`compare_sensors`
    seed : int, default 0

    Returns
    -------
    dict
        :meth:`SensorComparison.summary`: each sensor's accuracy and cost, the Pareto
        front.

    Examples
    --------
    >>> import tempfile, numpy as np, pandas as pd
    >>> from pdmkit.experiments import TableSource, run_sensors
    >>> rng = np.random.default_rng(0)
    >>> fault = np.repeat(["healthy", "worn"], 30)
    >>> table = pd.DataFrame({"acc/stats/RMS": rng.normal(size=60) + 3 * (fault == "worn"),
    ...                       "mic/stats/RMS": rng.normal(size=60), "fault": fault})
    >>> path = f"{tempfile.mkdtemp()}/table.csv"
    >>> table.to_csv(path, index=False)
    >>> source = TableSource(features=path, label="fault")
    >>> summary = run_sensors(source, out_dir=tempfile.mkdtemp(), top_k=1)
    >>> [row["sensor"] for row in summary["sensors"]]
    ['acc', 'mic']
    """
    from pdmkit.experiments._sensors import compare_sensors

    inputs = [*source.input_paths(), *([costs] if costs is not None else [])]
    with OutputRun(out_dir, "sensors", inputs=inputs, json_path=json_path) as run:
        table, label, default_sensors, _ = feature_table(source, common=False)
        label = require_label(table, label)
        chosen = parse_sensors(sensors, table, default_sensors)
        comparison = compare_sensors(
            table,
            label,
            chosen,
            load_sensor_costs(costs),
            model=model,
            top_k=top_k,
            random_state=seed,
            progress=source.progress,
            group=group,
        )
        summary = comparison.summary()
        report = Report("pdmkit sensors")
        frame = comparison.to_pandas()
        report.add_figure(
            comparison.plot(), caption="Accuracy against cost, Pareto front marked"
        )
        report.add_table(frame, caption="Sensors by accuracy (cross-validated) and cost")
        for sensor, note in zip(frame["sensor"], frame["note"], strict=True):
            if note:
                report.add_text(f"{sensor}: {note}")
        finish(run, summary, report)
    return summary
