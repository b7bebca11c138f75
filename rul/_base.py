"""Shared plumbing of the RUL estimators: run-to-failure tables split into units.

A run-to-failure table is a long :class:`pandas.DataFrame` with one row per unit and
time: a ``unit`` column telling the units apart, a ``time`` column (``"time"`` or
``"cycle"`` when not named) ordering each unit's rows, indicator columns and an
optional ``failed`` column (``False`` for units taken out of service before they
failed, i.e. right-censored lifetimes). Units are kept in order of first appearance.
"""

from __future__ import annotations

import abc
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
import pandas as pd

from pdmkit._checks import check_columns_present, check_int, parse_timestamps
from pdmkit.errors import DataError, NotFittedError
from pdmkit.rul._result import RULPrediction

if TYPE_CHECKING:
    from typing import Self

# columns that are labels, never indicators
LABEL_COLUMNS = ("rul", "rul_true_final", "failed")


class RULModel(Protocol):
    """What the wrappers (pipeline, conformal calibration) ask of a RUL model.

    Every pdmkit RUL estimator has these methods.
    """

    def fit(self, table: pd.DataFrame, y: object = None) -> Any:
        """Fit on a long run-to-failure table; return the model."""

    def predict(self, table: pd.DataFrame) -> RULPrediction:
        """The RUL of each unit at its last time."""

    def predict_trajectory(self, table: pd.DataFrame, **kwargs: Any) -> RULPrediction:
        """The RUL at every point of each unit's history."""


@dataclass
class Unit:
    """One unit's history: its id, times (1-D, increasing) and values ``(n, p)``."""

    name: object
    t: np.ndarray
    x: np.ndarray
    failed: bool = True

    def __len__(self) -> int:
        return len(self.t)

    def head(self, n: int) -> Unit:
        """The first ``n`` samples (a history cut at its ``n``-th sample)."""
        return Unit(self.name, self.t[:n], self.x[:n], self.failed)


def check_table(table: object, what: str = "table") -> pd.DataFrame:
    if not isinstance(table, pd.DataFrame):
        raise DataError(
            f"{what} must be a pandas DataFrame in long form (one row per unit and time), "
            f"got {type(table).__name__}"
        )
    if len(table) == 0:
        raise DataError(f"{what} has 0 rows; pass at least one unit's history")
    return table


def timestamps_to_seconds(
    table: pd.DataFrame, time: str | None = None
) -> tuple[pd.DataFrame, str | None]:
    """Turn a time column of timestamps into seconds since the earliest one.

    Recordings from loggers carry wall-clock stamps (``2004-03-04 09:27:46``); the RUL
    models count time in numbers. A column of datetimes, or of text that reads as
    timestamps throughout, becomes float seconds since its earliest stamp; a numeric
    column is left as it is.

    Parameters
    ----------
    table : pandas.DataFrame
        Long table (one row per unit and time).
    time : str, optional
        The time column (default ``"time"``, else ``"cycle"``; none: nothing to do).

    Returns
    -------
    (pandas.DataFrame, str or None)
        The table (a copy when converted) and the origin (the earliest stamp, ISO
        text), or None when nothing was converted.

    Raises
    ------
    pdmkit.errors.DataError
        Text that is neither numbers nor timestamps throughout (names the first bad row).

    Examples
    --------
    >>> import pandas as pd
    >>> from pdmkit.rul import timestamps_to_seconds
    >>> t = pd.DataFrame({"time": ["2004-03-04 09:27:46", "2004-03-04 10:27:46"]})
    >>> table, origin = timestamps_to_seconds(t)
    >>> table["time"].tolist(), origin
    ([0.0, 3600.0], '2004-03-04T09:27:46')
    """
    if time is None:
        time = next((c for c in ("time", "cycle") if c in table.columns), None)
    if time is None or time not in table.columns:
        return table, None
    column = table[time]
    if pd.api.types.is_numeric_dtype(column):  # seconds or cycles already
        return table, None
    if not pd.api.types.is_datetime64_any_dtype(column):
        numbers = pd.to_numeric(column, errors="coerce")
        if numbers.notna().all():  # numbers read as text
            return table.assign(**{time: numbers}), None
    stamps = parse_timestamps(column)
    bad = column[stamps.isna() & column.notna()]
    if len(bad) or stamps.isna().all():
        row = bad.index[0] if len(bad) else column.index[0]
        raise DataError(
            f"time column {time!r} must hold numbers (cycles or seconds) or "
            f"timestamps; row {row} holds {column.loc[row]!r}"
        )
    origin = stamps.min()
    seconds = (stamps - origin).dt.total_seconds().astype(float)
    return table.assign(**{time: seconds}), origin.isoformat()


