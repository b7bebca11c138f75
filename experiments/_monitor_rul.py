"""An RUL model attached to the health history: each unit's RUL after every scored file.

``pdmkit monitor score --rul MODEL`` (and ``watch --rul``) hands the RUL model each
touched unit's whole history so far, the rows already in the database and the new
ones, as a table with the columns ``unit``, ``time`` (the time as the user's table
wrote it: numbers, or timestamps that :func:`pdmkit.rul.timestamps_to_seconds` reads),
``score`` and ``health_index``, exactly what :func:`history_table` exports. So the
model is one trained by ``pdmkit rul`` on such an export of run-to-failure units (a
degradation model of ``health_index``, decreasing, or of ``score``, increasing): the
health model fuses the indicators into one health indicator, the RUL model
extrapolates it (the standard predictive-maintenance workflow). The answer at the
unit's last row (``rul``, ``lower``, ``upper``, ``level``, ``note``) is recorded in the
same transaction as the rows.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd

from pdmkit._atomic import atomic_path
from pdmkit._checks import file_sha256
from pdmkit._persist import load_model
from pdmkit.errors import DataError, ModelError
from pdmkit.experiments._monitor_history import HealthHistory
from pdmkit.experiments._rul import _predict_rul

__all__ = ["RULAttachment", "export_history", "history_table"]


def _table_times(text: pd.Series) -> pd.Series:
    """The time as the user's table wrote it: numbers where all are numbers."""
    numbers = pd.to_numeric(text, errors="coerce")
    return numbers.astype(float) if numbers.notna().all() else text.astype(str)


def history_table(frame: pd.DataFrame) -> pd.DataFrame:
    """A health history as a table to train (or run) an RUL model on.

    Parameters
    ----------
    frame : pandas.DataFrame
        ``HealthHistory.history()`` (or scored rows with ``time_text``).

    Returns
    -------
    pandas.DataFrame
        ``unit``, ``time`` (the table's own time: numbers, or timestamp text),
        ``score``, ``health_index``; per unit in time order.

    Examples
    --------
    >>> import pandas as pd
    >>> h = pd.DataFrame({"unit": ["a", "a"], "time": [3.0, 4.0],
    ...     "time_text": ["3", "4"], "score": [0.5, 2.0], "health_index": [0.8, 0.4]})
    >>> history_table(h).to_dict("list")["time"]
    [3.0, 4.0]
    """
    out = pd.DataFrame(
        {
            "unit": frame["unit"].astype(str).to_numpy(),
            "time": _table_times(frame["time_text"]).to_numpy(),
            "score": frame["score"].to_numpy(dtype=float),
            "health_index": frame["health_index"].to_numpy(dtype=float),
            "_order": frame["time"].to_numpy(dtype=float),
        }
    )
    out = out.sort_values(["unit", "_order"], kind="stable")
    return out.drop(columns="_order").reset_index(drop=True)


class RULAttachment:
    """An RUL model file, checked once, asked after every scored file.

    Parameters
    ----------
    model_file : path
        ``model.pdmkit`` written by ``pdmkit rul`` (trained on
        :func:`history_table` columns).

    Raises
    ------
    pdmkit.errors.ModelError
        The file is not a pdmkit RUL model (before anything is scored).
    """

    def __init__(self, model_file: str | os.PathLike) -> None:
        self.model_file = Path(model_file)
        self.sha256 = file_sha256(self.model_file)
        # loaded once: every scored file asks the same model (its hash checked here)
        self.model = model = load_model(self.model_file, expect_sha256=self.sha256)
        if not hasattr(model, "predict_trajectory"):
            raise ModelError(
                f"--rul {model_file}: holds a {type(model).__name__}, not an RUL model; "
                "train one with `pdmkit rul --train HISTORY.csv ... --out DIR`"
            )
        self.time_unit: str | None = None

    def after(self, past: pd.DataFrame, rows: pd.DataFrame) -> pd.DataFrame:
        """Each unit's RUL at its last row, given its past rows and the new ones.

        Parameters
        ----------
        past : pandas.DataFrame
            The units' rows already in the history (``HealthHistory.history()``).
        rows : pandas.DataFrame
            The new scored rows (``unit``, ``time``, ``time_text``, ``score``,
            ``health_index``).

        Returns
        -------
        pandas.DataFrame
            One row per unit of ``rows``: ``unit``, ``time``, ``time_text`` (its last
            row's), ``rul``, ``lower``, ``upper``, ``level``, ``note``.
        """
        keep = ["unit", "time", "time_text", "score", "health_index"]
        both = pd.concat([past[keep], rows[keep]], ignore_index=True)
        answer = _predict_rul(
            self.model_file,
            history_table(both),
            unit="unit",
            time="time",
            pipeline=self.model,
        )
        self.time_unit = answer["time_unit"]
        last = both.sort_values("time", kind="stable").groupby("unit").tail(1)
        last = last.set_index(last["unit"].astype(str))
        out = []
        for record in answer["units"]:
            unit = str(record["unit"])
            out.append(
                {
                    "unit": unit,
                    "time": float(last.loc[unit, "time"]),
                    "time_text": str(last.loc[unit, "time_text"]),
                    **{k: _number(record.get(k)) for k in ("rul", "lower", "upper")},
                    "level": float(answer["level"]),
                    "note": str(record.get("note") or ""),
                }
            )
        return pd.DataFrame(out)


def _number(value) -> float:
    return np.nan if value is None else float(value)


def export_history(db: str | os.PathLike, csv_path: str | os.PathLike) -> int:
    """Write a health history as :func:`history_table` CSV (to train an RUL model on).

    The history is only read. ``csv_path`` must not exist yet (nothing of the user's
    is overwritten); it appears whole or not at all. Returns the number of rows.

    Examples
    --------
    >>> import pathlib, tempfile, pandas as pd
    >>> from pdmkit.experiments._monitor_history import HealthHistory
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> rows = pd.DataFrame({"unit": "p", "time": [1.0, 2.0], "member": ["a", "b"],
    ...     "score": [0.1, 0.4], "health_index": [0.9, 0.7], "exceeds": False})
    >>> with HealthHistory(d / "h.sqlite") as h:
    ...     _ = h.record(rows, persistence=2)
    >>> export_history(d / "h.sqlite", d / "history.csv")
    2
    >>> pd.read_csv(d / "history.csv").columns.tolist()
    ['unit', 'time', 'score', 'health_index']
    """
    target = Path(csv_path)
    if target.exists():
        raise DataError(f"--csv {target} exists; remove it or name another file")
    if not target.parent.is_dir():
        raise DataError(f"--csv {target}: the folder {target.parent} does not exist")
    with HealthHistory(db, read_only=True) as history:
        table = history_table(history.history())
    with atomic_path(target) as tmp:
        table.to_csv(tmp, index=False)
    return len(table)
