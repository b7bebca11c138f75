"""``pdmkit classify`` and ``pdmkit predict``: train, judge without leakage, deploy.

:func:`run_classify` scores a classifier on members it never saw (whole recordings held
out when members are frames of recordings), writes the report and the JSON (the split
it made under ``split``) and saves the classifier with its recipe to ``model.pdmkit``.
:func:`run_predict` loads such a file, computes the same indicators from new files and
writes per-member and per-recording predictions.
"""

from __future__ import annotations

import dataclasses
import os
from typing import Any

import pandas as pd

from pdmkit._outputs import OutputRun
from pdmkit.errors import DataError, ModelError
from pdmkit.experiments._messages import finish, say
from pdmkit.experiments._report import Report
from pdmkit.experiments._sources import (
    TableSource,
    feature_table,
    order_column,
    require_label,
)

__all__ = ["run_classify", "run_predict"]

PathLike = str | os.PathLike

#: TableSource fields that say *which* members and how they are labelled; the others
#: (signals, groups, options, rate, framing, bearing) are the recipe a model keeps
_NOT_RECIPE = {"dataset", "ensemble", "members", "features", "label", "labels"}
_NOT_RECIPE |= {"label_from_name", "quiet"}
MODEL_FILE = "model.pdmkit"


def recipe_of(source: TableSource) -> dict:
    """The indicator recipe of a source: every option but the members and labels.

    Examples
    --------
    >>> recipe_of(TableSource(members=["a.csv"], fs=1000.0, groups=["stats"]))["groups"]
    ['stats']
    """
    recipe: dict[str, Any] = {"input": "features" if source.features else "members"}
    if source.dataset:
        recipe["dataset"] = source.dataset
    for f in dataclasses.fields(source):
        if f.name in _NOT_RECIPE:
            continue
        value = getattr(source, f.name)
        if isinstance(value, os.PathLike):
            value = str(value)
        elif isinstance(value, tuple):
            value = list(value)
        elif isinstance(value, dict):
            value = {str(k): v for k, v in value.items()}
        recipe[f.name] = value
    return recipe


def run_classify(
    source: TableSource,
    *,
    out_dir: PathLike,
    json_path: PathLike | None = None,
    model: str = "knn",
    top_k: int = 5,
    selection: str = "fisher",
    test_size: float = 0.25,
    split: str = "auto",
    order: str | None = None,
    group: str | None = None,
    gap: int = 1,
    test_where: str | None = None,
    test_table: PathLike | None = None,
    seed: int = 0,
) -> dict:
    """Train a fault classifier, score it on members it never saw, save it.

    Parameters
    ----------
    source : TableSource
        Members (indicators are extracted) or a feature table, with ``label``.
    out_dir : path
        Receives ``summary.json``, ``report.html`` and ``model.pdmkit``.
    json_path : path, optional
        Also write the summary here.
    model, top_k, selection, test_size, split, order, group, gap, test_where
        See :func:`pdmkit.experiments.classify`.
    test_table : path, optional
        A second feature table (read with :func:`pdmkit.ensembles.read_table`) to
        test on; the summary's ``test_accuracy`` is its accuracy.
    seed : int, default 0
        Seed of the split and the estimator.

    Returns
    -------
    dict
        :meth:`ClassificationResult.summary`, plus ``model_file``.

    Examples
    --------
    >>> import tempfile, numpy as np, pandas as pd
    >>> from pdmkit.experiments import TableSource, run_classify
    >>> rng = np.random.default_rng(0)
    >>> fault = np.repeat(["healthy", "worn"], 30)
    >>> table = pd.DataFrame({"acc/stats/RMS": rng.normal(size=60) + 3 * (fault == "worn"),
    ...                       "mic/stats/RMS": rng.normal(size=60), "fault": fault})
    >>> path = f"{tempfile.mkdtemp()}/table.csv"
    >>> table.to_csv(path, index=False)
    >>> source = TableSource(features=path, label="fault")
    >>> summary = run_classify(source, out_dir=tempfile.mkdtemp(), top_k=1)
    >>> summary["features"], summary["accuracy"] > 0.9, summary["split"]["kind"]
    (['acc/stats/RMS'], True, 'random')
    """
    from pdmkit._persist import save_model
    from pdmkit.ensembles import read_table
    from pdmkit.experiments._classify import classify
    from pdmkit.experiments._deploy import FaultClassifier

    inputs = [*source.input_paths(), *([test_table] if test_table else [])]
    with OutputRun(out_dir, "classify", inputs=inputs, json_path=json_path) as run:
        table, label, _, features = feature_table(source)
        label = require_label(table, label)
        if split == "time":
            order = order_column(table, source, order)
        elif order is not None:
            raise DataError("--order orders the members for --split time; give that too")
        test = read_table(test_table) if test_table is not None else None
        result = classify(
            table,
            label,
            features=features,
            model=model,
            top_k=top_k,
            selection=selection,
            test_size=test_size,
            random_state=seed,
            split=split,
            order=order,
            group=group,
            gap=gap,
            test_where=test_where,
            test=test,
            progress=source.progress,
        )
        summary = result.summary()
        if test is not None:
            summary["test_accuracy"] = summary["accuracy"]
        recipe = {**recipe_of(source), "rates_hz": table.attrs.get("fs")}
        clf = FaultClassifier.from_result(result, table, recipe=recipe, random_state=seed)
        run.add_file(MODEL_FILE, lambda p: save_model(clf, p))
        summary["model_file"] = str(run.path(MODEL_FILE))
        for note in _headline_notes(result):
            say(note)
        info = summary["split"]
        say(
            f"held-out accuracy {summary['accuracy']:.4f} ({model}, top {top_k}; "
            f"{info['kind']} split: {info['measures']})"
        )
        finish(run, summary, _classify_report(result, summary, table, label, features))
    return summary


