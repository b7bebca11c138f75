"""Turn long recording tables (one row per sample) into ensembles."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from pdmkit._checks import check_columns_present, check_int
from pdmkit.ensembles._ensemble import Ensemble
from pdmkit.ensembles._signals import _names_list
from pdmkit.errors import DataError

__all__ = ["from_frame"]


def _as_columns(value: Any, what: str) -> list[Any]:
    if value is None:
        return []
    if isinstance(value, str):
        return [value]
    return list(value)


def _constant_within(
    codes: np.ndarray, starts: np.ndarray, stops: np.ndarray
) -> np.ndarray:
    """Whether ``codes`` is constant on every row range ``[start, stop)`` (vectorised)."""
    changes = np.concatenate(([0], np.cumsum(codes[1:] != codes[:-1])))
    return changes[stops - 1] == changes[starts]


def from_frame(
    table: pd.DataFrame,
    *,
    signal_columns: str | Sequence[str],
    fs: float | Mapping[str, float],
    member_column: str | None = None,
    frame_length: int | None = None,
    label_columns: str | Sequence[str] = (),
) -> Ensemble:
    """Build an ensemble from a long table with one row per sample.

    Rows are taken in table order as time order. With ``member_column`` each distinct
    value of that column is one member (in order of first appearance; id ``str(value)``);
    without it the whole table is one recording (id ``"m00000"``). With
    ``frame_length`` the members are then cut into non-overlapping frames of that many
    rows (:meth:`Ensemble.frames`; ids ``"<member>/f<k:04d>"``, trailing rows dropped).

    Parameters
    ----------
    table : pandas.DataFrame
        The recording(s), e.g. from :func:`read_table`.
    signal_columns : str or sequence of str
        Numeric columns that become signals (same names).
    fs : float or mapping of str to float
        Sampling rate in Hz (rows per second), for all or per signal.
    member_column : str, optional
        Column that tells the members apart (unit, run, file, ...).
    frame_length : int, optional
        Cut every member into frames of this many rows.
    label_columns : str or sequence of str, optional
        Columns that become condition variables; each must hold one value per output
        member (per member, or per frame when framing), else DataError.

    Returns
    -------
    Ensemble

    Examples
    --------
    >>> import pandas as pd
    >>> table = pd.DataFrame({
    ...     "run": ["a", "a", "a", "b", "b"],
    ...     "flow": [1.0, 1.1, 1.2, 2.0, 2.1],
    ...     "valve": ["ok", "ok", "ok", "stuck", "stuck"],
    ... })
    >>> ens = from_frame(table, signal_columns="flow", fs=10.0, member_column="run",
    ...                  label_columns="valve")
    >>> ens.member_ids.tolist(), ens.signal("flow")[1], ens.conditions["valve"].tolist()
    (['a', 'b'], array([2. , 2.1]), ['ok', 'stuck'])
    >>> one = from_frame(table, signal_columns=["flow"], fs=10.0, frame_length=2)
    >>> one.member_ids.tolist()
    ['m00000/f0000', 'm00000/f0001']
    """
    if not isinstance(table, pd.DataFrame):
        raise DataError(f"from_frame takes a pandas DataFrame; got {type(table).__name__}")
    signals = _as_columns(signal_columns, "signal_columns")
    labels = _as_columns(label_columns, "label_columns")
    if not signals:
        raise DataError("signal_columns names no column; give at least one")
    check_columns_present(table, signals, "signal column(s)")
    check_columns_present(table, labels, "label column(s)")
    if member_column is not None:
        check_columns_present(table, [member_column], "member column")
        clash = [c for c in (*signals, *labels) if c == member_column]
        if clash:
            raise DataError(
                f"member_column {member_column!r} is also a signal or label column"
            )
    if frame_length is not None:
        frame_length = check_int(frame_length, "frame_length")
    if len(table) == 0:
        raise DataError("the table has no rows")

    # order rows by member (stable: time order inside a member is kept)
    if member_column is None:
        order = np.arange(len(table))
        bounds = np.array([0, len(table)])
        ids = None
    else:
        codes, uniques = pd.factorize(table[member_column], sort=False)
        if (codes < 0).any():
            rows = np.flatnonzero(codes < 0)[:5].tolist()
            raise DataError(
                f"member column {member_column!r} is empty in some rows (positions "
                f"{rows}); fill or drop them"
            )
        order = np.argsort(codes, kind="stable")
        bounds = np.concatenate(
            ([0], np.cumsum(np.bincount(codes, minlength=len(uniques))))
        )
        ids = [str(u) for u in uniques]

    arrays = {}
    for c in signals:
        try:
            values = table[c].to_numpy(dtype=np.float64, na_value=np.nan)
        except (TypeError, ValueError):
            raise DataError(
                f"signal column {c!r} is not numeric (dtype {table[c].dtype}); convert it "
                "or leave it out of signal_columns"
            ) from None
        arrays[c] = np.split(values[order], bounds[1:-1])
    ens = Ensemble(arrays, fs, member_ids=ids)
    starts, stops = bounds[:-1], bounds[1:]
    if frame_length is not None:
        ens = ens.frames(frame_length)
        cond = ens.conditions
        source = pd.Index(ids if ids is not None else ["m00000"]).get_indexer(
            cond["source_member"]
        )
        starts = bounds[source] + cond["frame"].to_numpy() * frame_length
        stops = starts + frame_length
    if labels:
        sorted_table = table.iloc[order]
        columns = {}
        for c in labels:
            col = sorted_table[c]
            codes = pd.factorize(col, use_na_sentinel=False)[0]
            ok = _constant_within(codes, starts, stops)
            if not ok.all():
                bad = ens.member_ids[~ok].tolist()
                unit = "frame" if frame_length is not None else "member"
                raise DataError(
                    f"label column {c!r} changes within {unit}(s) {_names_list(bad)}; a "
                    f"label must hold one value per {unit}. Split the recording with "
                    "member_column, or leave the column out of label_columns"
                )
            columns[c] = col.iloc[starts].reset_index(drop=True)
        ens = ens.with_conditions(**columns)
    return ens