def resolve_keys(table: pd.DataFrame, unit: str, time: str | None) -> tuple[str, str]:
    """The unit and time column names of a run-to-failure table, checked.

    ``time=None`` takes ``time``, else ``cycle``; a missing column is a one-line
    :class:`~pdmkit.errors.DataError` that lists the table's columns.

    Examples
    --------
    >>> import pandas as pd
    >>> from pdmkit.rul import resolve_keys
    >>> resolve_keys(pd.DataFrame({"unit": [1], "cycle": [1], "s1": [0.0]}), "unit", None)
    ('unit', 'cycle')
    """
    if unit not in table.columns:
        raise DataError(
            f"unit column {unit!r} is not in the table (columns: "
            f"{list(table.columns)[:12]}); "
            "pass unit=<column telling the units apart>"
        )
    if time is None:
        time = next((c for c in ("time", "cycle") if c in table.columns), None)
        if time is None:
            raise DataError(
                "the table has neither a 'time' nor a 'cycle' column; pass time=<column "
                "ordering each unit's rows>"
            )
    elif time not in table.columns:
        raise DataError(
            f"time column {time!r} is not in the table (columns: "
            f"{list(table.columns)[:12]})"
        )
    column = table[time]
    if not (
        pd.api.types.is_numeric_dtype(column)
        or pd.api.types.is_datetime64_any_dtype(column)
    ) or pd.api.types.is_bool_dtype(column):
        numbers = pd.to_numeric(column, errors="coerce")
        bad = column[numbers.isna() & column.notna()]
        if len(bad):
            raise DataError(
                f"time column {time!r} must hold numbers (cycles or seconds); row "
                f"{bad.index[0]} holds {bad.iloc[0]!r}"
            )
    return unit, time


def as_columns(columns: str | Sequence[str]) -> list[str]:
    if isinstance(columns, str):
        return [columns]
    return list(columns)


def check_columns(table: pd.DataFrame, columns: Sequence[str], param: str) -> None:
    check_columns_present(table, columns, f"{param} column(s)")
    bad = [c for c in columns if not pd.api.types.is_numeric_dtype(table[c])]
    if bad:
        raise DataError(f"{param} columns {bad} are not numeric")


def learnable_columns(
    table: pd.DataFrame,
    features: str | Sequence[str] | None,
    keys: set[str],
    owner: str,
) -> tuple[list[str], dict[str, str]]:
    """The feature columns a learned model trains on, and the ones it leaves out.

    ``features=None`` takes every numeric, non-boolean column that is not a key or a
    label; columns constant over the table (up to rounding: C-MAPSS stores two sensors
    with a 1e-15 spread, which standardised would be pure noise) are dropped.

    Returns
    -------
    (list of str, dict)
        The columns kept, and ``{column: why it was dropped}``.

    Examples
    --------
    >>> import pandas as pd
    >>> from pdmkit.rul._base import learnable_columns
    >>> t = pd.DataFrame({"unit": [1, 1], "time": [1, 2], "a": [0.1, 0.3], "b": 2.0})
    >>> learnable_columns(t, None, {"unit", "time"}, "model")
    (['a'], {'b': 'constant over the training table'})
    """
    if features is None:
        cols = [
            c
            for c in table.columns
            if c not in keys
            and c not in LABEL_COLUMNS
            and pd.api.types.is_numeric_dtype(table[c])
            and not pd.api.types.is_bool_dtype(table[c])
        ]
    else:
        cols = as_columns(features)
    check_columns(table, cols, "features")
    spread = table[cols].std() if cols else pd.Series(dtype=float)
    magnitude = table[cols].abs().mean() if cols else pd.Series(dtype=float)
    kept = [c for c in cols if spread[c] > 1e-9 * max(magnitude[c], 1.0)]
    if not kept:
        raise DataError(
            f"every feature is constant over the training table ({cols}); the {owner} "
            "has nothing to learn from"
        )
    return kept, {c: "constant over the training table" for c in cols if c not in kept}


