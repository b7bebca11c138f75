"""Compare sensors by the fault-classification accuracy their signals give and their cost.

Each sensor owns one or more signals; its condition indicators are the feature columns
``<signal>/...`` of those signals. A classifier is cross-validated on one sensor's
indicators at a time, over the members that have that sensor, and the sensors are set
against their cost (seed thesis, section 7.4 and table 9.1). The Pareto front holds the
sensors that no other sensor beats on both accuracy and cost.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator

from pdmkit._outputs import to_jsonable
from pdmkit._progress import progress as progress_bar_over
from pdmkit.errors import DataError
from pdmkit.experiments._classify import (
    ClassificationResult,
    _check_table,
    _cv_folds,
    _cv_scores,
    _feature_columns,
    _fit_to_size,
    _label_values,
    _model_name,
    _show,
    _smallest_fit_size,
    classify,
    make_classifier,
)
from pdmkit.experiments._classify_result import _sorted_plain
from pdmkit.experiments._classify_splits import _cv_groups, group_column
from pdmkit.experiments._sensor_costs import _resolve_costs

__all__ = ["SensorComparison", "compare_sensors"]

_COLUMNS = [
    "sensor",
    "signals",
    "accuracy",
    "accuracy_std",
    "heldout_accuracy",
    "cost",
    "n_members",
    "n_excluded",
    "n_classes",
    "n_features",
    "cv_folds",
    "features",
    "pareto",
    "note",
]


# --------------------------------------------------------------------------- Pareto
def _pareto_mask(accuracy: np.ndarray, cost: np.ndarray) -> np.ndarray:
    """True where no other point has accuracy >= and cost <= with one strict."""
    accuracy = np.asarray(accuracy, dtype=float)
    cost = np.asarray(cost, dtype=float)
    ok = np.isfinite(accuracy) & np.isfinite(cost)
    mask = np.zeros(len(accuracy), dtype=bool)
    for i in np.flatnonzero(ok):
        others = ok.copy()
        others[i] = False
        dominated = (
            others
            & (accuracy >= accuracy[i])
            & (cost <= cost[i])
            & ((accuracy > accuracy[i]) | (cost < cost[i]))
        )
        mask[i] = not dominated.any()
    return mask


# --------------------------------------------------------------------------- result
@dataclass(repr=False)
class SensorComparison:
    """Accuracy and cost of each sensor, with the Pareto front.

    Parameters
    ----------
    table : pandas.DataFrame
        One row per sensor, at least ``sensor``, ``accuracy`` and ``cost``; the other
        columns of :meth:`to_pandas` are filled in when absent, and ``pareto`` is
        (re)computed.
    results : dict, optional
        Sensor -> :class:`ClassificationResult` of the held-out evaluation.
    label, model : str, optional
        What was classified, and with which model.
    cost_unit : str, optional
        Currency / unit of the costs (axis label of :meth:`plot`).

    Examples
    --------
    Table 9.1 of the seed thesis (accuracy on the test set, cost in CZK):

    >>> import pandas as pd
    >>> t91 = pd.DataFrame({
    ...     "sensor": ["Acc", "Encoder", "Flow", "Mics", "Pressure", "Proximity", "Strain"],
    ...     "accuracy": [0.916, 0.961, 0.972, 0.958, 0.766, 0.805, 0.950],
    ...     "cost": [7000, 25000, 6000, 1500, 1000, 2000, 15000]})
    >>> SensorComparison(t91, cost_unit="CZK").pareto_front()["sensor"].tolist()
    ['Pressure', 'Mics', 'Flow']
    """

    table: pd.DataFrame
    results: dict[str, ClassificationResult] = field(default_factory=dict)
    label: str | None = None
    model: str | None = None
    cost_unit: str | None = None

    def __post_init__(self) -> None:
        table = pd.DataFrame(self.table).reset_index(drop=True)
        missing = [c for c in ("sensor", "accuracy", "cost") if c not in table.columns]
        if missing:
            raise DataError(
                f"a sensor comparison table needs columns 'sensor', 'accuracy', 'cost'; "
                f"missing {missing}"
            )
        defaults: dict[str, Any] = {
            "signals": "",
            "accuracy_std": math.nan,
            "heldout_accuracy": math.nan,
            "n_members": pd.NA,
            "n_excluded": 0,
            "n_classes": pd.NA,
            "n_features": pd.NA,
            "cv_folds": pd.NA,
            "features": "",
            "note": "",
        }
        for col, value in defaults.items():
            if col not in table.columns:
                table[col] = value
        table["accuracy"] = table["accuracy"].astype(float)
        table["cost"] = table["cost"].astype(float)
        # a sensor scored on fewer classes than the others answers an easier question:
        # it does not compete for the front
        n_classes = pd.to_numeric(table["n_classes"], errors="coerce").to_numpy(dtype=float)
        fewer = np.isfinite(n_classes) & (n_classes < np.nanmax(n_classes, initial=0.0))
        accuracy = np.where(fewer, np.nan, table["accuracy"].to_numpy())
        table["pareto"] = _pareto_mask(accuracy, table["cost"].to_numpy())
        table["note"] = table["note"].fillna("").astype(str)
        extra = [c for c in table.columns if c not in _COLUMNS]
        self.table = table[_COLUMNS + extra]

    def __repr__(self) -> str:
        rows = ", ".join(
            f"{r.sensor}: {r.accuracy:.3f} @ {r.cost:g}" for r in self.table.itertuples()
        )
        return f"SensorComparison({rows})"

    def to_pandas(self) -> pd.DataFrame:
        """One row per sensor.

        Returns
        -------
        pandas.DataFrame
            Columns ``sensor``, ``signals`` (joined with ``", "``), ``accuracy`` /
            ``accuracy_std`` (mean / std over the cross-validation folds),
            ``heldout_accuracy``, ``cost`` (NaN when unknown), ``n_members`` (members
            that have the sensor and were used), ``n_excluded``, ``n_classes``,
            ``n_features``, ``cv_folds``, ``features`` (the indicators the selector
            kept on the held-out fit, ``"; "``-joined), ``pareto`` (on the Pareto
            front) and ``note`` (``""`` when there is nothing to say).

        Examples
        --------
        >>> import pandas as pd
        >>> c = SensorComparison(pd.DataFrame({"sensor": ["a", "b"], "accuracy": [0.9, 0.8],
        ...                                    "cost": [1.0, 2.0]}))
        >>> c.to_pandas()[["sensor", "pareto"]].to_dict("list")
        {'sensor': ['a', 'b'], 'pareto': [True, False]}
        """
        return self.table.copy()

    def pareto_front(self) -> pd.DataFrame:
        """Sensors no other sensor beats on both accuracy (higher) and cost (lower).

        Sensors with an unknown cost or accuracy are never on the front, nor are
        sensors scored on fewer classes than the others (``n_classes``).

        Returns
        -------
        pandas.DataFrame
            The rows of :meth:`to_pandas` on the front, by increasing cost.

        Examples
        --------
        >>> import pandas as pd
        >>> c = SensorComparison(pd.DataFrame({"sensor": ["a", "b", "c"],
        ...     "accuracy": [0.7, 0.9, 0.8], "cost": [1.0, 5.0, 6.0]}))
        >>> c.pareto_front()["sensor"].tolist()
        ['a', 'b']
        """
        front = self.table[self.table["pareto"]]
        return front.sort_values(
            ["cost", "accuracy"], ascending=[True, False], kind="stable"
        )

    def summary(self) -> dict:
        """Plain-JSON summary (NaN written as ``None``).

        Returns
        -------
        dict
            ``{"label", "model", "cost_unit", "pareto_front": [names],
            "sensors": [{"sensor", "signals": [...], "accuracy", "accuracy_std",
            "heldout_accuracy", "cost", "n_members", "n_excluded", "n_classes",
            "n_features", "cv_folds", "features": [...], "pareto", "note"}, ...]}``.

        Examples
        --------
        >>> import json, math, pandas as pd
        >>> c = SensorComparison(pd.DataFrame({"sensor": ["a"], "accuracy": [0.9],
        ...                                    "cost": [math.nan]}))
        >>> s = c.summary()
        >>> s["sensors"][0]["cost"], s["pareto_front"]
        (None, [])
        >>> _ = json.dumps(s)
        """
        sensors = []
        for row in self.table.to_dict("records"):
            row = {k: (None if _is_missing(v) else v) for k, v in row.items()}
            row["signals"] = _split(row.get("signals"), ", ")
            row["features"] = _split(row.get("features"), "; ")
            row["pareto"] = bool(row["pareto"])
            sensors.append(row)
        return to_jsonable(
            {
                "label": self.label,
                "model": self.model,
                "cost_unit": self.cost_unit,
                "pareto_front": self.pareto_front()["sensor"].tolist(),
                "sensors": sensors,
            }
        )

    def plot(
        self, ax: Any = None, *, cost_unit: str | None = None, logx: bool | None = None
    ):
        """Scatter accuracy against cost, with error bars and the Pareto front as steps.

        The accuracy is the cross-validated mean (error bars: its std over the folds);
        a comparison run without cross-validation shows the held-out accuracy.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Where to draw; a new figure when omitted.
        cost_unit : str, optional
            Unit shown on the cost axis; default: :attr:`cost_unit`.
        logx : bool, optional
            Logarithmic cost axis; default: when the costs span more than a factor 10.

        Returns
        -------
        matplotlib.axes.Axes

        Examples
        --------
        >>> import matplotlib
        >>> matplotlib.use("Agg")
        >>> import pandas as pd
        >>> c = SensorComparison(pd.DataFrame({"sensor": ["a", "b"], "accuracy": [0.9, 0.8],
        ...                                    "cost": [1.0, 2.0]}))
        >>> ax = c.plot(cost_unit="EUR")
        >>> ax.get_xlabel()
        'sensor cost [EUR]'
        """
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(7.0, 4.5))
        t = self.table
        # without cross-validation the held-out accuracy is the one there is
        cv = bool(np.isfinite(t["accuracy"]).any())
        col = "accuracy" if cv else "heldout_accuracy"
        t = t.assign(shown=t[col].astype(float))
        known = t[np.isfinite(t["cost"]) & np.isfinite(t["shown"])]
        std = known["accuracy_std"].astype(float).fillna(0.0).to_numpy() if cv else None
        ax.errorbar(
            known["cost"],
            known["shown"],
            yerr=std,
            fmt="o",
            color="tab:blue",
            ecolor="0.55",
            capsize=3,
            label="sensor (CV mean ± std)" if cv else "sensor (held-out accuracy)",
        )
        for row in known.itertuples():
            ax.annotate(
                str(row.sensor),
                (row.cost, row.shown),
                xytext=(5, 5),
                textcoords="offset points",
                fontsize=9,
            )
        front = (
            self.pareto_front()
            if cv
            else known[_pareto_mask(known["shown"], known["cost"])]
            .assign(accuracy=lambda f: f["shown"])
            .sort_values(["cost", "accuracy"], ascending=[True, False], kind="stable")
        )
        if len(front):
            ax.step(
                front["cost"],
                front["accuracy"],
                where="post",
                color="tab:red",
                lw=1.5,
                label="Pareto front",
            )
            ax.plot(front["cost"], front["accuracy"], "o", mfc="none", mec="tab:red", ms=11)
        unknown = t.loc[~np.isfinite(t["cost"]), "sensor"].tolist()
        if unknown:
            ax.text(
                0.01,
                0.01,
                "no cost: " + ", ".join(map(str, unknown)),
                transform=ax.transAxes,
                fontsize=8,
                color="0.4",
            )
        costs = known["cost"].to_numpy()
        if logx is None:
            logx = len(costs) > 1 and costs.min() > 0 and costs.max() / costs.min() > 10
        if logx:
            ax.set_xscale("log")
        unit = cost_unit if cost_unit is not None else self.cost_unit
        ax.set_xlabel(f"sensor cost [{unit}]" if unit else "sensor cost")
        ax.set_ylabel("accuracy" if cv else "held-out accuracy")
        ax.set_title(f"Sensors: accuracy{f' ({self.model})' if self.model else ''} vs cost")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="lower right", fontsize=8)
        return ax


def _is_missing(value: Any) -> bool:
    return (
        value is None or value is pd.NA or (isinstance(value, float) and math.isnan(value))
    )


def _split(text: Any, sep: str) -> list[str]:
    if text is None or text == "":
        return []
    if isinstance(text, list | tuple):
        return [str(t) for t in text]
    return str(text).split(sep)


# --------------------------------------------------------------------------- workflow
def _sensor_columns(
    table: pd.DataFrame, sensor: str, signals: Sequence[str], feature_cols: list
) -> dict[str, list]:
    by_signal: dict[str, list] = {}
    for signal in signals:
        cols = [c for c in feature_cols if str(c).startswith(f"{signal}/")]
        if not cols:
            known = sorted(
                {str(c).split("/")[0] for c in feature_cols if str(c).count("/") >= 2}
            )
            raise DataError(
                f"sensor {sensor!r}: no feature columns start with '{signal}/'; signals "
                f"with features in the table: {known}. Fix the signal name in sensors=."
            )
        by_signal[signal] = cols
    return by_signal


def compare_sensors(
    table: pd.DataFrame,
    label: str,
    sensors: Mapping[str, Sequence[str]],
    costs: Mapping[str, float] | str | os.PathLike | None = None,
    *,
    model: str | BaseEstimator = "knn",
    top_k: int = 5,
    selection: str | None = "fisher",
    cv: int = 5,
    test_size: float = 0.25,
    random_state: int | None = 0,
    progress: bool | None = None,
    group: str | None = None,
) -> SensorComparison:
    """Classify faults with each sensor's indicators alone and set accuracy against cost.

    For each sensor, the members that have it are those whose features of every signal
    it owns are not all NaN; the others are excluded and counted (``n_excluded``). On
    the members kept, the pipeline of :func:`make_classifier` is scored by stratified
    k-fold cross-validation over all of them (``accuracy`` ± ``accuracy_std``:
    ``StratifiedKFold(cv, shuffle=True, random_state=random_state)``; grouped folds
    when the members have groups, see ``group``) and by one held-out split as in
    :func:`classify` (``heldout_accuracy``; whole recordings held out when grouped).

    Parameters
    ----------
    table : pandas.DataFrame
        Feature table, one row per member; feature columns ``<signal>/<group>/<F>``.
    label : str
        Condition column holding the class.
    sensors : mapping
        Sensor name -> the signals it owns (``{"Acc1": ["AccX", "AccY"]}``); a single
        string stands for one signal.
    costs : mapping, path or None
        Sensor -> cost; or the TOML file to read with :func:`load_sensor_costs`;
        default: pdmkit's shipped costs. A sensor without a cost gets NaN and a note.
    model, top_k, selection, test_size, random_state
        As for :func:`classify`.
    cv : int, default 5
        Folds; lowered (with a note) when a class has fewer members with the sensor.
    progress : bool, optional
        A progress bar over the sensors; default only when stderr is a terminal.
    group : str, optional
        The column naming each member's recording / session / unit (default
        ``source_member`` when the members are frames): a group's members stay on
        one side of every fold and split (a class recorded once: time blocks).

    Returns
    -------
    SensorComparison

    Raises
    ------
    DataError
        Label problems (as in :func:`classify`); a signal with no feature columns; a
        member whose features of a signal are NaN only in part (a broken extraction,
        not a missing sensor).

    Notes
    -----
    When a class has no member with a sensor (CWRU: the ``normal`` recordings have no
    ``BA`` channel), that sensor is scored on fewer classes; the note says which, since
    its accuracy is then not directly comparable with the others', and it is left off
    the Pareto front (it never had to tell those classes apart). A class left with a
    single member is dropped from that sensor's evaluation, with a note.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> rng = np.random.default_rng(3)
    >>> y = np.repeat(["normal", "inner", "outer"], 20)
    >>> table = pd.DataFrame({
    ...     "DE/stats/Kurtosis": rng.normal(size=60) + 6 * (y == "inner"),
    ...     "DE/stats/RMS": rng.normal(size=60) + 6 * (y == "outer"),
    ...     "FE/stats/Kurtosis": rng.normal(size=60),
    ...     "FE/stats/RMS": rng.normal(size=60),
    ...     "fault": y})
    >>> cmp = compare_sensors(table, "fault", {"DE": ["DE"], "FE": ["FE"]},
    ...                       {"DE": 100.0, "FE": 100.0}, top_k=2)
    >>> df = cmp.to_pandas().set_index("sensor")
    >>> bool(df.loc["DE", "accuracy"] > 0.9 > df.loc["FE", "accuracy"])
    True
    >>> cmp.pareto_front()["sensor"].tolist()
    ['DE']
    """
    y_full = _check_table(table, label)
    if not isinstance(sensors, Mapping) or not sensors:
        raise DataError(
            "sensors must be a non-empty mapping sensor name -> signals, e.g. "
            "{'DE': ['DE'], 'Acc1': ['AccX', 'AccY']}"
        )
    cost_map, cost_unit, cost_source = _resolve_costs(costs)
    task = _SensorTask(
        table, label, y_full, _feature_columns(table), cost_map, cost_source,
        model, top_k, selection, cv, test_size, random_state,
        group_column(table, group),
    )  # fmt: skip
    rows, results = [], {}
    bar = progress_bar_over(
        sensors.items(), desc="sensors", total=len(sensors), enable=progress
    )
    for sensor, signals in bar:
        row, result = _sensor_row(task, sensor, signals)
        rows.append(row)
        if result is not None:
            results[str(sensor)] = result
    return SensorComparison(
        pd.DataFrame(rows),
        results=results,
        label=label,
        model=_model_name(model),
        cost_unit=cost_unit,
    )


@dataclass(frozen=True)
class _SensorTask:
    """What every sensor is scored with: the table and its labels, the costs, the model."""

    table: pd.DataFrame
    label: str
    y: pd.Series
    feature_cols: list
    costs: Mapping[str, float]
    cost_source: str
    model: str | BaseEstimator
    top_k: int
    selection: str | None
    cv: int
    test_size: float
    random_state: int | None
    group: str | None = None


def _sensor_row(task: _SensorTask, sensor, signals) -> tuple[dict, Any]:
    """One sensor's row of the comparison, and its held-out result (None: not scored)."""
    if isinstance(signals, str):
        signals = [signals]
    signals = list(dict.fromkeys(str(s) for s in signals))
    if not signals:
        raise DataError(f"sensor {sensor!r} owns no signals; list at least one")
    notes: list[str] = []
    by_signal = _sensor_columns(task.table, sensor, signals, task.feature_cols)
    cols = list(dict.fromkeys(c for cs in by_signal.values() for c in cs))
    y, n_excluded = _sensor_members(task, sensor, by_signal, notes)
    if task.costs.get(sensor) is None:
        cost = math.nan
        notes.append(f"no cost for sensor {sensor!r} in {task.cost_source}")
    else:
        cost = float(task.costs[sensor])
    row = {
        "sensor": str(sensor),
        "signals": ", ".join(signals),
        "accuracy": math.nan,
        "accuracy_std": math.nan,
        "heldout_accuracy": math.nan,
        "cost": cost,
        "n_members": len(y),
        "n_excluded": n_excluded,
        "n_classes": int(y.nunique()),
        "n_features": len(cols),
        "cv_folds": 0,
        "features": "",
    }
    if y.nunique() < 2:
        notes.append("fewer than 2 classes among the members with this sensor: not scored")
        row["note"] = "; ".join(notes)
        return row, None
    result = _score_sensor(task, row, y, cols, notes)
    row["note"] = "; ".join(dict.fromkeys(notes))
    return row, result


