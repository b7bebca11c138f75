"""The result object every RUL model returns."""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from pdmkit.errors import DataError

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from numpy.typing import ArrayLike


class RULPrediction:
    """Remaining useful life estimates with their confidence intervals.

    One row per unit (``predict``) or several per unit, one per point of its history
    (``predict_trajectory``).

    Parameters
    ----------
    unit : array_like
        Unit of each row.
    time : array_like
        Time of the last observation the row's prediction used.
    estimate : array_like
        Point estimate of the RUL (median of the model's RUL distribution), in the
        unit of the time column. ``inf`` when the model expects no failure (see the
        model's notes).
    lower, upper : array_like
        Interval holding the RUL with probability ``level``.
    level : float, default 0.9
        Confidence level of the intervals.
    model : str, optional
        Name of the model that made the prediction.
    extra : dict of str -> array_like, optional
        Further per-row columns (for example the nearest training units).
    time_unit : str, optional
        Unit of the time column and the RULs (``"cycles"``, ``"h"``, ...), shown on
        the plots' axes.

    Attributes
    ----------
    unit, time, estimate, lower, upper : numpy.ndarray
    level : float
    model : str
    extra : dict
    time_unit : str

    Examples
    --------
    >>> from pdmkit.rul import RULPrediction
    >>> p = RULPrediction([1, 2], [50, 80], [30.0, 12.0], [20.0, 5.0], [45.0, 20.0])
    >>> p.to_pandas()
       unit  time   rul  lower  upper
    0     1    50  30.0   20.0   45.0
    1     2    80  12.0    5.0   20.0
    >>> p.evaluate([35.0, 10.0])["coverage"]
    1.0
    """

    def __init__(
        self,
        unit: ArrayLike,
        time: ArrayLike,
        estimate: ArrayLike,
        lower: ArrayLike,
        upper: ArrayLike,
        *,
        level: float = 0.9,
        model: str = "",
        extra: Mapping[str, ArrayLike] | None = None,
        time_unit: str = "",
    ) -> None:
        self.unit = np.asarray(unit)
        self.time = np.asarray(time)
        self.estimate = np.asarray(estimate, dtype=float)
        self.lower = np.asarray(lower, dtype=float)
        self.upper = np.asarray(upper, dtype=float)
        n = len(self.estimate)
        for name in ("unit", "time", "lower", "upper"):
            if getattr(self, name).shape != (n,):
                raise DataError(
                    f"RULPrediction: {name} has shape {getattr(self, name).shape}; "
                    f"expected ({n},) like estimate"
                )
        self.level = float(level)
        self.model = str(model)
        self.time_unit = str(time_unit)
        self.extra = {}
        for key, values in (extra or {}).items():
            values = list(values) if not isinstance(values, np.ndarray) else values
            if len(values) != n:
                raise DataError(
                    f"RULPrediction: extra column {key!r} has {len(values)} rows; "
                    f"expected {n}"
                )
            self.extra[key] = (
                np.asarray(values) if isinstance(values, np.ndarray) else values
            )

    def __len__(self) -> int:
        return len(self.estimate)

    def __repr__(self) -> str:
        units = len(pd.unique(self.unit)) if len(self) else 0
        name = f"{self.model}, " if self.model else ""
        return f"RULPrediction({name}{len(self)} rows, {units} units, level={self.level:g})"

    def to_pandas(self) -> pd.DataFrame:
        """Table with ``unit, time, rul, lower, upper`` and any extra columns.

        Examples
        --------
        >>> from pdmkit.rul import RULPrediction
        >>> RULPrediction(["a"], [3.0], [7.0], [5.0], [9.0]).to_pandas().columns.tolist()
        ['unit', 'time', 'rul', 'lower', 'upper']
        """
        frame = pd.DataFrame(
            {
                "unit": self.unit,
                "time": self.time,
                "rul": self.estimate,
                "lower": self.lower,
                "upper": self.upper,
            }
        )
        for key, values in self.extra.items():
            frame[key] = list(values) if not isinstance(values, np.ndarray) else values
        return frame

    def evaluate(self, rul_true: ArrayLike | Mapping[object, float]) -> dict[str, float]:
        """RMSE, MAE, PHM08 score and interval coverage against the true RULs.

        Warns (:func:`pdmkit.rul.coverage_check`) when the intervals cover far fewer
        true RULs than their level says.

        Parameters
        ----------
        rul_true : array_like or mapping
            True RUL per row, or a mapping unit -> true RUL (for one row per unit).

        Returns
        -------
        dict
            See :func:`pdmkit.rul.rul_metrics`.

        Examples
        --------
        >>> from pdmkit.rul import RULPrediction
        >>> p = RULPrediction([1, 2], [5, 5], [10.0, 20.0], [8.0, 15.0], [12.0, 30.0])
        >>> p.evaluate({1: 12.0, 2: 20.0})["rmse"]
        1.4142135623730951
        """
        from pdmkit.rul._metrics import coverage_check, rul_metrics

        if isinstance(rul_true, dict | pd.Series):
            mapping = dict(rul_true)
            missing = [u for u in self.unit if u not in mapping]
            if missing:
                raise DataError(f"rul_true has no value for units {missing[:8]}")
            rul_true = [mapping[u] for u in self.unit]
        out = rul_metrics(rul_true, self.estimate, self.lower, self.upper)
        if 0 < self.level < 1:
            check = coverage_check(
                rul_true, self.lower, self.upper, self.level, what="the scored units",
                warn=False,
            )  # fmt: skip
            if check["far_below"]:
                warnings.warn(check["message"], UserWarning, stacklevel=2)
        return out

    def plot(
        self,
        ax: Axes | None = None,
        *,
        true: ArrayLike | None = None,
        units: Sequence[object] | None = None,
        max_units: int = 6,
        time_unit: str | None = None,
    ) -> Axes:
        """Plot the predictions with their intervals.

        With several rows per unit (a trajectory), RUL against time, one line and
        shaded interval per unit, and the true RUL dashed when ``true`` is given.
        With one row per unit: predicted against true RUL (``true`` given) or the
        estimate per unit with error bars.

        Parameters
        ----------
        ax : matplotlib Axes, optional
            Where to draw; a new figure when omitted.
        true : array_like, optional
            True RUL of each row.
        units : sequence, optional
            Units to show in the trajectory plot (default: the first ``max_units``).
        max_units : int, default 6
        time_unit : str, optional
            Unit on the axes (default :attr:`time_unit`; none shown when empty).

        Returns
        -------
        matplotlib.axes.Axes

        Examples
        --------
        >>> from pdmkit.rul import RULPrediction
        >>> p = RULPrediction([1, 1, 1], [10, 20, 30], [28.0, 21.0, 9.0],
        ...                   [20.0, 15.0, 5.0], [35.0, 27.0, 14.0])
        >>> ax = p.plot(true=[30.0, 20.0, 10.0], time_unit="h")
        >>> ax.get_xlabel(), ax.get_ylabel()
        ('time (h)', 'RUL (h)')
        """
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 4.5))
        true = None if true is None else np.asarray(true, dtype=float)
        if true is not None and true.shape != self.estimate.shape:
            raise DataError(f"true has shape {true.shape}; expected {self.estimate.shape}")
        names = list(pd.unique(self.unit))
        trajectory = len(names) < len(self)
        tu = getattr(self, "time_unit", "") if time_unit is None else str(time_unit)
        suffix = f" ({tu})" if tu else ""
        pct = f"{100 * self.level:g} %"
        # infinite RULs (no failure expected) are drawn at the top of the plot
        cap = _finite_cap(np.r_[self.upper, self.estimate])
        est, lo, up = (np.minimum(v, cap) for v in (self.estimate, self.lower, self.upper))
        if trajectory:
            shown = list(units) if units is not None else names[:max_units]
            for i, name in enumerate(shown):
                rows = self.unit == name
                if not rows.any():
                    raise DataError(f"unit {name!r} is not in this prediction")
                colour = f"C{i % 10}"
                t = self.time[rows]
                ax.plot(t, est[rows], color=colour, label=f"unit {name}")
                ax.fill_between(t, lo[rows], up[rows], color=colour, alpha=0.2, linewidth=0)
                if true is not None:
                    ax.plot(t, true[rows], color=colour, linestyle="--", linewidth=1)
            ax.set_xlabel("time" + suffix)
            ax.set_ylabel("RUL" + suffix)
            title = f"RUL with {pct} intervals"
            ax.set_title(title + (" (true dashed)" if true is not None else ""))
            ax.legend(fontsize="small")
            return ax
        err = np.vstack([np.clip(est - lo, 0, None), np.clip(up - est, 0, None)])
        if true is not None:
            ax.errorbar(
                true,
                est,
                yerr=err,
                fmt="o",
                markersize=3,
                alpha=0.7,
                elinewidth=0.6,
                label=f"estimate, {pct} interval",
            )
            top = float(np.nanmax(np.r_[true, est]))
            ax.plot([0, top], [0, top], "k--", linewidth=1, label="ideal")
            ax.set_xlabel("true RUL" + suffix)
            ax.set_ylabel("predicted RUL" + suffix)
            ax.set_title("Predicted against true RUL")
            ax.legend(fontsize="small")
        else:
            x = np.arange(len(self))
            ax.errorbar(x, est, yerr=err, fmt="o", markersize=3)
            if len(self) <= 30:
                ax.set_xticks(x, labels=[str(u) for u in self.unit], rotation=90)
            ax.set_xlabel("unit")
            ax.set_ylabel("RUL" + suffix)
            ax.set_title(f"RUL per unit with {pct} intervals")
        return ax


def _finite_cap(values: np.ndarray) -> float:
    finite = values[np.isfinite(values)]
    return float(finite.max()) * 1.2 if finite.size else 1.0