def failed_column(table: pd.DataFrame, failed: str | None) -> str | None:
    if failed is None:
        return "failed" if "failed" in table.columns else None
    if failed not in table.columns:
        raise DataError(
            f"failed={failed!r} is not a column of the table; it should hold True for "
            "units that ran to failure and False for censored ones"
        )
    return failed


def split_units(
    table: pd.DataFrame,
    columns: Sequence[str],
    *,
    unit: str,
    time: str | None,
    failed: str | None = None,
    what: str = "table",
) -> list[Unit]:
    """Split a long table into :class:`Unit` objects (sorted by time, values checked)."""
    table = check_table(table, what)
    unit, time = resolve_keys(table, unit, time)
    columns = as_columns(columns)
    check_columns(table, columns, "indicator")
    if what != "training table" and failed is not None and failed not in table.columns:
        failed = None  # histories to predict need no failure flag
    failed = failed_column(table, failed)
    if table[unit].isna().any():
        raise DataError(f"unit column {unit!r} has missing values; every row needs a unit")
    units = []
    for name, part in table.groupby(unit, sort=False):
        part = part.sort_values(time, kind="stable")
        t = part[time].to_numpy(dtype=float)
        x = part[columns].to_numpy(dtype=float)
        if not np.isfinite(t).all():
            raise DataError(f"unit {name!r}: time column {time!r} has NaN or inf values")
        if len(t) > 1 and (np.diff(t) <= 0).any():
            raise DataError(
                f"unit {name!r}: time {time!r} repeats a value; each unit needs one row "
                "per time (aggregate duplicates first)"
            )
        bad = ~np.isfinite(x)
        if bad.any():
            row, col = np.argwhere(bad)[0]
            raise DataError(
                f"unit {name!r}: indicator {columns[col]!r} is NaN or inf at {time}="
                f"{t[row]:g} ({int(bad.sum())} such values); fill or drop them first"
            )
        flag = True
        if failed is not None:
            flag = bool(part[failed].astype(bool).to_numpy()[-1])
        units.append(Unit(name, t, x, flag))
    return units


def require_failures(units: Sequence[Unit], model: str) -> None:
    """Raise when a training unit is censored (the model needs run-to-failure units)."""
    censored = [u.name for u in units if not u.failed]
    if censored:
        raise DataError(
            f"{model} needs run-to-failure training units, but {len(censored)} unit(s) "
            f"are censored (failed=False): {censored[:8]}; drop them, or use "
            "ReliabilitySurvivalModel / CovariateSurvivalModel, which use censored "
            "lifetimes"
        )


def check_fitted(estimator: object, attribute: str) -> None:
    if not hasattr(estimator, attribute):
        raise NotFittedError(
            f"this {type(estimator).__name__} is not fitted yet; call fit(table) first"
        )


def check_rul_model(model: object, owner: str) -> None:
    """A wrapper's ``model=`` must be a pdmkit RUL model (``predict_trajectory``)."""
    if model is None or not hasattr(model, "predict_trajectory"):
        raise TypeError(
            f"{owner} needs model= a pdmkit RUL model (fit / predict / "
            f"predict_trajectory); got {type(model).__name__}"
        )


def check_level(level: object) -> float:
    if isinstance(level, bool) or not isinstance(level, int | float | np.number):
        raise ValueError(f"level must be a number in (0, 1), got {level!r}")
    if not 0.0 < float(level) < 1.0:
        raise ValueError(
            f"level must lie in (0, 1) (e.g. 0.9 for 90 % intervals), got {level}"
        )
    return float(level)


def check_positive_int(value: object, name: str, minimum: int = 1) -> int:
    """:func:`pdmkit._checks.check_int` raising ``ValueError`` (estimator parameters)."""
    return check_int(value, name, minimum=minimum, error=ValueError)


def check_max_rul(value: object) -> float | None:
    if value is None:
        return None
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float | np.number)
        or value <= 0
    ):
        raise ValueError(f"max_rul must be a positive number or None, got {value!r}")
    return float(value)


