"""What engineers look at after ``pdmkit monitor score``: health over time, alarms, drivers.

The report is drawn from the history (every row scored so far), not only from the
file just scored: a unit's health index over time with the alarm threshold (the
health index is 0.5 at the threshold), the alarm from its first row on, and at the
first alarm the indicators that drove the score.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd

from pdmkit._checks import parse_timestamps

__all__ = ["alarm_table", "plot_health_history", "plot_rul_history"]

#: units drawn in the figure (the least healthy first when there are more)
MAX_UNITS_DRAWN = 12


def _axis_times(frame: pd.DataFrame) -> tuple[pd.Series, str]:
    """The history's times for an axis: timestamps where the user's table had them."""
    text = frame["time_text"].astype(str)
    if not pd.to_numeric(text, errors="coerce").notna().all():
        stamps = parse_timestamps(text)
        if stamps.notna().all():
            return stamps, "time"
    return frame["time"], "time (the table's time column)"


def _drivers(top_json) -> str:
    if top_json is None or (isinstance(top_json, float) and np.isnan(top_json)):
        return ""
    return ", ".join(json.loads(top_json))


def alarm_table(frame: pd.DataFrame) -> pd.DataFrame:
    """One row per unit: rows scored, first alarm, its health index and drivers.

    Parameters
    ----------
    frame : DataFrame
        ``HealthHistory.history()``.

    Returns
    -------
    DataFrame
        ``unit``, ``rows``, ``first_alarm`` (the time as the table wrote it, empty
        when the unit never alarmed), ``health_index_at_alarm``,
        ``drivers_at_alarm`` (the indicators with the largest contributions),
        ``last_health_index``; alarmed units first, earliest alarm first.

    Examples
    --------
    >>> import pandas as pd
    >>> h = pd.DataFrame({"unit": ["a", "a", "b"], "time": [0.0, 1.0, 0.0],
    ...     "time_text": ["0", "1", "0"], "health_index": [0.9, 0.2, 0.8],
    ...     "alarm": [0, 1, 0], "top_indicators": [None, '["v/RMS"]', None]})
    >>> alarm_table(h)[["unit", "first_alarm", "drivers_at_alarm"]].values.tolist()
    [['a', '1', 'v/RMS'], ['b', '', '']]
    """
    rows = []
    for unit, part in frame.groupby("unit", sort=True):
        alarmed = np.flatnonzero(part["alarm"].to_numpy(dtype=bool))
        first = part.iloc[alarmed[0]] if alarmed.size else None
        never = first is None
        rows.append(
            {
                "unit": str(unit),
                "rows": len(part),
                "first_alarm": "" if never else str(first["time_text"]),
                "health_index_at_alarm": np.nan if never else float(first["health_index"]),
                "drivers_at_alarm": "" if never else _drivers(first["top_indicators"]),
                "last_health_index": float(part["health_index"].iloc[-1]),
                "_never": never,
                "_time": np.inf if never else float(first["time"]),
            }
        )
    table = pd.DataFrame(rows)
    if table.empty:
        return table
    table = table.sort_values(["_never", "_time", "unit"], kind="stable")
    return table.drop(columns=["_never", "_time"]).reset_index(drop=True)


def _units_to_draw(frame: pd.DataFrame) -> list:
    least = frame.groupby("unit")["health_index"].min().sort_values(kind="stable")
    return sorted(least.index[:MAX_UNITS_DRAWN].tolist(), key=str)


def _panels(units: list, ax, sharey: bool):
    """(figure, one axes per unit): a grid of panels, or ``ax`` for every unit."""
    import matplotlib.pyplot as plt

    if ax is not None:
        return ax.figure, [ax] * len(units)
    ncols = 1 if len(units) < 4 else 2
    nrows = max(1, -(-len(units) // ncols))
    fig, axes = plt.subplots(
        nrows, ncols, figsize=(6.0 * ncols, 2.2 * nrows), squeeze=False, sharey=sharey
    )
    axes = axes.ravel()
    for extra in axes[len(units) :]:
        extra.set_visible(False)
    return fig, axes


def plot_health_history(frame: pd.DataFrame, ax=None):
    """Each unit's health index over time, the threshold and its alarm.

    Parameters
    ----------
    frame : DataFrame
        ``HealthHistory.history()`` (columns ``unit``, ``time``, ``time_text``,
        ``health_index``, ``alarm``).
    ax : matplotlib Axes, optional
        Draw all units on this one axes; by default one panel per unit (at most
        ``MAX_UNITS_DRAWN``, the least healthy).

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import pandas as pd
    >>> h = pd.DataFrame({"unit": ["a"] * 3, "time": [0.0, 1.0, 2.0],
    ...     "time_text": ["0", "1", "2"], "health_index": [0.9, 0.4, 0.2],
    ...     "alarm": [0, 0, 1]})
    >>> fig = plot_health_history(h)
    >>> fig.axes[0].get_ylabel()
    'health index (1 = healthy)'
    """
    import matplotlib.dates as mdates

    units = _units_to_draw(frame)
    fig, axes = _panels(units, ax, sharey=True)
    for a, unit in zip(axes, units, strict=False):
        part = frame[frame["unit"] == unit]
        t, label = _axis_times(part)
        a.plot(t, part["health_index"], lw=0.9, label=str(unit))
        alarm = part["alarm"].to_numpy(dtype=bool)
        if alarm.any():
            k = int(np.argmax(alarm))
            a.axvspan(t.iloc[k], t.iloc[-1], color="tab:red", alpha=0.12, lw=0)
            a.axvline(t.iloc[k], color="tab:red", lw=1.0)
        a.axhline(0.5, color="k", ls="--", lw=0.8)
        a.set_ylim(-0.02, 1.02)
        a.set_ylabel("health index (1 = healthy)")
        a.set_xlabel(label)
        if label == "time":  # timestamps: short, non-overlapping date ticks
            locator = mdates.AutoDateLocator(maxticks=6)
            a.xaxis.set_major_locator(locator)
            a.xaxis.set_major_formatter(mdates.ConciseDateFormatter(locator))
        if ax is None:
            a.set_title(f"{unit}" + (" (alarm)" if alarm.any() else ""), fontsize=9)
    if ax is not None and units:
        ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def plot_rul_history(frame: pd.DataFrame, ax=None, time_unit: str | None = None):
    """Each unit's RUL after every scored file, with its interval.

    Parameters
    ----------
    frame : DataFrame
        ``HealthHistory.rul_history()`` (``unit``, ``time``, ``time_text``, ``rul``,
        ``lower``, ``upper``); a NaN bound (an open interval) is drawn to the
        panel's edge.
    ax : matplotlib Axes, optional
        Draw all units on this one axes; by default one panel per unit (at most
        ``MAX_UNITS_DRAWN``, the shortest last RUL first).
    time_unit : str, optional
        The RUL model's time unit, for the axis label.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import numpy as np, pandas as pd
    >>> r = pd.DataFrame({"unit": ["a"] * 3, "time": [0.0, 1.0, 2.0],
    ...     "time_text": ["0", "1", "2"], "rul": [9.0, 8.0, 7.5],
    ...     "lower": [5.0, 6.0, np.nan], "upper": [12.0, 10.0, 9.0]})
    >>> plot_rul_history(r, time_unit="h").axes[0].get_ylabel()
    'RUL (h)'
    """
    last = frame.groupby("unit")["rul"].last().sort_values(kind="stable")
    units = sorted(last.index[:MAX_UNITS_DRAWN].tolist(), key=str)
    fig, axes = _panels(units, ax, sharey=False)
    label = f"RUL ({time_unit})" if time_unit else "RUL"
    for a, unit in zip(axes, units, strict=False):
        part = frame[frame["unit"] == unit]
        t, xlabel = _axis_times(part)
        line = a.plot(t, part["rul"], lw=1.0, marker=".", ms=3, label=str(unit))[0]
        top = np.nanmax(part[["rul", "upper"]].to_numpy(dtype=float)) * 1.1
        lower = part["lower"].fillna(0.0)
        upper = part["upper"].fillna(top if np.isfinite(top) else 0.0)
        a.fill_between(t, lower, upper, color=line.get_color(), alpha=0.2, lw=0)
        a.set_ylim(bottom=0.0)
        a.set_ylabel(label)
        a.set_xlabel(xlabel)
        if ax is None:
            a.set_title(str(unit), fontsize=9)
    if ax is not None and units:
        ax.legend(fontsize=8)
    fig.tight_layout()
    return fig
