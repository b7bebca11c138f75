"""The in-memory ensemble: members with named signals and condition variables."""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator, Mapping, Sequence
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pdmkit._checks import check_fs, check_int
from pdmkit.errors import DataError

__all__ = ["Ensemble"]

MEMBER = "member"
"""Name of the member-id index (and of the id column on disk)."""

_SHOW = 5  # how many offending members an error message names
_RESAMPLE_BLOCK = 1 << 24  # samples resampled in one vectorised call (128 MiB of float64)

SignalList = list  # list[np.ndarray | None], one entry per member


# --------------------------------------------------------------------------------------
# small helpers shared by the ensemble, the Parquet store and the loaders
# --------------------------------------------------------------------------------------


def _names_list(items: Sequence[Any], limit: int = _SHOW) -> str:
    shown = ", ".join(repr(x) for x in list(items)[:limit])
    more = len(items) - limit
    return shown + (f" and {more} more" if more > 0 else "")


def _readonly(a: np.ndarray) -> np.ndarray:
    if a.flags.writeable:
        a = a.view()
        a.flags.writeable = False
    return a


def resample_ratio(fs_from: float, fs_to: float, what: str = "signal") -> tuple[int, int]:
    """Return ``(up, down)`` with ``fs_to / fs_from == up / down`` in small integers.

    Examples
    --------
    >>> resample_ratio(48000.0, 12000.0)
    (1, 4)
    """
    exact = Fraction(fs_to) / Fraction(fs_from)
    ratio = exact.limit_denominator(10_000)
    if abs(float(ratio) - fs_to / fs_from) > 1e-9 * (fs_to / fs_from):
        raise DataError(
            f"cannot resample {what} from {fs_from:g} Hz to {fs_to:g} Hz: the ratio is not "
            "a fraction of integers below 10000; choose a target rate with a simpler ratio"
        )
    return ratio.numerator, ratio.denominator


def resample_poly_1d(x: np.ndarray, up: int, down: int) -> np.ndarray:
    """Polyphase-resample the last axis of ``x`` by ``up / down`` (scipy defaults).

    Examples
    --------
    >>> resample_poly_1d(np.ones(8), 1, 2).shape
    (4,)
    """
    from scipy.signal import resample_poly

    if up == down:
        return np.asarray(x, dtype=np.float64)
    return resample_poly(np.asarray(x, dtype=np.float64), up, down, axis=-1)


def _as_float(x: Any, signal: str, member: str | None) -> np.ndarray:
    where = f"signal {signal!r}" + (f" of member {member!r}" if member is not None else "")
    try:
        a = np.asarray(x)
    except (ValueError, TypeError) as exc:
        raise DataError(f"{where} is not a numeric array ({exc})") from None
    if a.dtype.kind == "c":
        raise DataError(
            f"{where} holds complex values; store real and imaginary parts as two signals"
        )
    if a.dtype.kind not in "biuf":
        raise DataError(
            f"{where} holds values of dtype {a.dtype}; expected numbers (float samples)"
        )
    return a.astype(np.float64, copy=False)


def _nonfinite_error(signal: str, member: str, x: np.ndarray, others: int = 0) -> DataError:
    bad = ~np.isfinite(x)
    first = int(np.argmax(bad))
    more = f" ({others} other member(s) too)" if others else ""
    return DataError(
        f"signal {signal!r} of member {member!r} holds {int(bad.sum())} non-finite "
        f"value(s) (first at sample {first}){more}; clean or drop the member"
    )


def _convert_signal(name: Any, value: Any, ids: Sequence[str]) -> SignalList:
    """Validate one signal (2-D array or per-member sequence) into a list of 1-D arrays."""
    n = len(ids)
    if isinstance(value, pd.DataFrame):
        value = value.to_numpy()
    if isinstance(value, np.ndarray) and value.dtype != object:
        if value.ndim != 2:
            raise DataError(
                f"signal {name!r} must be a 2-D array (n_members, n_samples) or a sequence "
                f"of one 1-D array (or None) per member; got an array of shape "
                f"{value.shape}. Wrap a single recording in a list: {{{name!r}: [x]}}"
            )
        a = _as_float(value, name, None)
        if a.shape[1] == 0:
            raise DataError(f"signal {name!r} has no samples (shape {a.shape})")
        finite = np.isfinite(a).all(axis=1)
        if not finite.all():
            rows = np.flatnonzero(~finite)
            raise _nonfinite_error(name, ids[rows[0]], a[rows[0]], len(rows) - 1)
        return list(_readonly(a))
    if isinstance(value, str | bytes) or not isinstance(value, Iterable):
        raise DataError(
            f"signal {name!r} must be a 2-D array or a sequence of 1-D arrays (None where "
            f"a member lacks it); got {type(value).__name__}"
        )
    seq = list(value)
    if len(seq) != n:
        raise DataError(
            f"signal {name!r} has {len(seq)} entries; expected one per member ({n})"
        )
    out: SignalList = []
    for member, x in zip(ids, seq, strict=True):
        if x is None:
            out.append(None)
            continue
        a = _as_float(x, name, member)
        if a.ndim != 1:
            raise DataError(
                f"signal {name!r} of member {member!r} must be 1-D; got shape {a.shape}. "
                "Flatten it (np.ravel) or pass None when the member lacks the signal"
            )
        if a.size == 0:
            raise DataError(
                f"signal {name!r} of member {member!r} has no samples; pass None when the "
                "member lacks the signal"
            )
        if not np.isfinite(a).all():
            raise _nonfinite_error(name, member, a)
        out.append(_readonly(a))
    return out


