"""``pdmkit monitor``: health baselines from healthy rows, new rows scored into a history.

``fit`` learns a :class:`~pdmkit.models.diagnosis.HealthModel` from the rows the user
marks healthy (the first part of each unit's life, or an expression) and saves it;
``score`` judges a feature table against it and adds the rows to each unit's history
(:class:`~pdmkit.experiments._monitor_history.HealthHistory`, SQLite); ``watch`` does
the same for every new table that lands in a folder, each file once.
"""

from __future__ import annotations

import os
import time as _time
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pdmkit._checks import file_sha256, time_as_seconds
from pdmkit._outputs import OutputRun
from pdmkit._persist import load_model, save_model
from pdmkit.ensembles import read_table
from pdmkit.errors import DataError, ModelError
from pdmkit.experiments._messages import finish, say
from pdmkit.experiments._monitor_history import HealthHistory
from pdmkit.experiments._monitor_report import (
    alarm_table,
    plot_health_history,
    plot_rul_history,
)
from pdmkit.experiments._monitor_rul import RULAttachment
from pdmkit.experiments._report import Report
from pdmkit.models.diagnosis import HealthModel, calibration_split

__all__ = ["false_alarm_spec", "run_monitor_fit", "run_monitor_score", "watch_folder"]

PathLike = str | os.PathLike
#: indicators named in the history per row (the largest contributions)
TOP_INDICATORS = 3


def _read(path: PathLike, unit: str | None, time: str) -> pd.DataFrame:
    table = read_table(path)
    for flag, col in (("--unit", unit), ("--time", time)):
        if col is not None and col not in table.columns:
            raise DataError(
                f"{path}: {flag} {col!r} is not a column; columns: "
                f"{[str(c) for c in table.columns][:12]}"
            )
    return table


def _time_values(table: pd.DataFrame, time: str, where: str) -> np.ndarray:
    """The time column as numbers (seconds since 1970 for timestamps)."""
    values, unread = time_as_seconds(table[time])
    if unread is not None:
        raise DataError(
            f"{where}: --time {time!r} holds {str(unread)!r}, neither a number nor a "
            "timestamp"
        )
    if not np.isfinite(values).all():
        raise DataError(f"{where}: --time {time!r} is missing on some rows")
    return values


def _feature_columns(table: pd.DataFrame, exclude: set) -> list[str]:
    """Indicator columns (``signal/group/F``), else every numeric column but unit/time."""
    named = [str(c) for c in table.columns if "/" in str(c)]
    if named:
        return named
    return [
        str(c)
        for c in table.columns
        if str(c) not in exclude
        and pd.api.types.is_numeric_dtype(table[c])
        and not pd.api.types.is_bool_dtype(table[c])
    ]


def _healthy_rows(table, units, t, healthy_first, healthy_where) -> np.ndarray:
    if (healthy_first is None) == (healthy_where is None):
        raise DataError("give one of --healthy-first FRACTION or --healthy-where EXPR")
    if healthy_where is not None:
        try:
            mask = np.asarray(table.eval(healthy_where, engine="python"), dtype=bool)
        except Exception as exc:
            raise DataError(
                f"--healthy-where {healthy_where!r} cannot be evaluated: {exc}"
            ) from None
        return mask
    if not 0 < healthy_first < 1:
        raise DataError(f"--healthy-first must be in (0, 1); got {healthy_first}")
    mask = np.zeros(len(table), dtype=bool)
    for u in pd.unique(units):
        rows = np.flatnonzero(units == u)
        start, end = t[rows].min(), t[rows].max()
        mask[rows] = t[rows] <= start + healthy_first * (end - start)
    return mask


_PER = {"s": 1.0, "min": 60.0, "h": 3600.0, "d": 86400.0, "w": 604800.0}


