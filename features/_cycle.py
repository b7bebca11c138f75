"""Condition indicators of cyclic machines (group ``"cycle"``).

A press, a pneumatic cylinder or a pick-and-place axis repeats the same motion every
cycle, commanded by a controller that knows the cycle period and when each cycle starts.
Statistics of a whole recording mix the few milliseconds in which most faults show (an
end-of-stroke impact, a slower stroke, a damper that no longer brakes) with seconds of
standstill; the indicators here cut the recording into its cycles first and describe
each part of the cycle on its own (McFadden, "A revised model for the extraction of
periodic waveforms by time domain averaging", MSSP 1987, for the synchronous average;
the stroke measures follow the transition and pulse terms of IEEE Std 181: reference
levels, transition times at fractions of the way between them, overshoot, settling).

Each cycle of length ``period`` starting at ``start + c * period`` is split into
*segments* at the fractions ``phases`` of the period (default ``(0.0, 0.5)``: the first
and the second half, e.g. the up and the down stroke of a cylinder driven by a square
command). For every complete segment in the recording the indicators below are
computed, then the median over the segments of the recording is reported (robust to a
first stroke from rest or one disturbed cycle). Times are measured from the nominal
start of the segment (sub-sample exact) in s; levels and rates are in the signal's unit
(per second for rates).

Transition indicators. ``Start`` is the mean over the 2 % of a segment's length just
before it begins (where the machine rests before the command; the segment's own first
samples for a segment at the very start of the recording), ``End`` the mean of its last
2 %, and the *extreme* the sample farthest from ``Start``. A segment whose End lies at
least half as far from Start as its extreme is a *step* (position, pressure, force) and
its *target* is End; otherwise it is a *pulse* (speed, an impact) and its target is the
extreme. The signal is followed from Start towards the target, so the indicators do not
depend on the direction of the stroke:

=================  ==============================================================
Start, End         level before and at the end of the segment
T<l>               first time the signal has covered the fraction ``l`` of the
                   way from Start to the target (``T50``: half-way; ``T99p5``:
                   99.5 %), linearly interpolated between samples; the segment
                   length when it never gets there
Rate<l>            rate of change towards the target between the two samples
                   around that crossing (for a position: the speed on passing
                   that point)
Drop<l1>_<l2>      ``Rate<l1> - Rate<l2>``: speed lost between two points (what an
                   end damper takes out)
PeakRate           largest rate of change towards the target
Overshoot          how far a step's extreme lies beyond End (0 for a plain step
                   and for a pulse)
Rebound            after the last level is first reached, the largest fall back
                   from the highest level reached so far (a bounce)
Fall50, Fall90     time from the extreme until the signal has come back half /
                   90 % of the way to End (a speed braked to standstill, a ring
                   dying down), interpolated; the rest of the segment if it never
                   does
Settle             time after which the signal stays within 2 % of the excursion
                   (``|extreme - Start|``) of End
=================  ==============================================================

Event indicators, for impulsive signals (acceleration, sound, strain) on the deviation
``e = x - End`` from the segment's final level:

=================  ==============================================================
Peak, PeakTime     ``max |e|`` and when it occurs
Energy             ``sum(e**2) / fs`` over the segment
Decay              time from the peak until ``|e|`` last exceeds 10 % of the peak
EventRMS<k>        RMS of ``e`` in the k-th window of ``event_windows`` (s, relative
                   to the peak: before it, the approach; after it, the ring-down)
=================  ==============================================================

Phase-window indicators of the whole cycle (``n_windows`` equal windows):
``W<k>_Mean`` is the cycle-synchronous average (:func:`cycle_average`) averaged over
window ``k``; ``W<k>_Std`` the median over cycles of the standard deviation inside it.

Column names: ``S<j>_<indicator>`` for segment ``j`` (1-based, in the order of
``phases``), then ``W<kk>_Mean`` / ``W<kk>_Std``.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from pdmkit.errors import DataError
from pdmkit.features._common import check_finite, check_fs, from_rows, to_rows

__all__ = [
    "CYCLE_LEVELS",
    "EVENT_WINDOWS",
    "cycle_average",
    "cycle_feature_names",
    "cycle_features",
]

#: Default levels (fractions of the way from Start to End) of the transition times and
#: rates: the classic 10 / 50 / 90 % of a step response, then closer and closer to the
#: end, where end-of-stroke cushioning and impacts act.
CYCLE_LEVELS = (0.1, 0.5, 0.9, 0.95, 0.97, 0.98, 0.99, 0.995, 0.998)

#: Default event windows in s relative to the peak: the approach (30 to 10 ms and 10 to
#: 2 ms before), and the ring-down (2 to 10 ms, 10 to 30 ms and 30 to 100 ms after).
EVENT_WINDOWS = ((-0.03, -0.01), (-0.01, -0.002), (0.002, 0.01), (0.01, 0.03), (0.03, 0.1))

_EDGE = 0.02  # fraction of a segment averaged for its Start and End levels
_SETTLE = 0.02  # settling band, fraction of the excursion
_STEP = 0.5  # End at least this fraction of the extreme's distance from Start: a step
_DECAY = 0.1  # Decay: fraction of the peak
_TOL = 1e-9  # samples: a boundary landing on a sample up to rounding is on it

_TRANSITION = ("Start", "End")
_FALLS = (0.5, 0.9)  # Fall<l>: back from the extreme this fraction of the way to End
_AFTER_LEVELS = ("PeakRate", "Overshoot", "Rebound", "Fall50", "Fall90", "Settle")
_EVENT = ("Peak", "PeakTime", "Energy", "Decay")


def _level_tag(level: float) -> str:
    """0.995 -> '99p5', 0.5 -> '50'."""
    return f"{round(100.0 * level, 6):g}".replace(".", "p")


def cycle_feature_names(
    phases: Sequence[float] = (0.0, 0.5),
    levels: Sequence[float] = CYCLE_LEVELS,
    n_windows: int = 8,
    event_windows: Sequence = EVENT_WINDOWS,
) -> list[str]:
    """Column names of the cycle group, in table order.

    Examples
    --------
    >>> from pdmkit.features import cycle_feature_names
    >>> names = cycle_feature_names(phases=(0.0,), levels=(0.5, 0.9), n_windows=2,
    ...                             event_windows=())
    >>> names  # doctest: +NORMALIZE_WHITESPACE
    ['S1_Start', 'S1_End', 'S1_T50', 'S1_T90', 'S1_Rate50', 'S1_Rate90',
     'S1_Drop50_90', 'S1_PeakRate', 'S1_Overshoot', 'S1_Rebound', 'S1_Fall50',
     'S1_Fall90', 'S1_Settle', 'S1_Peak', 'S1_PeakTime', 'S1_Energy', 'S1_Decay',
     'W01_Mean', 'W01_Std', 'W02_Mean', 'W02_Std']
    """
    tags = [_level_tag(f) for f in levels]
    per_segment = [*_TRANSITION]
    per_segment += [f"T{t}" for t in tags]
    per_segment += [f"Rate{t}" for t in tags]
    per_segment += [f"Drop{a}_{b}" for a, b in itertools.pairwise(tags)]
    per_segment += [*_AFTER_LEVELS, *_EVENT]
    per_segment += [f"EventRMS{k + 1}" for k in range(len(event_windows))]
    names = [f"S{j + 1}_{n}" for j in range(len(phases)) for n in per_segment]
    for k in range(n_windows):
        names += [f"W{k + 1:02d}_Mean", f"W{k + 1:02d}_Std"]
    return names


# --------------------------------------------------------------------------- options
def _per_member(value, name: str, *, positive: bool) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        arr = np.array([np.nan])
    ok = arr.ndim <= 1 and arr.size >= 1 and np.all(np.isfinite(arr))
    if ok and positive:
        ok = bool(np.all(arr > 0))
    if not ok:
        what = "a positive time in s" if positive else "a time in s"
        raise DataError(
            f"{name} must be {what} (a number, or one per member); got {value!r}"
        )
    return arr


def resolve_cycle_options(
    fs: float,
    *,
    period=None,
    start=0.0,
    phases: Sequence[float] = (0.0, 0.5),
    levels: Sequence[float] = CYCLE_LEVELS,
    n_windows: int = 8,
    event_windows: Sequence = EVENT_WINDOWS,
    prefix: str = "",
) -> dict:
    """Validate the cycle options (names as the extract group spells them with prefix)."""
    if period is None:
        raise DataError(
            f"the cycle group needs the cycle period: pass {prefix}period= the time of one "
            "machine cycle in s (e.g. cycle_period=2.0 for a piston commanded up and down "
            "every 2 s)"
        )
    period_arr = _per_member(period, f"{prefix}period", positive=True)
    start_arr = _per_member(start, f"{prefix}start", positive=False)
    try:
        ph = np.asarray(phases, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        ph = np.array([np.nan])
    if (
        ph.size < 1
        or not np.all(np.isfinite(ph))
        or np.any(ph < 0)
        or np.any(ph >= 1)
        or np.any(np.diff(ph) <= 0)
    ):
        raise DataError(
            f"{prefix}phases must be increasing fractions of the period in [0, 1) where "
            f"segments begin, e.g. (0.0, 0.5) for two half-cycles; got {phases!r}"
        )
    try:
        lv = np.asarray(levels, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        lv = np.array([np.nan])
    if (
        lv.size < 1
        or not np.all(np.isfinite(lv))
        or np.any(lv <= 0)
        or np.any(lv > 1)
        or np.any(np.diff(lv) <= 0)
    ):
        name = "cycle_levels" if prefix else "levels"
        raise DataError(
            f"{name} must be increasing fractions in (0, 1] of the way from a segment's "
            f"start level to its target, e.g. (0.1, 0.5, 0.9); got {levels!r}"
        )
    if len({_level_tag(f) for f in lv}) != lv.size:
        raise DataError(
            f"levels {levels!r} are too close to tell apart in column names (0.0001 % "
            "apart at least)"
        )
    if isinstance(n_windows, bool) or not isinstance(n_windows, int | np.integer):
        n_windows = -1
    if n_windows < 0:
        name = "cycle_windows" if prefix else "n_windows"
        raise DataError(
            f"{name} must be a whole number of phase windows per cycle (0 for none); "
            f"got {n_windows!r}"
        )
    windows = []
    for w in event_windows:
        try:
            a, b = (float(v) for v in w)
        except (TypeError, ValueError):
            a, b = math.nan, math.nan
        if not (math.isfinite(a) and math.isfinite(b) and a < b):
            raise DataError(
                "event_windows must be (begin, end) pairs in s relative to the peak with "
                f"begin < end, e.g. ((-0.01, -0.002), (0.002, 0.01)); got {w!r}"
            )
        windows.append((a, b))
    return {
        "period": period_arr,
        "start": start_arr,
        "phases": tuple(float(p) for p in ph),
        "levels": tuple(float(f) for f in lv),
        "n_windows": int(n_windows),
        "event_windows": tuple(windows),
    }


# --------------------------------------------------------------------------- segments
def _segment_starts(n_samples: int, fs: float, period: float, start: float, p0, p1):
    """First sample, sub-sample offset and length of each complete segment [p0, p1)."""
    span = (p1 - p0) * period * fs  # samples in a segment
    length = math.floor(span + _TOL)
    if length < 2:
        raise DataError(
            f"a segment of {(p1 - p0) * period:g} s holds {span:.3g} samples at fs={fs:g} "
            "Hz; segments need at least 2 samples (raise the sampling rate, lengthen the "
            "period or use fewer phases)"
        )
    first = (start + p0 * period) * fs  # nominal start of cycle 0's segment, in samples
    step = period * fs
    c0 = math.ceil(-first / step - _TOL)  # first cycle whose segment starts at t >= 0
    c = np.arange(c0, c0 + int(n_samples // max(step, 1)) + 2)
    nominal = first + c * step
    i0 = np.ceil(nominal - _TOL).astype(np.int64)
    keep = (i0 >= 0) & (i0 + length <= n_samples)
    i0, nominal = i0[keep], nominal[keep]
    return i0, np.maximum(i0 - nominal, 0.0), length


def _no_segment(n_samples, fs, period, start, j) -> DataError:
    return DataError(
        f"the recording of {n_samples} samples ({n_samples / fs:g} s) holds no complete "
        f"segment S{j + 1} of a cycle of {period:g} s starting at {start:g} s; record "
        "at least one full cycle, or check the cycle period and start"
    )


def _take(values: np.ndarray, index: np.ndarray) -> np.ndarray:
    return np.take_along_axis(values, index[..., None], axis=-1)[..., 0]


def _segment_features(seg, before, fs, delta, levels, windows) -> dict[str, np.ndarray]:
    """Indicators of each segment instance.

    seg (m, C, L) the segments; before (m, C, k) the samples just before each (its start
    level); delta (C,) offset of each segment's first sample from its nominal start.
    """
    m, n_seg, length = seg.shape
    k = before.shape[-1]
    start = before.mean(axis=-1)
    end = seg[..., -k:].mean(axis=-1)
    dev = seg - start[..., None]
    i_ext = np.argmax(np.abs(dev), axis=-1)  # the extreme: farthest from Start
    extreme = _take(dev, i_ext)
    span = end - start
    # a step ends at least half-way to its extreme: followed to End; a pulse to its peak
    step_like = np.abs(span) >= _STEP * np.abs(extreme)
    target = np.where(step_like, span, extreme)
    sign = np.where(target >= 0, 1.0, -1.0)
    a = np.abs(target)
    y = dev * sign[..., None]  # from ~0 towards a
    y_end = span * sign
    y_ext = np.abs(extreme)
    y_pk = _take(y, i_ext)
    t0 = np.broadcast_to(delta / fs, (m, n_seg))
    rate = np.diff(y, axis=-1) * fs  # rate[..., i - 1]: between samples i - 1 and i
    out: dict[str, np.ndarray] = {"Start": start, "End": end}
    tags = [_level_tag(f) for f in levels]
    cross_idx = _level_crossings(out, y, a, rate, t0, levels, fs)
    for t_a, t_b in itertools.pairwise(tags):
        out[f"Drop{t_a}_{t_b}"] = out[f"Rate{t_a}"] - out[f"Rate{t_b}"]
    out["PeakRate"] = rate.max(axis=-1)
    out["Overshoot"] = np.where(step_like, np.maximum(y.max(axis=-1) - y_end, 0.0), 0.0)
    fall = np.maximum.accumulate(y, axis=-1) - y
    index = np.arange(length)
    out["Rebound"] = np.where(index >= cross_idx[..., None], fall, 0.0).max(axis=-1)
    _fall_times(out, y, y_end, y_pk, i_ext, fs)
    outside = np.abs(y - y_end[..., None]) > _SETTLE * y_ext[..., None]
    last_out = length - 1 - np.argmax(outside[..., ::-1], axis=-1)
    out["Settle"] = t0 + np.where(outside.any(axis=-1), last_out + 1, 0) / fs
    _event_features(out, seg, end, t0, fs, windows)
    return out


def _level_crossings(out: dict, y, a, rate, t0, levels, fs) -> np.ndarray:
    """``T<l>`` and ``Rate<l>``: when ``y`` first reaches each level, and its rate there.

    Added to ``out``; returns the sample index of the last level's crossing (the
    length where it is never reached).
    """
    length = y.shape[-1]
    cross_idx = None
    for f in levels:
        tag = _level_tag(f)
        th = f * a
        above = y >= th[..., None]
        i = np.argmax(above, axis=-1)
        never = ~above.any(axis=-1)
        i1 = np.clip(i, 1, length - 1)
        y0 = _take(y, i1 - 1)
        y1 = _take(y, i1)
        step = y1 - y0
        frac = np.clip((th - y0) / np.where(step > 0, step, 1.0), 0.0, 1.0)
        t = np.where(i == 0, 0.0, i1 - 1 + frac)
        out[f"T{tag}"] = t0 + np.where(never, float(length), t) / fs
        out[f"Rate{tag}"] = np.where(never, rate[..., -1], _take(rate, i1 - 1))
        cross_idx = np.where(never, length, i)
    return cross_idx


def _fall_times(out: dict, y, y_end, y_pk, i_ext, fs) -> None:
    """``Fall<f>``: time from the extreme back a fraction f of the way to the end level."""
    length = y.shape[-1]
    index = np.arange(length)
    gap = y_pk - y_end
    to_end = (y - y_end[..., None]) * np.where(gap >= 0, 1.0, -1.0)[..., None]
    for f in _FALLS:
        # back from the extreme a fraction f of the way to the end level
        th = (1.0 - f) * np.abs(gap)
        below = (to_end <= th[..., None]) & (index >= i_ext[..., None])
        j = np.argmax(below, axis=-1)
        j1 = np.clip(j, 1, length - 1)
        d0 = _take(to_end, j1 - 1)
        d1 = _take(to_end, j1)
        frac = np.clip((d0 - th) / np.where(d0 > d1, d0 - d1, 1.0), 0.0, 1.0)
        t = np.where(j > i_ext, j1 - 1 + frac, j)  # interpolated, as T<l>
        t = np.where(below.any(axis=-1), t, length)
        out[f"Fall{_level_tag(f)}"] = (t - i_ext) / fs


def _event_features(out: dict, seg, end, t0, fs, windows) -> None:
    """``Peak``, ``PeakTime``, ``Energy``, ``Decay``, ``EventRMS<j>``: around End."""
    m, n_seg, length = seg.shape
    e = seg - end[..., None]
    ae = np.abs(e)
    ip = np.argmax(ae, axis=-1)
    peak = _take(ae, ip)
    out["Peak"] = peak
    out["PeakTime"] = t0 + ip / fs
    cum = np.concatenate([np.zeros((m, n_seg, 1)), np.cumsum(e * e, axis=-1)], axis=-1)
    out["Energy"] = cum[..., -1] / fs
    big = ae > _DECAY * peak[..., None]
    last_big = length - 1 - np.argmax(big[..., ::-1], axis=-1)
    out["Decay"] = np.where(big.any(axis=-1), np.maximum(last_big - ip, 0), 0) / fs
    for j, (w0, w1) in enumerate(windows):
        lo = np.clip(ip + math.ceil(w0 * fs - _TOL), 0, length)
        hi = np.clip(ip + math.ceil(w1 * fs - _TOL), 0, length)
        n = hi - lo
        power = (_take(cum, hi) - _take(cum, lo)) / np.maximum(n, 1)
        out[f"EventRMS{j + 1}"] = np.where(n > 0, np.sqrt(np.maximum(power, 0.0)), 0.0)


def _cycle_rows(x: np.ndarray, fs: float, period: float, start: float, opts: dict):
    """All indicators of rows sharing one period and start (no validation)."""
    n = x.shape[1]
    phases = opts["phases"]
    bounds = [*phases, 1.0 + phases[0]]
    out: dict[str, np.ndarray] = {}
    for j in range(len(phases)):
        i0, delta, length = _segment_starts(n, fs, period, start, bounds[j], bounds[j + 1])
        if i0.size == 0:
            raise _no_segment(n, fs, period, start, j)
        seg = x[:, i0[:, None] + np.arange(length)[None, :]]
        # the start level: the samples just before the segment (where the machine rests
        # before the next command); the segment's own first samples at the recording start
        k = max(1, round(_EDGE * length))
        pre = np.maximum(i0 - k, 0)[:, None] + np.arange(k)[None, :]
        before = x[:, pre]
        feats = _segment_features(
            seg, before, fs, delta, opts["levels"], opts["event_windows"]
        )
        for name, v in feats.items():
            out[f"S{j + 1}_{name}"] = np.median(v, axis=1)
    n_win = opts["n_windows"]
    if n_win:
        i0, _, length = _segment_starts(n, fs, period, start, 0.0, 1.0)
        if i0.size == 0:
            raise _no_segment(n, fs, period, start, 0)
        if length < n_win:
            raise DataError(
                f"a cycle of {length} samples cannot be cut into {n_win} phase windows; "
                "use fewer windows"
            )
        cyc = x[:, i0[:, None] + np.arange(length)[None, :]]  # (m, C, length)
        edges = np.linspace(0, length, n_win + 1).round().astype(int)
        for k in range(n_win):
            w = cyc[..., edges[k] : edges[k + 1]]
            out[f"W{k + 1:02d}_Mean"] = w.mean(axis=(1, 2))
            out[f"W{k + 1:02d}_Std"] = np.median(w.std(axis=-1), axis=1)
    return out


def _cycle_feature_rows(x: np.ndarray, fs: float, opts: dict) -> dict[str, np.ndarray]:
    """Indicators of every row of a finite 2-D array; per-member periods grouped."""
    m = x.shape[0]
    period = np.broadcast_to(opts["period"], (m,))
    start = np.broadcast_to(opts["start"], (m,))
    if period.shape != (m,) or start.shape != (m,):
        raise DataError(
            f"cycle period / start have {opts['period'].size} / {opts['start'].size} "
            f"values for {m} members; pass one value, or one per member"
        )
    pairs = np.stack([period, start], axis=1)
    unique, inverse = np.unique(pairs, axis=0, return_inverse=True)
    inverse = np.asarray(inverse).reshape(-1)
    if len(unique) == 1:
        return _cycle_rows(x, fs, float(unique[0, 0]), float(unique[0, 1]), opts)
    out: dict[str, np.ndarray] = {}
    for g, (p, s) in enumerate(unique):
        rows = np.flatnonzero(inverse == g)
        part = _cycle_rows(x[rows], fs, float(p), float(s), opts)
        for name, v in part.items():
            out.setdefault(name, np.empty(m))[rows] = v
    return out


# --------------------------------------------------------------------------- public
def cycle_features(
    x: ArrayLike,
    fs: float,
    period: float | ArrayLike,
    *,
    start: float | ArrayLike = 0.0,
    phases: Sequence[float] = (0.0, 0.5),
    levels: Sequence[float] = CYCLE_LEVELS,
    n_windows: int = 8,
    event_windows: Sequence = EVENT_WINDOWS,
    axis: int = -1,
) -> dict[str, np.ndarray | float]:
    """Per-stroke and phase-window condition indicators of a cyclic machine.

    The recording is cut into its cycles (``period``, first one starting at ``start``)
    and each cycle into segments at the fractions ``phases`` of the period; transition,
    event and phase-window indicators are computed per segment and the median over the
    complete segments of the recording is returned (see the module notes for each
    definition).

    Parameters
    ----------
    x : array_like
        Signal samples along ``axis``: 1-D for one member, 2-D ``(members, samples)``.
        Must be finite.
    fs : float
        Sampling rate in Hz.
    period : float or array_like
        Cycle period in s; one value, or one per member.
    start : float or array_like, default 0.0
        Time in s (from the first sample) at which a cycle starts, e.g. the controller's
        first up command; one value, or one per member. Cycles before the first sample
        or running past the last are not used.
    phases : sequence of float, default (0.0, 0.5)
        Increasing fractions of the period in [0, 1) where segments begin; segment ``j``
        runs to the next phase (the last one to the first phase of the next cycle).
    levels : sequence of float, default :data:`CYCLE_LEVELS`
        Increasing fractions in (0, 1] of the way from a segment's start level to its
        target (its end level for a step, its peak for a pulse), for the ``T<l>``,
        ``Rate<l>`` and ``Drop`` indicators.
    n_windows : int, default 8
        Equal phase windows per cycle for ``W<k>_Mean`` / ``W<k>_Std``; 0 for none.
    event_windows : sequence of (float, float), default :data:`EVENT_WINDOWS`
        Windows in s relative to each segment's peak for ``EventRMS<k>``.
    axis : int, default -1
        Axis holding the samples.

    Returns
    -------
    dict of str -> float or ndarray
        Names as :func:`cycle_feature_names`; floats for a 1-D input, otherwise arrays
        of shape ``(members,)``.

    Raises
    ------
    pdmkit.errors.DataError
        NaN/inf samples (naming the rows), or a recording without a complete segment.
    ValueError
        A bad period, start, phases, levels, window count or event window.

    See Also
    --------
    cycle_average : the cycle-synchronous average itself.
    extract : the same indicators as group ``"cycle"`` of a feature table.

    Examples
    --------
    A cylinder position: up in 0.2 s at 1 m/s, down again half a cycle later, 10 cycles
    of 2 s sampled at 1 kHz:

    >>> import numpy as np
    >>> from pdmkit.features import cycle_features
    >>> fs = 1000.0
    >>> t = np.arange(20_000) / fs
    >>> phase = t % 2.0
    >>> x = np.clip(phase, 0, 0.2) - np.clip(phase - 1.0, 0, 0.2)
    >>> f = cycle_features(x, fs, period=2.0, levels=(0.5, 0.9))
    >>> round(f["S1_T50"], 4), round(f["S1_Rate50"], 3), round(f["S2_T90"], 4)
    (0.1, 1.0, 0.18)
    >>> round(f["S1_Start"], 3), round(f["S1_End"], 3), f["S1_Rebound"]
    (0.0, 0.2, 0.0)

    A decaying ring after an impact 0.3 s into each cycle: the 10 % decay time of
    ``exp(-t / 0.02)`` is ``0.02 * ln(10)``:

    >>> ring = np.where(phase >= 0.3, np.exp(-(phase - 0.3) / 0.02), 0.0)
    >>> g = cycle_features(ring, fs, period=2.0, phases=(0.0,), n_windows=0)
    >>> decay_10 = 0.02 * float(np.log(10))
    >>> round(g["S1_PeakTime"], 3), round(g["S1_Decay"], 3), round(decay_10, 3)
    (0.3, 0.046, 0.046)
    """
    fs = check_fs(fs)
    opts = resolve_cycle_options(
        fs,
        period=period,
        start=start,
        phases=phases,
        levels=levels,
        n_windows=n_windows,
        event_windows=event_windows,
    )
    rows, batch_shape = to_rows(x, axis, "x")
    check_finite(rows, "x")
    out = _cycle_feature_rows(rows, fs, opts)
    return {k: from_rows(v, batch_shape) for k, v in out.items()}


def cycle_average(
    x: ArrayLike,
    fs: float,
    period: float,
    *,
    start: float = 0.0,
    n_points: int | None = None,
    axis: int = -1,
) -> np.ndarray:
    """Cycle-synchronous average: the mean of a signal over its complete cycles.

    Each complete cycle (period ``period``, first starting at ``start``) is resampled
    by linear interpolation onto ``n_points`` equally spaced phases ``k / n_points``,
    ``k = 0 .. n_points - 1``, and the cycles are averaged. Whatever repeats every cycle
    stays; noise and anything not locked to the cycle average out (by ``1 / sqrt(C)``
    for ``C`` cycles of white noise).

    Parameters
    ----------
    x : array_like
        Samples along ``axis``; 1-D or 2-D ``(members, samples)``. Must be finite.
    fs : float
        Sampling rate in Hz.
    period : float
        Cycle period in s.
    start : float, default 0.0
        Time in s at which a cycle starts.
    n_points : int, optional
        Phase points per cycle; default ``round(period * fs)``.
    axis : int, default -1
        Axis holding the samples.

    Returns
    -------
    numpy.ndarray
        Shape ``(n_points,)`` for a 1-D input, ``(members, n_points)`` for 2-D; the
        phase of point ``k`` is ``k / n_points`` of the period.

    Raises
    ------
    pdmkit.errors.DataError
        NaN/inf samples, or no complete cycle in the recording.

    Examples
    --------
    A 5 Hz square wave buried in noise, 40 cycles of 0.2 s:

    >>> import numpy as np
    >>> from pdmkit.features import cycle_average
    >>> fs = 1000.0
    >>> clean = np.where(np.arange(8000) % 200 < 100, 1.0, -1.0)
    >>> noisy = clean + np.random.default_rng(0).normal(0, 0.5, clean.size)
    >>> csa = cycle_average(noisy, fs, period=0.2)
    >>> error = csa - clean[:200]   # about 0.5 / sqrt(39 cycles) = 0.08
    >>> csa.shape, bool(error.std() < 0.1), bool(noisy[:200].std() > 1.0)
    ((200,), True, True)
    """
    fs = check_fs(fs)
    opts = resolve_cycle_options(fs, period=period, start=start, n_windows=0)
    if opts["period"].size != 1 or opts["start"].size != 1:
        raise DataError(
            "cycle_average takes one period and one start for all members (the result "
            "has one phase grid); average groups of members with equal periods apart"
        )
    p = float(opts["period"].reshape(-1)[0])
    s = float(opts["start"].reshape(-1)[0])
    step = p * fs
    if n_points is None:
        n_points = max(1, round(step))
    if isinstance(n_points, bool) or not isinstance(n_points, int | np.integer):
        raise DataError(f"n_points must be a positive integer; got {n_points!r}")
    if n_points < 1:
        raise DataError(f"n_points must be a positive integer; got {n_points!r}")
    rows, batch_shape = to_rows(x, axis, "x")
    check_finite(rows, "x")
    n = rows.shape[1]
    first = s * fs
    c0 = math.ceil(-first / step - _TOL)
    cycles = np.arange(c0, c0 + int(n // max(step, 1)) + 2)
    begin = first + cycles * step
    cycles = cycles[(begin >= -_TOL) & (begin + step <= n - 1 + _TOL)]
    if cycles.size == 0:
        raise DataError(
            f"x: the recording of {n} samples ({n / fs:g} s) holds no complete cycle of "
            f"{p:g} s starting at {s:g} s; record at least one full cycle"
        )
    pos = first + (cycles[:, None] + np.arange(n_points)[None, :] / n_points) * step
    pos = np.clip(pos, 0.0, n - 1.0)
    i0 = (
        np.minimum(np.floor(pos).astype(np.int64), n - 2)
        if n > 1
        else np.zeros_like(pos, int)
    )
    w = pos - i0
    i1 = np.minimum(i0 + 1, n - 1)
    values = rows[:, i0] * (1.0 - w) + rows[:, i1] * w  # (m, C, n_points)
    avg = values.mean(axis=1)
    if batch_shape == ():
        return avg[0]
    return avg.reshape(*batch_shape, n_points)