def _headline_notes(result) -> list[str]:
    """The notes a user must read beside the number (split warnings, time blocks)."""
    keys = ("random split", "time split", "no honest split", "single recording")
    return [n for n in result.notes if any(k in n for k in keys)]


def _classify_report(result, summary, table, label, features) -> Report:
    from pdmkit.experiments._table_workflows import _ranking

    info = summary["split"]
    report = Report(f"pdmkit classify ({result.model})")
    report.add_text(
        f"Held-out accuracy {summary['accuracy']:.4f} on {summary['n_test']} members "
        f"(trained on {summary['n_train']}), {info['kind']} split: it measures "
        f"{info['measures']}. Selected indicators: {', '.join(summary['features'])}."
    )
    for note in _headline_notes(result):
        report.add_text(note[0].upper() + note[1:] + ".")
    report.add_figure(result.plot(), caption="Confusion matrix (held-out part)")
    report.add_table(result.to_pandas(), caption="Per-class recall")
    if result.test_groups is not None:
        report.add_table(
            result.group_scores(),
            caption="Per held-out recording: accuracy, worst first",
        )
    if result.selection not in ("pca", None):
        train = table.loc[table.index.intersection(result.train_members)]
        report.add_figure(
            _ranking(train, label, result.selection, features).plot(k=20),
            caption="Indicator ranking (training members only)",
        )
    return report