def _sensor_members(task: _SensorTask, sensor, by_signal: dict, notes: list[str]):
    """The labels of the members that have the sensor, and how many do not.

    A member has a sensor when its features of every signal the sensor owns are not all
    NaN; classes left with a single member are dropped. The notes say what was left out.
    """
    table = task.table
    present = np.ones(len(table), dtype=bool)
    for signal, scols in by_signal.items():
        values = table[scols].to_numpy(dtype=float)
        finite = np.isfinite(values)
        absent = np.isnan(values).all(axis=1)
        partial = ~finite.all(axis=1) & ~absent
        if partial.any():
            bad_cols = [scols[j] for j in np.flatnonzero((~finite[partial]).any(axis=0))]
            raise DataError(
                f"sensor {sensor!r}, signal {signal!r}: features are NaN or infinite "
                f"for members {_show(table.index[partial])} in columns "
                f"{_show(bad_cols)}, while their other features of that signal are "
                "finite. A missing sensor shows as all-NaN features; fix the "
                "extraction or drop those columns."
            )
        present &= ~absent
    n_excluded = int((~present).sum())
    if n_excluded:
        notes.append(f"{n_excluded} member(s) without this sensor excluded")
    y = task.y[present]
    lonely = [c for c, n in y.value_counts().items() if n < 2]
    if lonely:
        notes.append(
            f"class(es) {_show(lonely)} have a single member with this sensor and were "
            "left out"
        )
        y = y[~y.isin(lonely)]
    all_classes = set(task.y.unique())
    missing_classes = _sorted_plain(all_classes - set(y.unique()))
    if missing_classes:
        notes.append(
            f"classes {_show(missing_classes)} have no (usable) member with this "
            f"sensor: scored on {y.nunique()} of {len(all_classes)} classes, not "
            "directly comparable with sensors that see all classes, and left off "
            "the Pareto front"
        )
    return y, n_excluded