def keep_init_args(estimator: object, args: dict[str, Any]) -> None:
    """Store an ``__init__``'s arguments (its ``locals()``) as attributes of the same names.

    scikit-learn's ``get_params`` expects them there.
    """
    for name, value in args.items():
        if name not in ("self", "__class__"):
            setattr(estimator, name, value)


def time_unit_cuts(units: Sequence[Unit], every: int, min_length: int) -> list[Unit]:
    """Histories cut after samples ``min_length, min_length + every, ..., n``."""
    out = []
    for u in units:
        n = len(u)
        cuts = list(range(min(min_length, n), n + 1, every))
        if not cuts or cuts[-1] != n:
            cuts.append(n)
        out.extend(u.head(c) for c in cuts)
    return out


class TrajectoryMixin:
    """``predict_trajectory``: the RUL a model gives at each point of a unit's history."""

    _min_history = 1

    def _split_columns(self) -> list[str]:
        """The value columns of each unit (none for a lifetime-only model)."""
        return []

    def _prediction(self, names, times, est, lo, hi, *, level, extra=None):
        """The estimates and intervals as a :class:`RULPrediction`, capped at ``max_rul``.

        With ``max_rul`` set, no estimate or interval bound is above it.
        """
        est, lo, hi = (np.asarray(v, dtype=float) for v in (est, lo, hi))
        cap = check_max_rul(self.max_rul)
        if cap is not None:
            est, lo, hi = (np.minimum(v, cap) for v in (est, lo, hi))
        return RULPrediction(
            names,
            times,
            est,
            lo,
            hi,
            level=level,
            model=type(self).__name__,
            extra=extra,
        )

    def _split(self, table, what: str = "table") -> list[Unit]:
        """``table`` as units, with the key and failure columns ``fit`` resolved."""
        return split_units(
            table,
            self._split_columns(),
            unit=self._keys[0],
            time=self._keys[1],
            failed=self._failed,
            what=what,
        )

    def predict_trajectory(
        self, table: pd.DataFrame, *, every: int = 1, min_length: int | None = None
    ) -> RULPrediction:
        """RUL predicted at every ``every``-th sample of each unit's history.

        The unit's history is cut after its ``min_length``-th sample, then every
        ``every`` samples up to its last one, and each cut is predicted as if it were
        all the data there was (the online use of a RUL model).

        Parameters
        ----------
        table : pandas.DataFrame
            Long table of the units to follow.
        every : int, default 1
            Step between cuts, in samples.
        min_length : int, optional
            Length of the first cut; default the shortest history the model accepts.

        Returns
        -------
        RULPrediction
            Several rows per unit, one per cut (``time`` = last time of the cut).

        Examples
        --------
        >>> import numpy as np, pandas as pd
        >>> from pdmkit.rul import ReliabilitySurvivalModel
        >>> train = pd.DataFrame({"unit": np.repeat([1, 2, 3], 3),
        ...                       "time": [1, 2, 9, 1, 2, 11, 1, 2, 10]})
        >>> model = ReliabilitySurvivalModel().fit(train)
        >>> path = model.predict_trajectory(train[train.unit == 1], every=1)
        >>> path.time.tolist()
        [1.0, 2.0, 9.0]
        """
        check_fitted(self, "n_units_")
        every = check_positive_int(every, "every")
        first = (
            self._min_history
            if min_length is None
            else check_positive_int(min_length, "min_length")
        )
        units = self._split(table, what="table")
        return self._predict_units(time_unit_cuts(units, every, first))

    def predict(self, table: pd.DataFrame) -> RULPrediction:
        """Predict the RUL of each unit at the last time of its history.

        Parameters
        ----------
        table : pandas.DataFrame
            Long table (``unit``, ``time``, indicator columns) of the units' histories
            so far.

        Returns
        -------
        RULPrediction
            One row per unit: estimate and interval at the unit's last time.

        Examples
        --------
        >>> import numpy as np, pandas as pd
        >>> from pdmkit.rul import ReliabilitySurvivalModel
        >>> train = pd.DataFrame({"unit": [1, 2, 3], "time": [9.0, 11.0, 10.0]})
        >>> rul = ReliabilitySurvivalModel().fit(train).predict(train.head(1))
        >>> len(rul)
        1
        """
        check_fitted(self, "n_units_")
        return self._predict_units(self._split(table, what="table"))

    def fit_predict(self, table: pd.DataFrame) -> RULPrediction:
        """Fit on ``table`` and predict its units (in-sample; for a quick look only).

        Examples
        --------
        >>> import pandas as pd
        >>> from pdmkit.rul import ReliabilitySurvivalModel
        >>> t = pd.DataFrame({"unit": [1, 2, 3], "time": [9.0, 11.0, 10.0]})
        >>> len(ReliabilitySurvivalModel().fit_predict(t))
        3
        """
        return self.fit(table).predict(table)


