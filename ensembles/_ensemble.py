"""The in-memory ensemble: members with named signals and condition variables."""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pdmkit._checks import check_fs
from pdmkit.ensembles._parquet import _lists_to_arrays, read_parts, write_parquet
from pdmkit.ensembles._signals import (
    _SHOW,
    MEMBER,
    SignalList,
    _column_values,
    _convert_signal,
    _n_rows,
    _names_list,
)
from pdmkit.ensembles._views import _EnsembleViews
from pdmkit.errors import DataError

__all__ = ["Ensemble"]


def _check_input_types(signals: Any, conditions: Any) -> None:
    """Refuse signals that are no mapping of named arrays, conditions of another type."""
    if not isinstance(signals, Mapping):
        raise DataError(
            f"signals must be a mapping of signal name -> arrays; got "
            f"{type(signals).__name__}"
        )
    for name in signals:
        if not isinstance(name, str) or not name:
            raise DataError(f"signal names must be non-empty strings; got {name!r}")
    if conditions is not None and not isinstance(conditions, pd.DataFrame | Mapping):
        raise DataError(
            "conditions must be a pandas DataFrame or a mapping of column -> values; "
            f"got {type(conditions).__name__}"
        )


def _ids_from_frame(
    conditions: pd.DataFrame, member_ids: Sequence[Any] | None
) -> tuple[pd.DataFrame, Sequence[Any] | None]:
    """Conditions in row order, and member ids from their index or column if not given."""
    conditions = conditions.copy(deep=False)
    if member_ids is None and conditions.index.name == MEMBER:
        member_ids = list(conditions.index)
    if MEMBER in conditions.columns and member_ids is None:
        member_ids = list(conditions[MEMBER])
        conditions = conditions.drop(columns=MEMBER)
    return conditions.reset_index(drop=True), member_ids


def _member_count(
    signals: Mapping[str, Any], conditions: Any, member_ids: Sequence[Any] | None
) -> tuple[int, list | None]:
    """How many members (every source that knows must agree), and the ids as a list."""
    counts: dict[str, int] = {}
    for name, value in signals.items():
        if isinstance(value, np.ndarray) and value.dtype != object and value.ndim >= 1:
            counts[f"signal {name!r}"] = value.shape[0]
        elif hasattr(value, "__len__") and not isinstance(value, str | bytes):
            counts[f"signal {name!r}"] = len(value)
    if member_ids is not None:
        if isinstance(member_ids, str):
            raise DataError("member_ids must be a sequence of ids, not one string")
        member_ids = list(member_ids)
        counts["member_ids"] = len(member_ids)
    n_cond = _n_rows(conditions)
    if n_cond is not None:
        counts["conditions"] = n_cond
    if len(set(counts.values())) > 1:
        found = ", ".join(f"{k}: {v}" for k, v in counts.items())
        raise DataError(
            f"inputs disagree on the number of members ({found}); give every signal, "
            "the conditions and member_ids one entry per member"
        )
    return next(iter(counts.values()), 0), member_ids


