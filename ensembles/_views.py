"""Views of an ensemble: members selected, cut into frames, or resampled.

:class:`_EnsembleViews` holds the methods of :class:`~pdmkit.ensembles.Ensemble` that
return another ensemble over the same arrays (read-only views, no copies, except
where resampling computes new samples): ``select``, ``batches``, ``frames`` and
``resample``.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from pdmkit._checks import check_fs, check_int
from pdmkit.ensembles._signals import (
    _RESAMPLE_BLOCK,
    _SHOW,
    MEMBER,
    SignalList,
    _names_list,
    _readonly,
    resample_poly_1d,
    resample_ratio,
)
from pdmkit.errors import DataError

if TYPE_CHECKING:
    from typing import Self  # Python 3.11+; only read by type checkers here

__all__: list[str] = []


class _EnsembleViews:
    """The selecting, framing and resampling methods of an :class:`Ensemble`.

    A base class of ``Ensemble`` only: it uses the ensemble's ``_signals``, ``_fs``,
    ``_conditions``, ``_new``, ``_lengths``, ``_select_names`` and ``member_ids``.
    """

    __slots__ = ()

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

    def _take(self, pos: np.ndarray) -> Self:
        signals = {k: [xs[i] for i in pos] for k, xs in self._signals.items()}
        return self._new(signals, dict(self._fs), self._conditions.iloc[pos])

    def select(self, which: Any) -> Self:
        """Return the members picked by a boolean mask, ids, positions, a slice or an int.

        Examples
        --------
        >>> from pdmkit.ensembles import Ensemble
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

    def batches(self, size: int) -> Iterator[Self]:
        """Yield consecutive ensembles of at most ``size`` members.

        Examples
        --------
        >>> from pdmkit.ensembles import Ensemble
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
    ) -> Self:
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
        >>> from pdmkit.ensembles import Ensemble
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
        return self._new(out, {s: self._fs[s] for s in names}, table)

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
    ) -> Self:
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
        >>> from pdmkit.ensembles import Ensemble
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
        return self._new(new_signals, new_fs, self._conditions)

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