def false_alarm_spec(spec: str | float) -> tuple[float | None, float | None]:
    """``--false-alarms``: a rate per row (``0.01``) or per time (``1/30d``).

    Returns ``(per_row, per_second)``, one of them None. Time units: ``s``, ``min``,
    ``h``, ``d``, ``w``.

    Examples
    --------
    >>> false_alarm_spec("0.01")
    (0.01, None)
    >>> false_alarm_spec("1/30d")[1] * 86400 * 30
    1.0
    """
    text = str(spec).strip().replace(" ", "")
    if "/" not in text:
        try:
            rate = float(text)
        except ValueError:
            rate = np.nan
        if not 0 < rate < 1:
            raise DataError(
                f"--false-alarms {spec!r}: expected a rate per row in (0, 1) such as "
                "0.01, or a rate per time such as 1/30d"
            )
        return rate, None
    count, _, span = text.partition("/")
    unit = span.lstrip("0123456789.")
    number = span[: len(span) - len(unit)] or "1"
    try:
        per_second = float(count) / (float(number) * _PER[unit])
    except (ValueError, KeyError, ZeroDivisionError):
        per_second = np.nan
    if not np.isfinite(per_second) or per_second <= 0:
        raise DataError(
            f"--false-alarms {spec!r}: expected COUNT/SPAN such as 1/30d (units: "
            f"{', '.join(_PER)})"
        )
    return None, per_second


def _per_row_rate(spec, table, time, t, units, healthy) -> tuple[float, dict]:
    """The per-row false-alarm rate for ``spec``, and what it was derived from."""
    per_row, per_second = false_alarm_spec(spec)
    if per_row is not None:
        return per_row, {}
    column = table[time]
    if pd.api.types.is_numeric_dtype(column):
        raise DataError(
            f"--false-alarms {spec}: a rate per time needs timestamps in --time "
            f"{time!r}, which holds numbers of unknown unit; give a rate per row"
        )
    steps = np.concatenate(
        [np.diff(t[healthy & (units == u)]) for u in pd.unique(units[healthy])]
    )
    step = float(np.median(steps)) if steps.size else np.nan
    if not step > 0:
        raise DataError(f"--false-alarms {spec}: the healthy rows have no time step")
    rate = per_second * step
    if not rate < 1:
        raise DataError(
            f"--false-alarms {spec}: one row every {step:g} s already exceeds that rate"
        )
    return rate, {"false_alarms": str(spec), "row_step_s": step}


