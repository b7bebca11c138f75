"""What the page draws, computed on the server: few points per trace, never all samples.

Signals are cut to about :data:`POINTS` points per trace by min/max decimation (each
bucket of samples keeps its smallest and its largest, in time order, so spikes and
the envelope survive); spectra are Welch PSDs decimated the same way; indicator
values are sent per class, at most :data:`MAX_VALUES` per class.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from pdmkit.errors import DataError
from pdmkit.experiments.designer._source import MAX_PLOT_MEMBERS

__all__ = [
    "MAX_VALUES",
    "POINTS",
    "class_values",
    "filter_members",
    "minmax_decimate",
    "pick_members",
    "signal_traces",
]

#: points per drawn trace (about; min/max pairs)
POINTS = 2000
#: most indicator values sent per class for a histogram or a scatter
MAX_VALUES = 5000
#: most distinct values a condition may have to be offered as a filter or a colour
MAX_LEVELS = 60


def minmax_decimate(
    x: np.ndarray, y: np.ndarray, points: int = POINTS
) -> tuple[np.ndarray, np.ndarray]:
    """Keep each bucket's smallest and largest sample, in order: about ``points`` left.

    Parameters
    ----------
    x, y : numpy.ndarray
        Abscissa (time, frequency) and values, 1-D, same length.
    points : int, default 2000
        About how many points to keep (a short trace is returned whole).

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)

    Examples
    --------
    >>> import numpy as np
    >>> y = np.zeros(100_000); y[12_345] = 9.0
    >>> xd, yd = minmax_decimate(np.arange(100_000.0), y, points=200)
    >>> len(yd) <= 200, yd.max(), xd[yd.argmax()]
    (True, np.float64(9.0), np.float64(12345.0))
    """
    n = len(y)
    if n <= points:
        return np.asarray(x, float), np.asarray(y, float)
    buckets = max(1, points // 2)
    edges = np.linspace(0, n, buckets + 1).astype(np.int64)
    starts = edges[:-1]
    # positions of the extremes inside each bucket
    idx_lo = np.empty(buckets, np.int64)
    idx_hi = np.empty(buckets, np.int64)
    for b, (a, z) in enumerate(zip(starts, edges[1:], strict=True)):
        seg = y[a:z]
        idx_lo[b] = a + int(np.argmin(seg))
        idx_hi[b] = a + int(np.argmax(seg))
    first = np.minimum(idx_lo, idx_hi)
    second = np.maximum(idx_lo, idx_hi)
    order = np.column_stack([first, second]).ravel()
    return np.asarray(x, float)[order], np.asarray(y, float)[order]


def filter_members(conditions: pd.DataFrame, where: dict | None) -> pd.Index:
    """The member ids whose conditions take one of the allowed values, column by column.

    Parameters
    ----------
    conditions : pandas.DataFrame
        One row per member.
    where : dict, optional
        Column -> allowed values (shown as text); a column left out, or an empty list,
        allows all.

    Examples
    --------
    >>> import pandas as pd
    >>> c = pd.DataFrame({"fault": ["a", "b", "a"], "rpm": [1, 2, 2]}, index=list("xyz"))
    >>> filter_members(c, {"fault": ["a"], "rpm": ["2"]}).tolist()
    ['z']
    """
    keep = np.ones(len(conditions), dtype=bool)
    for column, allowed in (where or {}).items():
        if column not in conditions.columns:
            raise DataError(f"filter: no condition {column!r}")
        if not allowed:
            continue
        text = conditions[column].astype(str).to_numpy()
        keep &= np.isin(text, [str(a) for a in allowed])
    return conditions.index[keep]


def pick_members(
    conditions: pd.DataFrame, members: pd.Index, by: str | None, per_class: int = 1
) -> list[str]:
    """The first ``per_class`` members of each value of ``by`` (at most 12 values).

    Examples
    --------
    >>> import pandas as pd
    >>> c = pd.DataFrame({"fault": ["a", "a", "b"]}, index=["m0", "m1", "m2"])
    >>> pick_members(c, c.index, "fault")
    ['m0', 'm2']
    """
    if by is None or by not in conditions.columns:
        return [str(m) for m in members[: max(per_class, 6)]]
    values = conditions.loc[members, by].astype(str)
    picked: list[str] = []
    for _, ids in values.groupby(values, sort=True).groups.items():
        picked += [str(m) for m in list(ids)[:per_class]]
        if len(picked) >= 12 * per_class:
            break
    return picked


def _welch(x: np.ndarray, fs: float, nperseg: int | None):
    from scipy.signal import welch

    n = len(x)
    seg = min(int(nperseg or min(n, 1024)), n)
    freq, pxx = welch(x, fs=fs, nperseg=seg)
    return freq, pxx


def signal_traces(
    source: Any,
    members: Sequence[str],
    signal: str,
    by: str | None,
    kind: str = "signal",
    nperseg: int | None = None,
) -> dict:
    """Decimated traces of ``signal`` (or its Welch PSD) for the members, by class.

    Parameters
    ----------
    source : Source
        Where the members are read from (one member at a time).
    members : sequence of str
        Member ids; at most :data:`MAX_PLOT_MEMBERS` are read.
    signal : str
        Signal name.
    by : str or None
        Condition that groups (and colours) the traces.
    kind : {"signal", "spectrum"}
        Time signal or its Welch power spectral density.
    nperseg : int, optional
        Welch segment length (default min(length, 1024)).

    Returns
    -------
    dict
        ``traces`` (each ``member``, ``group``, ``x``, ``y``, ``n_samples``),
        ``x_label``, ``y_label``, ``decimated`` (any trace cut).

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.ensembles import Ensemble
    >>> from pdmkit.experiments.designer._source import Source
    >>> ens = Ensemble({"v": np.random.default_rng(0).normal(size=(2, 50_000))},
    ...                fs=1e4, conditions={"fault": ["a", "b"]})
    >>> out = signal_traces(Source.from_ensemble(ens), ["m00000"], "v", "fault")
    >>> out["traces"][0]["group"], len(out["traces"][0]["y"]) <= 2000, out["decimated"]
    ('a', True, True)
    """
    if kind not in ("signal", "spectrum"):
        raise DataError(f"kind must be 'signal' or 'spectrum'; got {kind!r}")
    fs = source.signals.get(signal)
    if fs is None:
        raise DataError(
            f"signal {signal!r} is not in this ensemble; its signals are "
            f"{sorted(source.signals)}"
        )
    traces, cut = [], False
    for member in list(members)[:MAX_PLOT_MEMBERS]:
        x = source.read(member, signal)
        if x is None:
            continue
        if kind == "signal":
            t = np.arange(len(x)) / fs
            xs, ys = minmax_decimate(t, np.asarray(x, float))
        else:
            freq, pxx = _welch(np.asarray(x, float), fs, nperseg)
            xs, ys = minmax_decimate(freq, pxx)
        cut |= len(ys) < (len(x) if kind == "signal" else len(ys) + 1)
        group = None
        if by is not None and by in source.conditions.columns:
            group = str(source.conditions.at[member, by])
        traces.append(
            {
                "member": str(member),
                "group": group,
                "x": xs.tolist(),
                "y": ys.tolist(),
                "n_samples": len(x),
            }
        )
    return {
        "traces": traces,
        "x_label": "time (s)" if kind == "signal" else "frequency (Hz)",
        "y_label": signal if kind == "signal" else f"PSD of {signal} (unit²/Hz)",
        "decimated": bool(cut),
    }


def class_values(table: pd.DataFrame, columns: Sequence[str], by: str | None) -> dict:
    """Values of indicator ``columns`` grouped by ``by`` (histograms, scatters).

    At most :data:`MAX_VALUES` members per class are sent (evenly spaced), with the
    class's size.

    Examples
    --------
    >>> import pandas as pd
    >>> t = pd.DataFrame({"v/stats/RMS": [1.0, 2.0, 3.0], "fault": ["a", "b", "b"]})
    >>> class_values(t, ["v/stats/RMS"], "fault")["groups"][1]
    {'name': 'b', 'n': 2, 'values': [[2.0, 3.0]], 'members': ['1', '2']}
    """
    for c in columns:
        if c not in table.columns:
            raise DataError(f"no indicator {c!r}; compute the indicators first")
    groups = []
    keys = table[by].astype(str) if by is not None and by in table.columns else None
    parts = [("all", table)] if keys is None else list(table.groupby(keys, sort=True))
    for name, rows in parts:
        n = len(rows)
        if n > MAX_VALUES:
            rows = rows.iloc[np.linspace(0, n - 1, MAX_VALUES).astype(int)]
        values = [
            [None if not np.isfinite(v) else float(v) for v in rows[c].to_numpy(float)]
            for c in columns
        ]
        groups.append(
            {
                "name": str(name),
                "n": n,
                "values": values,
                "members": [str(m) for m in rows.index],
            }
        )
    return {"columns": list(columns), "by": by, "groups": groups}