def run_predict(
    model_path: PathLike,
    source: TableSource,
    *,
    out_dir: PathLike,
    json_path: PathLike | None = None,
    group: str | None = None,
) -> dict:
    """Score new recordings with a classifier saved by ``pdmkit classify``.

    The indicators are computed from ``source``'s member files with the recipe the
    model holds (its signals, groups, options, rate and framing); a feature table is
    matched by column names. Writes ``predictions.csv`` (per member: the predicted
    class, one ``p_<class>`` column per class, ``ood_score`` and
    ``out_of_distribution``) and, when members are frames of recordings,
    ``recordings.csv`` (the majority vote per recording).

    Parameters
    ----------
    model_path : path
        A ``model.pdmkit`` written by ``pdmkit classify`` or the designer.
    source : TableSource
        ``members`` (files; the recipe's options are used) or ``features``.
    out_dir : path
        Receives ``predictions.csv``, ``recordings.csv``, ``summary.json``.
    json_path : path, optional
        Also write the summary here.
    group : str, optional
        The column naming each member's recording for the vote (default
        ``source_member`` when the members are frames).

    Returns
    -------
    dict
        ``n_members``, ``predicted`` (class -> count), ``n_out_of_distribution``,
        ``recordings`` (the vote per recording, when grouped), ``model_file``.

    Examples
    --------
    >>> import tempfile, numpy as np, pandas as pd
    >>> from pdmkit.experiments import TableSource, run_classify, run_predict
    >>> rng = np.random.default_rng(0)
    >>> fault = np.repeat(["healthy", "worn"], 30)
    >>> table = pd.DataFrame({"acc/stats/RMS": rng.normal(size=60) + 3 * (fault == "worn"),
    ...                       "fault": fault})
    >>> d = tempfile.mkdtemp()
    >>> table.to_csv(f"{d}/train.csv", index=False)
    >>> table.iloc[::-1].to_csv(f"{d}/new.csv", index=False)
    >>> s = run_classify(TableSource(features=f"{d}/train.csv", label="fault"),
    ...                  out_dir=f"{d}/run", top_k=1)
    >>> p = run_predict(f"{d}/run/model.pdmkit", TableSource(features=f"{d}/new.csv"),
    ...                 out_dir=f"{d}/pred")
    >>> p["n_members"], sorted(p["predicted"])
    (60, ['healthy', 'worn'])
    """
    from pdmkit._persist import load_model
    from pdmkit.experiments._deploy import FaultClassifier, vote_by_group

    clf = load_model(model_path)
    if not isinstance(clf, FaultClassifier):
        raise ModelError(
            f"{model_path} holds a {type(clf).__name__}, not a fault classifier saved "
            "by pdmkit classify or the designer"
        )
    if source.features is None and clf.recipe.get("input") == "features":
        raise DataError(
            f"{model_path} was trained on a feature table, so it cannot compute its "
            "indicators from recordings; give --features TABLE with the same columns"
        )
    inputs = [model_path, *source.input_paths()]
    with OutputRun(out_dir, "predict", inputs=inputs, json_path=json_path) as run:
        table = _prediction_table(clf, source)
        members = clf.predict_table(table)
        by = group or ("source_member" if "source_member" in table.columns else None)
        if by is not None and by not in table.columns:
            raise DataError(f"--group {by!r} is not a column of the members' table")
        run.add_csv("predictions.csv", members, index_label="member")
        summary: dict[str, Any] = {
            "model_file": str(model_path),
            "label": clf.label,
            "n_members": len(members),
            "predicted": {
                str(k): int(v) for k, v in members["predicted"].value_counts().items()
            },
            "n_out_of_distribution": int(members["out_of_distribution"].sum()),
        }
        if by is not None:
            votes = vote_by_group(members, table[by])
            run.add_csv("recordings.csv", votes, index=False)
            summary["recordings"] = votes.to_dict("records")
        say(
            f"{len(members)} members: "
            + ", ".join(f"{k} {v}" for k, v in summary["predicted"].items())
            + f"; {summary['n_out_of_distribution']} out of distribution"
        )
        report = Report("pdmkit predict")
        report.add_text(
            f"{len(members)} members scored with {model_path} (predicts {clf.label!r})."
        )
        if by is not None:
            report.add_table(votes, caption="Per recording: the majority vote")
        report.add_table(members.head(200), caption="Per member (first 200)")
        finish(run, summary, report)
    return summary


def _prediction_table(clf, source: TableSource) -> pd.DataFrame:
    """The members' indicators: read, or computed with the model's recipe."""
    if source.features is not None:
        table, *_ = feature_table(source)
        if "member" in table.columns and table["member"].is_unique:
            table = table.set_index("member")  # the ids a CSV table keeps as a column
        return table
    recipe = {
        k: v for k, v in clf.recipe.items() if k not in ("input", "dataset", "rates_hz")
    }
    known = {f.name for f in dataclasses.fields(TableSource)}
    unknown = sorted(set(recipe) - known)
    if unknown:
        raise ModelError(
            f"the model's recipe names options this pdmkit does not know: {unknown}; "
            "it was saved by another version"
        )
    mine = {
        k: getattr(source, k)
        for k in ("label_from_name", "labels", "quiet")
        if getattr(source, k) not in (None, False)
    }
    given = {**recipe, **mine, "members": source.members}
    table, *_ = feature_table(TableSource(**given))
    _check_rates(clf.recipe.get("rates_hz"), table.attrs.get("fs"), source.members)
    return table


def _check_rates(trained: dict | None, new: dict | None, members) -> None:
    """New members read at the rates the classifier's indicators were computed at."""
    if not trained or not new:
        return
    for signal, rate in trained.items():
        got = new.get(signal)
        if got is not None and abs(got - rate) > 1e-6 * rate:
            raise DataError(
                f"the --members files give signal {signal!r} at {got:g} Hz; the "
                f"classifier's indicators were computed at {rate:g} Hz. Pass --fs or a "
                "labels table with each file's fs, or train with --resample HZ so that "
                "predict resamples too"
            )