def run_monitor_fit(
    features: PathLike,
    *,
    out_dir: PathLike,
    unit: str | None = None,
    time: str,
    healthy_first: float | None = None,
    healthy_where: str | None = None,
    method: str = "pca",
    false_alarm_rate: float | str = 0.01,
    persistence: int = 3,
    json_path: PathLike | None = None,
) -> dict:
    """Fit a health baseline on the healthy rows of a feature table and save it.

    Parameters
    ----------
    features : path
        A feature table: one row per recording, a unit column, a time column.
    out_dir : path
        Receives ``model.pdmkit``, ``summary.json`` and ``report.html``.
    unit, time : str
        The columns naming each row's asset and its time (numbers or timestamps).
    healthy_first : float, optional
        The first fraction of each unit's time span is healthy.
    healthy_where : str, optional
        A pandas expression marking the healthy rows instead.
    false_alarm_rate : float or str
        Per row (``0.01``) or per time (``"1/30d"``, with timestamps in ``time``:
        converted with the healthy rows' median time step; at most one false alarm
        per row is then certified, so the rate per time holds before persistence).
    method, persistence
        See :class:`~pdmkit.models.diagnosis.HealthModel`.
    json_path : path, optional
        Also write the summary here.

    Returns
    -------
    dict
        ``threshold``, ``n_healthy``, ``features``, ``method``, ``model_file``.

    Examples
    --------
    >>> import tempfile, numpy as np, pandas as pd
    >>> rng = np.random.default_rng(0)
    >>> t = np.tile(np.arange(300.0), 2)
    >>> table = pd.DataFrame({"unit": np.repeat(["a", "b"], 300), "t": t,
    ...     "v/stats/RMS": rng.normal(size=600) + (t > 250) * 8,
    ...     "v/stats/Kurtosis": rng.normal(size=600)})
    >>> d = tempfile.mkdtemp()
    >>> table.to_csv(f"{d}/f.csv", index=False)
    >>> s = run_monitor_fit(f"{d}/f.csv", out_dir=f"{d}/m", unit="unit", time="t",
    ...                     healthy_first=0.5, false_alarm_rate=0.05)
    >>> s["n_healthy"], s["features"]
    (300, ['v/stats/RMS', 'v/stats/Kurtosis'])
    """
    table = _read(features, unit, time)
    t = _time_values(table, time, str(features))
    units = (
        table[unit].astype(str).to_numpy(dtype=object)
        if unit
        else np.full(len(table), "unit")
    )
    order = np.lexsort((t, units))
    table, t, units = table.iloc[order], t[order], units[order]
    healthy = _healthy_rows(table, units, t, healthy_first, healthy_where)
    cols = _feature_columns(table, {unit, time})
    if not cols:
        raise DataError(f"{features}: no numeric indicator columns to monitor")
    alpha, derived = _per_row_rate(false_alarm_rate, table, time, t, units, healthy)
    model = HealthModel(method=method, false_alarm_rate=alpha, persistence=persistence)
    try:
        model.fit(table.loc[healthy, cols], groups=units[healthy])
    except DataError:
        if not derived:
            raise
        step = derived["row_step_s"]
        n_cal = calibration_split(
            int(healthy.sum()), model.calibration_fraction, units[healthy]
        )[1].size
        raise DataError(
            f"--false-alarms {false_alarm_rate} is {alpha:.3g} per row at one row every "
            f"{step:g} s, and {n_cal} healthy calibration rows can certify at most "
            f"1/{(n_cal + 1) * step / 3600:.3g}h; mark more rows healthy or ask for a "
            "larger rate"
        ) from None
    inputs = [features]
    with OutputRun(out_dir, "monitor", inputs=inputs, json_path=json_path) as run:
        run.add_file("model.pdmkit", lambda p: save_model(model, p))
        summary = {
            "method": method,
            "threshold": float(model.threshold_),
            "false_alarm_rate": float(alpha),
            **derived,
            "persistence": int(persistence),
            "n_healthy": int(healthy.sum()),
            "n_units": len(pd.unique(units)),
            "features": cols,
            "unit": unit,
            "time": time,
            "model_file": str(run.path("model.pdmkit")),
        }
        per_time = ""
        if derived:
            per_time = f" ({false_alarm_rate} at one row per {derived['row_step_s']:g} s)"
        say(
            f"health baseline ({method}) on {summary['n_healthy']} healthy rows of "
            f"{summary['n_units']} unit(s): threshold {summary['threshold']:.4g} for a "
            f"{alpha:.3g} false-alarm rate per row{per_time}"
        )
        report = Report("pdmkit monitor fit")
        report.add_text(
            f"Baseline {method} on {summary['n_healthy']} healthy rows; alarm threshold "
            f"{summary['threshold']:.4g} (split conformal, {alpha:.3g} per row), "
            f"{persistence} consecutive rows above it raise the alarm."
        )
        finish(run, summary, report)
    return summary


def _load_health_model(path: PathLike):

    model = load_model(path)
    if not isinstance(model, HealthModel):
        raise ModelError(
            f"{path} holds a {type(model).__name__}, not a health model saved by "
            "pdmkit monitor fit"
        )
    return model