def _score_sensor(task: _SensorTask, row: dict, y: pd.Series, cols: list, notes: list):
    """Cross-validate and hold out on the sensor's members; fill in ``row``.

    Returns the held-out :class:`ClassificationResult`, or None when it failed (noted).
    """
    used = task.table.loc[y.index]
    X = used[cols].to_numpy(dtype=float)
    folds = _cv_folds(y, task.cv, notes, "members with this sensor")
    pipe = make_classifier(
        task.model,
        top_k=task.top_k,
        selection=task.selection,
        random_state=task.random_state,
    )
    _fit_to_size(pipe, len(cols), _smallest_fit_size(y, folds), notes, task.top_k)
    groups = None
    if task.group is not None:
        g = used[task.group].astype(str).to_numpy(dtype=object)
        groups = _cv_groups(used, y, g, np.arange(len(y)), [], folds)
    if folds:
        scores = _cv_scores(
            pipe,
            X,
            _label_values(y, notes),
            folds,
            task.random_state,
            progress=False,
            groups=groups,
        )
        row["accuracy"] = float(scores.mean())
        row["accuracy_std"] = float(scores.std())
        row["cv_folds"] = folds
    try:
        res = classify(
            used,
            task.label,
            features=cols,
            model=task.model,
            top_k=task.top_k,
            selection=task.selection,
            test_size=task.test_size,
            cv=None,
            random_state=task.random_state,
            group=task.group,
        )
    except DataError as exc:
        notes.append(f"no held-out score: {exc}")
        return None
    row["heldout_accuracy"] = res.accuracy
    row["features"] = "; ".join(res.features)
    notes.extend(n for n in res.notes if n not in notes)
    return res
