"""The files of ``pdmkit rul --trained MODEL --history TABLE --out DIR``.

A trained model's answers, written like every command's results (:mod:`pdmkit._outputs`):
``predictions.csv`` (one row per unit: the unit, its last time, the predicted RUL and the
interval's bounds, with the interval's level, what the interval means where it is not
plain, and how far the history lies from the training rows), ``summary.json`` (the
answer of :func:`pdmkit.experiments._rul.predict_rul`, with the model file's SHA-256)
and ``report.html``.
"""

from __future__ import annotations

from typing import Any

import pandas as pd

from pdmkit._checks import file_sha256
from pdmkit.experiments._report import Report
from pdmkit.rul import RULPrediction

__all__ = ["answer_table", "register_answer"]

#: Columns of ``predictions.csv`` after the unit and its time column.
ANSWER_COLUMNS = ("rul", "lower", "upper", "level", "note", "ood_score")


def answer_table(answer: dict[str, Any]) -> pd.DataFrame:
    """``predictions.csv`` of an answer: one row per unit.

    The time column keeps the model's name for it (``cycle``, ``time``).

    Examples
    --------
    >>> from pdmkit.experiments._rul_trained import answer_table
    >>> answer = {"level": 0.9, "time_column": "cycle", "units": [
    ...     {"unit": 7, "time": 31.0, "rul": 12.5, "lower": 8.0, "upper": 20.0,
    ...      "note": "", "text": "..."}]}
    >>> answer_table(answer).columns.tolist()
    ['unit', 'cycle', 'rul', 'lower', 'upper', 'level', 'note']
    """
    rows = pd.DataFrame(answer["units"])
    rows["level"] = float(answer["level"])
    keep = ["unit", "time", *[c for c in ANSWER_COLUMNS if c in rows.columns]]
    return rows[keep].rename(columns={"time": answer.get("time_column") or "time"})


def register_answer(run, answer: dict[str, Any], model_file) -> None:
    """Register the answer's three files with the output run (written at its commit)."""
    table = answer_table(answer)
    answer["model_sha256"] = file_sha256(model_file)
    answer["n_units"] = len(table)
    answer["paths"] = {
        name: str(run.path(f))
        for name, f in (
            ("predictions", "predictions.csv"),
            ("json", "summary.json"),
            ("report", "report.html"),
        )
    }
    run.add_csv("predictions.csv", table, index=False)
    run.add_report("report.html", _report(answer, table))
    run.add_json("summary.json", answer)


def _report(answer: dict[str, Any], table: pd.DataFrame) -> Report:
    """The answer in words, its warnings, the table and a plot of the intervals."""
    u, level = answer["time_unit"], float(answer["level"])
    cap = answer.get("rul_cap")
    report = Report(f"pdmkit rul: RUL answered by {answer['model_file']}")
    report.add_text(
        f"Model file {answer['model_file']} (SHA-256 {answer['model_sha256']}), "
        f"{answer['model']}. The RUL of each of the {len(table)} unit(s) at its last "
        f"row, in {u}, with its {100 * level:g} % interval"
        + (f"; RULs capped at {cap:g} {u} as the model was trained." if cap else ".")
    )
    if answer.get("warnings"):
        report.add_heading("Warnings")
        for message in answer["warnings"]:
            report.add_text(message)
    report.add_table(table, caption="Predicted RUL per unit (predictions.csv)")
    rows = pd.DataFrame(answer["units"])
    answered = rows["rul"].notna().to_numpy()
    if answered.any():
        part = rows[answered]
        prediction = RULPrediction(
            part["unit"].astype(str), part["time"], part["rul"], part["lower"],
            part["upper"], level=level, time_unit=u,
        )  # fmt: skip
        report.add_figure(
            prediction.plot(), caption=f"Predicted RUL per unit with its interval ({u})"
        )
    return report