def score_file(model, path: PathLike, history, *, unit: str | None, time: str, rul=None):
    """Score one feature table into ``history`` (None when it was scored before).

    ``rul`` (a :class:`~pdmkit.experiments._monitor_rul.RULAttachment`) adds each
    touched unit's RUL after these rows, in the same transaction.
    """
    sha = file_sha256(Path(path))
    if history.seen(sha):
        return None
    table = _read(path, unit, time)
    t = _time_values(table, time, str(path))
    units = table[unit].astype(str) if unit else pd.Series("unit", index=table.index)
    assessed = model.assess(table[list(model.feature_names_in_)])
    contrib = model.contributions(table[list(model.feature_names_in_)])
    C = np.nan_to_num(contrib.to_numpy(dtype=float), nan=-np.inf)  # NaN ranks last
    names = np.asarray(contrib.columns, dtype=object)
    best = np.argsort(-C, axis=1, kind="stable")[:, :TOP_INDICATORS]
    tops = [list(names[b]) for b in best]  # the largest contributions, per row
    rows = pd.DataFrame(
        {
            "unit": units.to_numpy(),
            "time": t,
            "time_text": table[time].astype(str).to_numpy(),
            "member": [str(m) for m in table.index],
            "score": assessed["score"].to_numpy(),
            "health_index": assessed["health_index"].to_numpy(),
            "exceeds": assessed["above_threshold"].to_numpy(),
        }
    )
    answers = None
    if rul is not None:
        past = pd.concat([history.history(u) for u in pd.unique(rows["unit"])])
        answers = rul.after(past, rows)
    return history.record(
        rows,
        persistence=int(model.persistence),
        source=(sha, str(path)),
        top_indicators=tops,
        rul=answers,
    )


def _rul_words(history, unit: str, rul) -> str:
    """``; RUL 30 h [20, 45]`` for an alarm line (empty without an RUL answer)."""
    ruls = history.rul_history(unit) if rul is not None else None
    if ruls is None or ruls.empty:
        return ""
    last = ruls.iloc[-1]
    lower, upper = ("open" if np.isnan(v) else f"{v:.3g}" for v in last[["lower", "upper"]])
    return f"; RUL {last['rul']:.3g} {rul.time_unit or ''} [{lower}, {upper}]"


def _units_summary(history, frame: pd.DataFrame, ruls: pd.DataFrame) -> dict:
    """Per unit its alarm and last state; ``frame`` and ``ruls`` as the history reads."""
    first = history.first_alarms(text=True)
    ruls = ruls.groupby("unit").tail(1).set_index("unit")
    out: dict[str, Any] = {}
    for u, part in frame.groupby("unit", sort=True):
        out[str(u)] = {
            "first_alarm": first.get(u),
            "n_rows": len(part),
            "last_time": part["time_text"].iloc[-1],
            "last_health_index": float(part["health_index"].iloc[-1]),
            "alarm": bool(part["alarm"].iloc[-1]),
        }
        if u in ruls.index:  # the last RUL answer (None for an open bound)
            last = ruls.loc[u]
            out[str(u)]["rul"] = {
                k: None if np.isnan(last[k]) else float(last[k])
                for k in ("rul", "lower", "upper", "level")
            } | {"time": str(last["time_text"]), "note": str(last["note"])}
    return out


def _score_report(frame: pd.DataFrame, summary: dict, ruls=None) -> Report:
    report = Report("pdmkit monitor score")
    n_alarm = sum(1 for v in summary["units"].values() if v["first_alarm"])
    report.add_summary_box(
        [
            ("Scored now", f"{summary['n_scored']} rows", None),
            (
                "In alarm",
                f"{n_alarm} of {len(summary['units'])} unit(s)",
                report.anchor("Alarms"),
            ),
            ("History", str(summary["db"]), None),
        ]
    )
    if frame.empty:
        report.add_text("The history holds no rows yet.")
        return report
    report.add_heading("Health over time")
    report.add_figure(
        plot_health_history(frame),
        caption="Health index per unit over its whole history (dashed: the alarm "
        "threshold, 0.5; red: in alarm from the first alarm on)",
    )
    report.add_heading("Alarms")
    report.add_table(
        alarm_table(frame), caption="Per unit: first alarm and the indicators that drove it"
    )
    if ruls is not None and len(ruls):
        level = float(ruls["level"].iloc[-1])
        report.add_heading("Remaining useful life")
        report.add_figure(
            plot_rul_history(ruls, time_unit=summary.get("rul_time_unit")),
            caption=f"Per unit: the attached RUL model's estimate after each scored "
            f"file, with its {level:.0%} interval (an open bound is drawn to the "
            "panel's edge)",
        )
    return report