class LearnedMixin(TrajectoryMixin):
    """Shared plumbing of the learned models: gradient-boosted trees and networks.

    The fit-time checks and feature columns, and the cross-conformal intervals: the
    out-of-fold residuals, binned by the predicted RUL, give each bin's offsets.
    """

    # integer settings ``fit`` checks, with the smallest value each may take
    _int_settings: tuple[tuple[str, int], ...] = ()
    # what the message about constant features calls the model
    _learner = "model"

    def _split_columns(self) -> list[str]:
        """The feature columns ``fit`` kept."""
        return list(self.features_)

    def _check_choices(self) -> None:
        """Hook: checks of a model's own text settings, run before the integer ones."""

    def _start_fit(self, table: object) -> tuple[list[Unit], float]:
        """Check the table and settings; the training units and the interval level."""
        table = check_table(table)
        self._keys = resolve_keys(table, self.unit, self.time)
        self._failed = failed_column(table, self.failed)
        self._check_choices()
        for name, low in self._int_settings:
            check_positive_int(getattr(self, name), name, low)
        level = check_level(self.level)
        check_max_rul(self.max_rul)
        keys = {*self._keys, *([self._failed] if self._failed else [])}
        self.features_, self.dropped_ = learnable_columns(
            table, self.features, keys, self._learner
        )
        units = self._split(table, "training table")
        require_failures(units, type(self).__name__)
        return units, level

    def _calibrate(
        self, pred: np.ndarray, true: np.ndarray, level: float, n_bins: int
    ) -> None:
        """``residual_bins_``: interval offsets per bin of predicted RUL.

        The bins are ``n_bins`` quantile bins of ``pred`` (the outer ones open); each
        bin's offsets are the empirical ``level`` quantiles of ``true - pred`` in it
        (of all residuals for an empty bin).
        """
        resid = true - pred
        edges = np.unique(np.quantile(pred, np.linspace(0, 1, n_bins + 1)))
        if len(edges) < 2:
            edges = np.array([pred.min(), pred.max() + 1e-9])
        edges[0], edges[-1] = -np.inf, np.inf
        bins = np.clip(np.searchsorted(edges, pred, side="right") - 1, 0, len(edges) - 2)
        rows = []
        for b in range(len(edges) - 1):
            r = resid[bins == b]
            r = resid if r.size == 0 else r
            lo, hi = np.quantile(r, [(1 - level) / 2, (1 + level) / 2])
            rows.append(
                {
                    "low": edges[b],
                    "high": edges[b + 1],
                    "n": int((bins == b).sum()),
                    "lower_offset": float(lo),
                    "upper_offset": float(hi),
                }
            )
        self.residual_bins_ = pd.DataFrame(rows)

    def _binned_prediction(
        self, units: Sequence[Unit], est: np.ndarray, top: float, level: float
    ) -> RULPrediction:
        """Estimates with the offsets of their bins, clipped to ``[0, top]``.

        An interval always holds its estimate.
        """
        bins = self.residual_bins_
        b = np.clip(
            np.searchsorted(bins["low"].to_numpy(), est, side="right") - 1, 0, len(bins) - 1
        )
        lower = np.clip(est + bins["lower_offset"].to_numpy()[b], 0.0, top)
        upper = np.clip(est + bins["upper_offset"].to_numpy()[b], 0.0, top)
        return RULPrediction(
            [u.name for u in units],
            [float(u.t[-1]) for u in units],
            est,
            np.minimum(lower, est),
            np.maximum(upper, est),
            level=level,
            model=type(self).__name__,
        )