class Ensemble(_EnsembleViews):
    """A collection of recordings (members): named signals plus condition variables.

    Every member has a string id, a row of condition variables (labels, settings,
    operating point, unit, cycle, ...) and, for each signal, a 1-D float64 array or
    ``None`` when the member lacks that signal. Each signal has one sampling rate for
    all members; bring recordings to a common rate (:meth:`resample`) before mixing.

    The ensemble does not copy the arrays it is given; it hands them out as read-only
    views so that no caller can change a member behind the others' backs. Methods
    return new ensembles and never modify this one.

    Parameters
    ----------
    signals : mapping of str to array
        Signal name -> either a 2-D array ``(n_members, n_samples)`` or a sequence with
        one 1-D array (or ``None``: member lacks the signal) per member.
    fs : float or mapping of str to float
        Sampling rate in Hz: one for every signal, or one per signal name.
    conditions : pandas.DataFrame or mapping, optional
        One row per member; a mapping gives column -> values (a scalar is broadcast).
        A DataFrame index named ``"member"`` (or a ``"member"`` column) supplies the
        member ids when ``member_ids`` is not given; otherwise rows are taken in order.
    member_ids : sequence, optional
        Member ids (converted to str, unique); default ``"m00000", "m00001", ...``.

    Raises
    ------
    pdmkit.errors.DataError
        Wrong number of entries, a non-1-D or empty array, non-numeric or non-finite
        samples (the message names the member and the signal), bad rates, duplicate ids,
        condition columns that clash with the member id or a signal name.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.ensembles import Ensemble
    >>> ens = Ensemble(
    ...     {"vib": np.zeros((3, 8)), "temp": [np.ones(2), None, np.ones(2)]},
    ...     fs={"vib": 8.0, "temp": 2.0},
    ...     conditions={"label": ["ok", "ok", "worn"], "rpm": 1500},
    ... )
    >>> len(ens), ens.signal_names
    (3, ['vib', 'temp'])
    >>> ens.has_signal("temp").tolist()
    [True, False, True]
    >>> list(ens.member_ids)
    ['m00000', 'm00001', 'm00002']
    >>> ens.conditions["rpm"].tolist()
    [1500, 1500, 1500]
    """

    __slots__ = ("_conditions", "_fs", "_signals")

    def __init__(
        self,
        signals: Mapping[str, Any],
        fs: float | Mapping[str, float],
        conditions: pd.DataFrame | Mapping[str, Any] | None = None,
        member_ids: Sequence[Any] | None = None,
    ) -> None:
        _check_input_types(signals, conditions)
        if isinstance(conditions, pd.DataFrame):
            conditions, member_ids = _ids_from_frame(conditions, member_ids)
        n, member_ids = _member_count(signals, conditions, member_ids)
        if member_ids is None:
            ids = [f"m{i:05d}" for i in range(n)]
        else:
            ids = [str(m) for m in member_ids]
        index = pd.Index(ids, name=MEMBER, dtype=str)
        if index.has_duplicates:
            dup = index[index.duplicated()].unique().tolist()
            raise DataError(f"member ids must be unique; repeated: {_names_list(dup)}")

        converted = {
            name: _convert_signal(name, value, ids) for name, value in signals.items()
        }
        rates = self._rates(fs, list(signals))

        if conditions is None:
            table = pd.DataFrame(index=index)
        elif isinstance(conditions, pd.DataFrame):
            table = conditions.set_axis(index, axis=0)
        else:
            columns = {k: _column_values(v, n, k) for k, v in conditions.items()}
            table = pd.DataFrame(columns, index=pd.RangeIndex(n)).set_axis(index, axis=0)
        self._check_columns(table.columns, converted)
        self._signals: dict[str, SignalList] = converted
        self._fs: dict[str, float] = rates
        self._conditions: pd.DataFrame = table

    # ---------------------------------------------------------------- construction
    @staticmethod
    def _rates(fs: Any, names: Sequence[str]) -> dict[str, float]:
        if isinstance(fs, Mapping):
            unknown = [k for k in fs if k not in names]
            if unknown:
                raise DataError(
                    f"fs names signal(s) {_names_list(unknown)} that the ensemble does not "
                    f"have; signals: {_names_list(names, 20)}"
                )
            missing = [k for k in names if k not in fs]
            if missing:
                raise DataError(
                    f"fs gives no sampling rate for signal(s) {_names_list(missing)}; give "
                    "one rate per signal or a single float for all"
                )
            return {k: check_fs(fs[k], f"fs of signal {k!r}") for k in names}
        rate = check_fs(fs, "fs")
        return dict.fromkeys(names, rate)

    @staticmethod
    def _check_columns(columns: pd.Index, signals: Mapping[str, Any]) -> None:
        for c in columns:
            if not isinstance(c, str):
                raise DataError(f"condition column names must be strings; got {c!r}")
            if c == MEMBER:
                raise DataError(
                    f"condition column {MEMBER!r} is reserved for the member ids; rename it"
                )
            if c in signals:
                raise DataError(
                    f"condition column {c!r} has the name of a signal; rename one of them"
                )

    @classmethod
    def _new(
        cls, signals: dict[str, SignalList], fs: dict[str, float], conditions: pd.DataFrame
    ) -> Ensemble:
        """Build from already validated parts (no copies, no checks)."""
        obj = cls.__new__(cls)
        obj._signals = signals
        obj._fs = fs
        obj._conditions = conditions
        return obj

    # ---------------------------------------------------------------- properties
    @property
    def member_ids(self) -> pd.Index:
        """Member ids, a pandas Index of str named ``"member"``.

        Examples
        --------
        >>> ens = Ensemble({"x": np.zeros((2, 4))}, fs=1.0, member_ids=["a", "b"])
        >>> ens.member_ids.tolist()
        ['a', 'b']
        """
        return self._conditions.index

    @property
    def conditions(self) -> pd.DataFrame:
        """Condition variables, one row per member, indexed by member id (a copy).

        Examples
        --------
        >>> ens = Ensemble({"x": np.zeros((2, 4))}, fs=1.0, conditions={"k": [1, 2]})
        >>> ens.conditions  # doctest: +NORMALIZE_WHITESPACE
                k
        member
        m00000  1
        m00001  2
        """
        return self._conditions.copy(deep=False)

    @property
    def signal_names(self) -> list[str]:
        """Names of the signals, in the order they were given.

        Examples
        --------
        >>> Ensemble({"a": np.zeros((1, 2)), "b": [None]}, fs=1.0).signal_names
        ['a', 'b']
        """
        return list(self._signals)

    @property
    def fs(self) -> dict[str, float]:
        """Sampling rate in Hz of each signal.

        Examples
        --------
        >>> Ensemble({"a": np.zeros((1, 2))}, fs=100).fs
        {'a': 100.0}
        """
        return dict(self._fs)

    def __len__(self) -> int:
        return len(self._conditions)

    def __repr__(self) -> str:
        n = len(self)
        parts = []
        for name, xs in self._signals.items():
            have = sum(x is not None for x in xs)
            share = "" if have == n else f", {have}/{n} members"
            parts.append(f"{name} @ {self._fs[name]:g} Hz{share}")
        cols = list(self._conditions.columns)
        shown = ", ".join(map(str, cols[:8])) + (", ..." if len(cols) > 8 else "")
        return (
            f"Ensemble({n} member{'s' if n != 1 else ''}; signals: "
            f"{'; '.join(parts) or 'none'}; conditions: {shown or 'none'})"
        )

    # ---------------------------------------------------------------- access
    def _check_signal(self, name: str) -> SignalList:
        try:
            return self._signals[name]
        except (KeyError, TypeError):
            raise DataError(
                f"the ensemble has no signal {name!r}; signals: "
                f"{_names_list(list(self._signals), 20) or 'none'}"
            ) from None

    def _select_names(self, signals: str | Sequence[str] | None) -> list[str]:
        if signals is None:
            return list(self._signals)
        names = [signals] if isinstance(signals, str) else list(signals)
        for s in names:
            self._check_signal(s)
        if len(set(names)) != len(names):
            raise DataError(f"signals lists a name twice: {names}")
        return names

    def _lengths(self, name: str) -> np.ndarray:
        """Samples per member (-1 where missing)."""
        xs = self._signals[name]
        return np.fromiter((-1 if x is None else len(x) for x in xs), np.int64, len(xs))

    def signal(self, name: str) -> list[np.ndarray | None]:
        """Return one signal of every member: a read-only float64 1-D array or None.

        Examples
        --------
        >>> ens = Ensemble({"x": [np.arange(3.0), None]}, fs=1.0)
        >>> ens.signal("x")
        [array([0., 1., 2.]), None]
        """
        return list(self._check_signal(name))

    def has_signal(self, name: str) -> np.ndarray:
        """Boolean mask over members: which ones have the signal.

        Examples
        --------
        >>> Ensemble({"x": [np.ones(3), None]}, fs=1.0).has_signal("x")
        array([ True, False])
        """
        return np.array([x is not None for x in self._check_signal(name)], dtype=bool)

    def stack(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """Stack a signal of equal length into a 2-D array.

        Returns
        -------
        data : numpy.ndarray
            ``(n_present, n_samples)`` float64 (a new, writable array) for the members
            that have the signal, in member order; shape ``(0, 0)`` when none has it.
        mask : numpy.ndarray
            Boolean mask over all members: which rows of ``data`` they are.

        Raises
        ------
        pdmkit.errors.DataError
            When members have different lengths (the message names them).

        Examples
        --------
        >>> ens = Ensemble({"x": [np.ones(4), None, np.zeros(4)]}, fs=1.0)
        >>> data, mask = ens.stack("x")
        >>> data.shape, mask.tolist()
        ((2, 4), [True, False, True])
        """
        xs = self._check_signal(name)
        mask = np.array([x is not None for x in xs], dtype=bool)
        present = [x for x in xs if x is not None]
        if not present:
            return np.empty((0, 0)), mask
        lengths = self._lengths(name)[mask]
        if (lengths != lengths[0]).any():
            ids = self.member_ids[mask]
            values, first, counts = np.unique(
                lengths, return_index=True, return_counts=True
            )
            desc = ", ".join(
                f"{v} samples ({c} member{'s' if c > 1 else ''}, e.g. {ids[i]!r})"
                for v, i, c in list(zip(values, first, counts, strict=True))[:_SHOW]
            )
            raise DataError(
                f"signal {name!r} has members of {len(values)} different lengths: {desc}; "
                "cut them to one length with frames(length) or select members of one length"
            )
        return np.stack(present), mask

    def with_conditions(self, **columns: Any) -> Ensemble:
        """Return a copy with condition columns added or replaced.

        Each value is a scalar (broadcast) or one value per member; a pandas Series
        whose index holds the member ids is aligned by id, any other sequence by order.

        Examples
        --------
        >>> ens = Ensemble({"x": np.zeros((2, 3))}, fs=1.0)
        >>> ens.with_conditions(label=["a", "b"], rpm=1797).conditions.to_dict("list")
        {'label': ['a', 'b'], 'rpm': [1797, 1797]}
        """
        table = self._conditions.copy(deep=False)
        n = len(self)
        ids = self.member_ids
        for name, value in columns.items():
            self._check_columns(pd.Index([name]), self._signals)
            if isinstance(value, pd.Series) and not value.index.equals(ids):
                if len(value) == n and set(value.index) == set(ids):
                    value = value.reindex(ids)
            value = _column_values(value, n, name)
            if isinstance(value, pd.Series):
                value = value.set_axis(table.index)
            table[name] = value
        return Ensemble._new(dict(self._signals), dict(self._fs), table)

    # ---------------------------------------------------------------- combining, I/O
    @staticmethod
    def concat(
        ensembles: Iterable[Ensemble], *, keys: Sequence[str] | None = None
    ) -> Ensemble:
        """Stack the members of several ensembles into one.

        Signals are united (a member of an ensemble without a signal gets None);
        a signal must have the same rate everywhere. Condition columns are united as
        :func:`pandas.concat` does (missing values become NaN).

        Parameters
        ----------
        ensembles : iterable of Ensemble
        keys : sequence of str, optional
            One prefix per ensemble; member ids become ``"<key>/<id>"`` (use it when
            ids repeat across the ensembles).

        Examples
        --------
        >>> a = Ensemble({"x": np.zeros((2, 3))}, fs=1.0, conditions={"run": 1})
        >>> b = Ensemble({"y": np.ones((1, 3))}, fs=1.0, conditions={"run": 2})
        >>> both = Ensemble.concat([a, b], keys=["a", "b"])
        >>> both.member_ids.tolist(), both.has_signal("y").tolist()
        (['a/m00000', 'a/m00001', 'b/m00000'], [False, False, True])
        """
        items = list(ensembles)
        if not items:
            raise DataError("concat needs at least one ensemble")
        for e in items:
            if not isinstance(e, Ensemble):
                raise DataError(f"concat takes Ensemble objects; got {type(e).__name__}")
        if keys is not None:
            keys = [str(k) for k in keys]
            if len(keys) != len(items):
                raise DataError(f"concat got {len(keys)} keys for {len(items)} ensembles")
        fs: dict[str, float] = {}
        for e in items:
            for s, rate in e._fs.items():
                if fs.setdefault(s, rate) != rate:
                    raise DataError(
                        f"signal {s!r} is sampled at {fs[s]:g} Hz in one ensemble and at "
                        f"{rate:g} Hz in another; resample() them to one rate first"
                    )
        signals: dict[str, SignalList] = {}
        for s in fs:
            signals[s] = [x for e in items for x in e._signals.get(s, [None] * len(e))]
        tables = []
        for i, e in enumerate(items):
            t = e._conditions
            if keys is not None:
                t = t.set_axis(pd.Index([f"{keys[i]}/{m}" for m in t.index], dtype=str))
            tables.append(t)
        table = pd.concat(tables, axis=0) if tables else pd.DataFrame()
        table.index = pd.Index(table.index, name=MEMBER, dtype=str)
        if table.index.has_duplicates:
            dup = table.index[table.index.duplicated()].unique().tolist()
            raise DataError(
                f"member ids repeat across the ensembles: {_names_list(dup)}; pass "
                "keys=[...] to prefix each ensemble's ids"
            )
        return Ensemble._new(signals, fs, table)

    def to_pandas(self) -> pd.DataFrame:
        """Conditions plus one column per signal holding its length (NaN where missing).

        Examples
        --------
        >>> ens = Ensemble({"x": [np.ones(4), None]}, fs=1.0, conditions={"k": [1, 2]})
        >>> ens.to_pandas()  # doctest: +NORMALIZE_WHITESPACE
                k    x
        member
        m00000  1  4.0
        m00001  2  NaN
        """
        table = self._conditions.copy()
        for s in self._signals:
            lens = self._lengths(s).astype(np.float64)
            lens[lens < 0] = np.nan
            table[s] = lens
        return table

    def to_parquet(self, path: str | os.PathLike, *, members_per_file: int = 256) -> Path:
        """Write the ensemble as a pdmkit Parquet dataset (a directory).

        See :func:`pdmkit.ensembles.iter_parquet` for the layout.

        The directory is written beside ``path`` under a temporary name and swapped in
        when complete: a crash never leaves a half-written dataset, and an existing
        dataset at ``path`` stays intact until the new one is complete. ``path`` may
        be missing, an empty directory or a pdmkit ensemble; anything else is refused.

        Parameters
        ----------
        path : str or path-like
            Target directory.
        members_per_file : int, default 256
            Members per ``part-NNNNN.parquet`` file.

        Returns
        -------
        pathlib.Path

        Examples
        --------
        >>> import tempfile, pathlib
        >>> ens = Ensemble({"x": np.arange(6.0).reshape(3, 2)}, fs=10.0,
        ...                conditions={"k": [1, 2, 3]})
        >>> target = pathlib.Path(tempfile.mkdtemp()) / "ens"
        >>> path = ens.to_parquet(target, members_per_file=2)
        >>> sorted(p.name for p in path.iterdir())
        ['_pdmkit_ensemble.json', 'part-00000.parquet', 'part-00001.parquet']
        >>> Ensemble.from_parquet(path).signal("x")[2]
        array([4., 5.])
        """
        return write_parquet(self, path, members_per_file=members_per_file)

    @classmethod
    def from_parquet(
        cls,
        path: str | os.PathLike,
        *,
        signals: str | Sequence[str] | None = None,
        columns: Sequence[str] | None = None,
    ) -> Ensemble:
        """Read a pdmkit Parquet dataset written by :meth:`to_parquet`.

        Parameters
        ----------
        path : str or path-like
            The dataset directory.
        signals : str or sequence of str, optional
            Signals to read (default: all).
        columns : sequence of str, optional
            Condition columns to read (default: all).

        Examples
        --------
        >>> import tempfile, pathlib
        >>> ens = Ensemble({"x": np.ones((2, 3)), "y": np.zeros((2, 5))}, fs=1.0)
        >>> path = ens.to_parquet(pathlib.Path(tempfile.mkdtemp()) / "ens")
        >>> Ensemble.from_parquet(path, signals=["y"]).signal_names
        ['y']
        """
        manifest, sigs, cols, tables = read_parts(path, signals, columns)
        parts = [
            _table_to_ensemble(table, manifest, sigs, cols, str(file))
            for table, file in tables
        ]
        if len(parts) == 1:
            return parts[0]
        return Ensemble.concat(parts)


def _table_to_ensemble(
    table: Any, manifest: dict[str, Any], signals: list[str], columns: list[str], where: str
) -> Ensemble:
    """The members of a pyarrow table of a pdmkit Parquet dataset as an Ensemble.

    A non-finite sample is a DataError naming ``where``, the member and the signal.
    """
    ids = table.column(MEMBER).to_pylist()
    conditions = table.select(columns).to_pandas() if columns else pd.DataFrame(index=ids)
    arrays, all_finite = {}, True
    for s in signals:
        arrays[s], finite = _lists_to_arrays(table.column(s))
        all_finite &= finite
    fs = {s: float(manifest["fs"][s]) for s in signals}
    if not all_finite:
        try:  # the full check names the member and the signal
            Ensemble(
                arrays, fs, conditions=conditions.reset_index(drop=True), member_ids=ids
            )
        except DataError as exc:
            raise DataError(f"{where}: {exc}") from None
    conditions.index = pd.Index(ids, name=MEMBER, dtype=str)
    return Ensemble._new(arrays, fs, conditions)