def run_monitor_score(
    model_path: PathLike,
    features: PathLike,
    *,
    db: PathLike,
    out_dir: PathLike,
    unit: str | None = None,
    time: str,
    json_path: PathLike | None = None,
    rul_model: PathLike | None = None,
) -> dict:
    """Score a feature table against a saved health model; add it to the history.

    Parameters
    ----------
    model_path : path
        ``model.pdmkit`` from :func:`run_monitor_fit`.
    features : path
        The rows to judge (the model's indicator columns, matched by name).
    db : path or str
        The history: an SQLite file (created when missing) or a database URL
        (``postgresql+psycopg://...``, through SQLAlchemy: ``pip install
        'pdmkit[db]'``); a table already scored (same SHA-256) is not added again.
        A URL's password is never written to the summary or the log.
    out_dir : path
        Receives ``summary.json`` and ``report.html``.
    unit, time : str
        As for :func:`run_monitor_fit`.
    json_path : path, optional
        Also write the summary here.
    rul_model : path, optional
        An RUL model (``model.pdmkit`` of ``pdmkit rul``) trained on health
        histories (:func:`~pdmkit.experiments._monitor_rul.history_table`): each
        touched unit's RUL after these rows is added to the history.

    Returns
    -------
    dict
        ``units``: per unit ``first_alarm`` (the time as the table writes it, or
        None), ``n_rows``, ``last_health_index``, ``alarm`` and, with an RUL model
        in the history, ``rul`` (the last answer: ``rul``, ``lower``, ``upper``,
        ``level``, ``time``, ``note``); ``n_scored`` (0 when the file was scored
        before).

    Examples
    --------
    >>> import tempfile, numpy as np, pandas as pd
    >>> rng = np.random.default_rng(0)
    >>> t = np.tile(np.arange(300.0), 2)
    >>> table = pd.DataFrame({"unit": np.repeat(["a", "b"], 300), "t": t,
    ...     "v/stats/RMS": rng.normal(size=600) + (t > 250) * 8 * (np.arange(600) < 300),
    ...     "v/stats/Kurtosis": rng.normal(size=600)})
    >>> d = tempfile.mkdtemp()
    >>> table.to_csv(f"{d}/f.csv", index=False)
    >>> _ = run_monitor_fit(f"{d}/f.csv", out_dir=f"{d}/m", unit="unit", time="t",
    ...                     healthy_first=0.5, false_alarm_rate=0.05)
    >>> s = run_monitor_score(f"{d}/m/model.pdmkit", f"{d}/f.csv", db=f"{d}/h.sqlite",
    ...                       out_dir=f"{d}/s", unit="unit", time="t")
    >>> s["units"]["a"]["first_alarm"], s["units"]["b"]["first_alarm"]
    ('253.0', None)
    """
    model = _load_health_model(model_path)
    rul = None if rul_model is None else RULAttachment(rul_model)
    inputs = [model_path, features, db] + ([] if rul_model is None else [rul_model])
    with OutputRun(out_dir, "monitor-score", inputs=inputs, json_path=json_path) as run:
        with HealthHistory(db, model_sha256=file_sha256(Path(model_path))) as history:
            scored = score_file(model, features, history, unit=unit, time=time, rul=rul)
            history_frame = history.history()
            ruls = history.rul_history()
            units = _units_summary(history, history_frame, ruls)
            db_name = history.name  # a URL's password masked
        n = 0 if scored is None else len(scored)
        summary = {"model_file": str(model_path), "db": db_name, "n_scored": n}
        if rul is not None:
            summary["rul_model_file"] = str(rul_model)
            summary["rul_time_unit"] = rul.time_unit
        summary["units"] = units
        alarmed = {u: v["first_alarm"] for u, v in units.items() if v["first_alarm"]}
        say(
            f"{n} rows scored"
            + (" (file scored before)" if scored is None else "")
            + f"; {len(alarmed)} of {len(units)} unit(s) in alarm"
            + (": " + ", ".join(f"{u} since {t}" for u, t in alarmed.items()))
            * bool(alarmed)
        )
        finish(run, summary, _score_report(history_frame, summary, ruls))
    return summary