def _column_values(value: Any, n: int, column: Any) -> Any:
    """Column values for a conditions table of ``n`` rows (scalars broadcast)."""
    if isinstance(value, pd.Series | pd.Index):
        value = pd.Series(value).reset_index(drop=True)
    elif np.ndim(value) == 0:
        return value
    if len(value) != n:
        raise DataError(
            f"condition column {column!r} has {len(value)} values; expected one per "
            f"member ({n})"
        )
    return value


def _n_rows(conditions: Any) -> int | None:
    if conditions is None:
        return None
    if isinstance(conditions, pd.DataFrame):
        return len(conditions)
    lengths = {len(v) for v in conditions.values() if np.ndim(v) != 0}
    if len(lengths) > 1:
        raise DataError(
            f"condition columns have different lengths {sorted(lengths)}; give one value "
            "per member in every column (or a scalar)"
        )
    return lengths.pop() if lengths else None


# --------------------------------------------------------------------------------------
# the ensemble
# --------------------------------------------------------------------------------------


class Ensemble:
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

    def __init__(  # noqa: C901
        self,
        signals: Mapping[str, Any],
        fs: float | Mapping[str, float],
        conditions: pd.DataFrame | Mapping[str, Any] | None = None,
        member_ids: Sequence[Any] | None = None,
    ) -> None:
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
        if isinstance(conditions, pd.DataFrame):
            conditions = conditions.copy(deep=False)
            if member_ids is None and conditions.index.name == MEMBER:
                member_ids = list(conditions.index)
            if MEMBER in conditions.columns and member_ids is None:
                member_ids = list(conditions[MEMBER])
                conditions = conditions.drop(columns=MEMBER)
            conditions = conditions.reset_index(drop=True)

        # how many members: every source that knows must agree
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
        n = next(iter(counts.values()), 0)

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

    # ---------------------------------------------------------------- selection
    def _positions(self, which: Any) -> np.ndarray:
        n = len(self)
        if isinstance(which, slice):
            return np.arange(n)[which]
        if isinstance(which, int | np.integer) and not isinstance(which, bool | np.bool_):
            if not -n <= which < n:
                raise DataError(f"member position {which} is out of range for {n} members")
            return np.array([which % n])
        if isinstance(which, str):
            which = [which]
        if isinstance(which, pd.Series | pd.Index):
            which = which.to_numpy()
        arr = np.asarray(which)
        if arr.ndim != 1:
            raise DataError(f"select expects a 1-D selection; got shape {arr.shape}")
        if arr.dtype == bool:
            if len(arr) != n:
                raise DataError(
                    f"boolean selection has {len(arr)} entries; expected one per member "
                    f"({n})"
                )
            return np.flatnonzero(arr)
        if arr.size == 0:
            return np.empty(0, dtype=np.int64)
        if arr.dtype.kind in "iu":
            bad = arr[(arr < -n) | (arr >= n)]
            if bad.size:
                raise DataError(
                    f"member positions {_names_list(bad.tolist())} are out of range for "
                    f"{n} members"
                )
            return arr.astype(np.int64) % max(n, 1)
        if arr.dtype.kind in "UO" or isinstance(arr.dtype, pd.StringDtype):
            pos = self.member_ids.get_indexer(pd.Index(arr.astype(str)))
            if (pos < 0).any():
                missing = arr[pos < 0].tolist()
                raise DataError(
                    f"no member with id(s) {_names_list(missing)}; ids look like "
                    f"{_names_list(self.member_ids[:3].tolist(), 3)}"
                )
            return pos.astype(np.int64)
        raise DataError(
            "select takes a boolean mask, member ids, integer positions, a slice or an "
            f"int; got an array of dtype {arr.dtype}"
        )

    def _take(self, pos: np.ndarray) -> Ensemble:
        signals = {k: [xs[i] for i in pos] for k, xs in self._signals.items()}
        return Ensemble._new(signals, dict(self._fs), self._conditions.iloc[pos])

    def select(self, which: Any) -> Ensemble:
        """Return the members picked by a boolean mask, ids, positions, a slice or an int.

        Examples
        --------
        >>> ens = Ensemble({"x": np.arange(6.0).reshape(3, 2)}, fs=1.0,
        ...                member_ids=list("abc"))
        >>> ens.select(["c", "a"]).member_ids.tolist()
        ['c', 'a']
        >>> ens.select(np.array([True, False, True])).member_ids.tolist()
        ['a', 'c']
        >>> ens.select(slice(1, None)).member_ids.tolist(), len(ens.select(0))
        (['b', 'c'], 1)
        """
        return self._take(self._positions(which))

    def batches(self, size: int) -> Iterator[Ensemble]:
        """Yield consecutive ensembles of at most ``size`` members.

        Examples
        --------
        >>> ens = Ensemble({"x": np.zeros((5, 2))}, fs=1.0)
        >>> [len(b) for b in ens.batches(2)]
        [2, 2, 1]
        """
        size = check_int(size, "size")
        for start in range(0, len(self), size):
            yield self._take(np.arange(start, min(start + size, len(self))))

    # ---------------------------------------------------------------- transforms
    def frames(
        self,
        length: int,
        *,
        hop: int | None = None,
        signals: str | Sequence[str] | None = None,
    ) -> Ensemble:
        """Cut every member into frames of equal duration.

        ``length`` and ``hop`` count samples of the *reference* signal, the first of
        ``signals`` (default: the first signal). Every other signal is cut over the same
        time span: ``length * fs_signal / fs_reference`` samples, which must be a whole
        number. Frame ``k`` of a member starts at ``k * hop / fs_reference`` seconds in
        every signal; a member gives as many frames as its shortest signal allows
        (trailing samples are dropped). Frames are read-only views (no copies).

        Parameters
        ----------
        length : int
            Frame length in samples of the reference signal.
        hop : int, optional
            Distance between frame starts; default ``length`` (no overlap).
        signals : str or sequence of str, optional
            Signals to keep and cut; the others are dropped. Default: all.

        Returns
        -------
        Ensemble
            One member per frame, id ``"<member>/f<k:04d>"``; the conditions of its
            source member plus ``source_member`` (str) and ``frame`` (int, from 0).

        Raises
        ------
        pdmkit.errors.DataError
            Members shorter than one frame (named with their lengths), members with
            none of the signals, or a length that is no whole number of samples of a
            signal at another rate.

        Examples
        --------
        >>> ens = Ensemble(
        ...     {"fast": [np.arange(10.0)], "slow": [np.arange(5.0)]},
        ...     fs={"fast": 10.0, "slow": 5.0},
        ...     conditions={"label": ["ok"]},
        ... )
        >>> fr = ens.frames(4)
        >>> fr.member_ids.tolist()
        ['m00000/f0000', 'm00000/f0001']
        >>> fr.signal("slow")[1]
        array([2., 3.])
        >>> fr.conditions[["label", "source_member", "frame"]].to_dict("list")
        {'label': ['ok', 'ok'], 'source_member': ['m00000', 'm00000'], 'frame': [0, 1]}
        """
        names = self._select_names(signals)
        if not names:
            raise DataError("frames needs at least one signal; the ensemble has none")
        length = check_int(length, "length")
        hop = length if hop is None else check_int(hop, "hop")
        ref = names[0]
        fs_ref = self._fs[ref]
        win = {s: self._scaled(length, s, ref, "length") for s in names}
        step = {s: self._scaled(hop, s, ref, "hop") for s in names}

        n = len(self)
        big = np.iinfo(np.int64).max
        counts = np.full(n, big, dtype=np.int64)
        have_any = np.zeros(n, dtype=bool)
        for s in names:
            lens = self._lengths(s)
            has = lens >= 0
            counts = np.minimum(counts, np.where(has, (lens - win[s]) // step[s] + 1, big))
            have_any |= has
        ids = self.member_ids
        if not have_any.all():
            raise DataError(
                f"member(s) {_names_list(ids[~have_any].tolist())} have none of the "
                f"signals {names}; drop them with select() before framing"
            )
        short = counts < 1
        if short.any():
            detail = []
            for i in np.flatnonzero(short)[:_SHOW]:
                lens = ", ".join(
                    f"{s!r} {len(self._signals[s][i])}"
                    for s in names
                    if self._signals[s][i] is not None
                )
                detail.append(f"{ids[i]!r} ({lens} samples)")
            more = int(short.sum()) - len(detail)
            raise DataError(
                f"{int(short.sum())} member(s) are shorter than one frame of {length} "
                f"samples of {ref!r} ({length / fs_ref:g} s): {', '.join(detail)}"
                f"{f' and {more} more' if more > 0 else ''}; drop them with select() or "
                "choose a shorter length"
            )

        out: dict[str, SignalList] = {}
        for s in names:
            frames: SignalList = []
            w, h = win[s], step[s]
            for x, c in zip(self._signals[s], counts, strict=True):
                if x is None:
                    frames.extend([None] * int(c))
                else:
                    view = np.lib.stride_tricks.sliding_window_view(x, w)
                    frames.extend(view[: (c - 1) * h + 1 : h])
            out[s] = frames

        rep = np.repeat(np.arange(n), counts)
        frame_no = np.arange(rep.size) - np.repeat(np.cumsum(counts) - counts, counts)
        source = ids.to_numpy()[rep]
        new_ids = [f"{m}/f{k:04d}" for m, k in zip(source, frame_no, strict=True)]
        table = self._conditions.iloc[rep].copy()
        table["source_member"] = pd.array(source, dtype=ids.dtype)
        table["frame"] = frame_no
        table.index = pd.Index(new_ids, name=MEMBER, dtype=str)
        return Ensemble._new(out, {s: self._fs[s] for s in names}, table)

    def _scaled(self, count: int, signal: str, ref: str, what: str) -> int:
        """``count`` samples of ``ref`` as a whole number of samples of ``signal``."""
        up, down = resample_ratio(self._fs[ref], self._fs[signal], f"signal {signal!r}")
        if (count * up) % down:
            raise DataError(
                f"a frame {what} of {count} samples of {ref!r} ({self._fs[ref]:g} Hz) is "
                f"{count * up / down:g} samples of {signal!r} ({self._fs[signal]:g} Hz), "
                f"not a whole number; choose a {what} that is a multiple of {down}"
            )
        return count * up // down

    def resample(
        self, fs: float | Mapping[str, float], *, signals: str | Sequence[str] | None = None
    ) -> Ensemble:
        """Bring signals to a new sampling rate (polyphase, ``scipy.signal.resample_poly``).

        Each chosen signal whose rate differs from the target is resampled by the exact
        ratio ``fs_new / fs_old = up / down`` with scipy's default Kaiser anti-aliasing
        filter; a member of ``n`` samples gets ``ceil(n * up / down)``. Members of equal
        length are resampled together in one vectorised call.

        Parameters
        ----------
        fs : float or mapping of str to float
            Target rate in Hz for every chosen signal, or per signal.
        signals : str or sequence of str, optional
            Signals to resample (default: all, or the keys of a mapping ``fs``); the
            others are kept unchanged.

        Examples
        --------
        >>> ens = Ensemble({"x": np.ones((2, 48)), "y": np.ones((2, 12))},
        ...                fs={"x": 48.0, "y": 12.0})
        >>> out = ens.resample(12.0)
        >>> out.fs, out.stack("x")[0].shape
        ({'x': 12.0, 'y': 12.0}, (2, 12))
        """
        if isinstance(fs, Mapping):
            self._select_names(list(fs))  # every key names a signal
            names = self._select_names(list(fs) if signals is None else signals)
            missing = [s for s in names if s not in fs]
            if missing:
                raise DataError(
                    f"fs gives no target rate for signal(s) {_names_list(missing)}; add "
                    "them to the mapping or leave them out of signals"
                )
            target = {s: check_fs(fs[s], f"fs of signal {s!r}") for s in names}
        else:
            names = self._select_names(signals)
            target = dict.fromkeys(names, check_fs(fs, "fs"))
        new_signals = dict(self._signals)
        new_fs = dict(self._fs)
        for s in names:
            if target[s] == self._fs[s]:
                continue
            up, down = resample_ratio(self._fs[s], target[s], f"signal {s!r}")
            new_signals[s] = self._resample_list(
                self._signals[s], self._lengths(s), up, down
            )
            new_fs[s] = target[s]
        return Ensemble._new(new_signals, new_fs, self._conditions)

    @staticmethod
    def _resample_list(xs: SignalList, lens: np.ndarray, up: int, down: int) -> SignalList:
        out: SignalList = [None] * len(xs)
        for length in np.unique(lens[lens >= 0]):
            idx = np.flatnonzero(lens == length)
            per_block = max(1, _RESAMPLE_BLOCK // int(length))
            for start in range(0, idx.size, per_block):
                chunk = idx[start : start + per_block]
                block = resample_poly_1d(np.stack([xs[i] for i in chunk]), up, down)
                for row, i in zip(_readonly(block), chunk, strict=True):
                    out[i] = row
        return out

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
        from pdmkit.ensembles._parquet import write_parquet

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
        from pdmkit.ensembles._parquet import read_parquet

        return read_parquet(path, signals=signals, columns=columns)