class DegradationMixin(TrajectoryMixin, abc.ABC):
    """Shared plumbing of the one-indicator degradation models.

    The models: linear, exponential, Wiener and gamma process. The plumbing: the fit-time
    checks, the threshold, the horizon and the sequential updates predicted without a table.
    """

    _min_history = 1
    # the attribute fit sets that predict(table=None) checks for
    _fitted_attribute = "n_units_"

    def _split_columns(self) -> list[str]:
        return [self.indicator]

    def _check_settings(self) -> None:
        """Hook: checks of a model's own parameters, run early in :meth:`fit`."""

    def _start_fit(self, table) -> tuple[list[Unit], np.ndarray]:
        """Check the table and parameters; the training units and all their values."""
        table = check_table(table)
        self._keys = resolve_keys(table, self.unit, self.time)
        self._failed = failed_column(table, self.failed)
        self._level = check_level(self.level)
        self._check_settings()
        check_max_rul(self.max_rul)
        if self.direction not in ("increasing", "decreasing"):
            raise ValueError(
                "direction must be 'increasing' (the indicator grows towards the "
                f"threshold) or 'decreasing', got {self.direction!r}"
            )
        if not isinstance(self.indicator, str):
            raise ValueError(f"indicator must be one column name, got {self.indicator!r}")
        self._sign = 1.0 if self.direction == "increasing" else -1.0
        units = self._split(table, "training table")
        values = np.concatenate([u.x[:, 0] for u in units])
        if np.ptp(values) == 0:
            raise DataError(
                f"indicator {self.indicator!r} is constant ({values[0]:g}) in every "
                "training unit; a degradation model needs an indicator that changes "
                "with wear"
            )
        return units, values

    @staticmethod
    def _require_failed_for_threshold(units: Sequence[Unit], takes: str) -> None:
        """Raise when ``threshold=None`` and a training unit is censored.

        With ``threshold=None`` the model ``takes`` a value at failure.
        """
        censored = [u.name for u in units if not u.failed]
        if censored:
            raise DataError(
                f"threshold=None takes {takes}, but units {censored[:8]} are censored; "
                "pass threshold=<indicator value at failure>"
            )

    def _given_threshold(self) -> float:
        threshold = float(self.threshold)
        if not np.isfinite(threshold):
            raise ValueError(f"threshold must be finite, got {self.threshold!r}")
        return threshold

    def _warn_unreached(self, values: np.ndarray, threshold: float, then: str) -> None:
        """Warn (at :meth:`fit`'s caller) that no training unit reaches the threshold."""
        warnings.warn(
            f"no training unit's {self.indicator!r} reaches threshold={threshold:g} "
            f"(training range {values.min():g} .. {values.max():g}); {then}",
            UserWarning,
            stacklevel=3,
        )

    def _finish_fit(self, units: Sequence[Unit], *, positive_horizon: bool = False) -> Self:
        """Set ``horizon_``, ``n_units_`` and empty ``states_``.

        ``horizon_`` defaults to 10 times the longest training life.
        """
        lives = [u.t[-1] - u.t[0] for u in units]
        self.horizon_ = (
            float(self.horizon) if self.horizon is not None else 10.0 * max(max(lives), 1.0)
        )
        if positive_horizon and not self.horizon_ > 0:
            raise ValueError(f"horizon must be positive, got {self.horizon!r}")
        self.n_units_ = len(units)
        self.states_ = {}
        return self

    @staticmethod
    def _check_update_start(u: Unit, last: float) -> None:
        if u.t[0] <= last:
            raise DataError(
                f"unit {u.name!r}: update starts at time {u.t[0]:g}, not after the "
                f"last time already folded in ({last:g}); pass only new rows"
            )

    @abc.abstractmethod
    def _predict_states(self):
        """Predict the units from :attr:`states_` (built by ``update``)."""

    def _predict_table_or_states(self, table):
        """``predict``: the units of ``table``, or without one those updated so far."""
        check_fitted(self, self._fitted_attribute)
        if table is not None:
            return self._predict_units(self._split(table))
        if not self.states_:
            raise DataError(
                "no unit has been updated yet; pass a table or call update first"
            )
        return self._predict_states()