def watch_folder(
    model_path: PathLike,
    folder: PathLike,
    *,
    db: PathLike,
    unit: str | None = None,
    time: str,
    interval: float = 10.0,
    once: bool = False,
    pattern: str = "*.csv",
    rul_model: PathLike | None = None,
) -> int:
    """Score every new feature table that lands in ``folder``, each once.

    Polls every ``interval`` seconds (``once``: one pass, then return); a file is
    taken when its size has not changed since the previous pass (still being
    written otherwise). Each new alarm is logged as one line (with the unit's RUL
    when ``rul_model`` is attached, as in :func:`run_monitor_score`). Ctrl-C stops
    cleanly between files. Returns the number of files scored.

    Examples
    --------
    >>> import pathlib, tempfile, numpy as np, pandas as pd
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> rng = np.random.default_rng(1)
    >>> day = lambda k: pd.DataFrame({"unit": "pump", "t": k * 100 + np.arange(100.0),
    ...     "v/stats/RMS": rng.normal(size=100) + (k == 2) * 9,
    ...     "v/stats/Kurtosis": rng.normal(size=100)})
    >>> day(0).to_csv(d / "base.csv", index=False)
    >>> _ = run_monitor_fit(d / "base.csv", out_dir=d / "m", unit="unit", time="t",
    ...                     healthy_first=0.99, false_alarm_rate=0.05)
    >>> (d / "in").mkdir()
    >>> for k in (1, 2):
    ...     day(k).to_csv(d / "in" / f"day{k}.csv", index=False)
    >>> watch_folder(d / "m" / "model.pdmkit", d / "in", db=d / "h.sqlite",
    ...              unit="unit", time="t", once=True)
    2
    """
    if not 0.1 <= interval <= 3600:
        raise DataError(f"--interval must be 0.1 to 3600 seconds; got {interval}")
    model = _load_health_model(model_path)
    rul = None if rul_model is None else RULAttachment(rul_model)
    folder = Path(folder)
    if not folder.is_dir():
        raise DataError(f"{folder} is not a folder to watch")
    sizes: dict[Path, int] = {}
    done = 0
    with HealthHistory(db, model_sha256=file_sha256(Path(model_path))) as history:
        try:
            while True:
                for path in sorted(folder.glob(pattern)):
                    size = path.stat().st_size
                    if not once and sizes.get(path) != size:
                        sizes[path] = size  # seen growing: take it next pass
                        continue
                    before = history.first_alarms()
                    rows = score_file(model, path, history, unit=unit, time=time, rul=rul)
                    if rows is None:
                        continue
                    done += 1
                    for u, t in history.first_alarms(text=True).items():
                        if t is not None and before.get(u) is None:
                            tail = _rul_words(history, u, rul)
                            say(f"ALARM {u} since {t} ({path.name}){tail}")
                if once:
                    return done
                _time.sleep(interval)
        except KeyboardInterrupt:
            say(f"stopped; {done} file(s) scored into {history.name}")
    return done
