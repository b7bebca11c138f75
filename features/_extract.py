"""Feature tables: :func:`extract` for arrays, :func:`extract_ensemble` for ensembles."""

from __future__ import annotations

import difflib
import math
import os
from collections.abc import Iterable, Sequence
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pandas as pd

from pdmkit._progress import progress as _progress_bar
from pdmkit.errors import DataError
from pdmkit.features._ar import (
    AR_DEFAULT_ORDER,
    _ar_feature_rows,
    ar_feature_names,
    resolve_ar_options,
)
from pdmkit.features._common import (
    MemberDataError,
    check_fs,
    nonfinite_rows,
    raise_nonfinite,
)
from pdmkit.features._cycle import (
    CYCLE_LEVELS,
    EVENT_WINDOWS,
    _cycle_feature_rows,
    cycle_feature_names,
    resolve_cycle_options,
)
from pdmkit.features._envelope import (
    _envelope_feature_rows,
    envelope_feature_names,
    resolve_envelope_options,
)
from pdmkit.features._model_features import (
    MODEL_GROUP_OPTIONS,
    _model_feature_rows,
    model_feature_names,
    resolve_model_options,
)
from pdmkit.features._spectral import (
    _spectral_rows,
    resolve_spectral_options,
    spectral_feature_names,
)
from pdmkit.features._stats import (
    HARMONIC_FEATURES,
    STATS_FEATURES,
    _harmonic_rows,
    _stats_rows,
)

__all__ = ["GROUPS", "extract", "extract_ensemble"]

#: Indicator groups :func:`extract` knows, and the keyword options each one takes
#: (with their defaults).
GROUP_OPTIONS: dict[str, dict[str, object]] = {
    "stats": {},
    "harmonic": {"n_harmonics": 6},
    "spectral": {
        "nperseg": None,
        "noverlap": None,
        "bands": None,
        "n_peaks": 5,
        "detrend": "constant",
        "frange": None,
    },
    "envelope": {
        "bearing": None,
        "shaft_hz": None,
        "envelope_band": None,
        "tolerance": 0.02,
        "envelope_harmonics": 3,
    },
    "cycle": {
        "cycle_period": None,
        "cycle_start": 0.0,
        "cycle_phases": (0.0, 0.5),
        "cycle_levels": CYCLE_LEVELS,
        "cycle_windows": 8,
        "event_windows": EVENT_WINDOWS,
    },
    "ar": {"ar_order": AR_DEFAULT_ORDER},
    # model-based groups fitted between an input and each member: frf, hw, fractional
    **MODEL_GROUP_OPTIONS,
}
GROUPS = tuple(GROUP_OPTIONS)
_OPTION_GROUP = {opt: group for group, opts in GROUP_OPTIONS.items() for opt in opts}

#: Rows per chunk when ``batch_size`` is not given: about this many samples per chunk
#: (4 MiB of float64) keeps the intermediates cache-friendly and a few tens of MB
#: (measured: 2000 x 10000 members run fastest with chunks of 16 to 128 rows).
_AUTO_CHUNK_SAMPLES = 1 << 19


# --------------------------------------------------------------------------- checks
def _check_groups(groups) -> tuple[str, ...]:
    if isinstance(groups, str):
        groups = (groups,)
    try:
        groups = tuple(groups)
    except TypeError:
        raise DataError(
            f"groups must be a sequence of group names from {list(GROUPS)}, got {groups!r}"
        ) from None
    unknown = [g for g in groups if g not in GROUP_OPTIONS]
    if unknown:
        raise DataError(f"unknown feature group(s) {unknown}; known groups: {list(GROUPS)}")
    if not groups:
        raise DataError(f"groups is empty; pick at least one of {list(GROUPS)}")
    return tuple(dict.fromkeys(groups))  # drop repeats, keep order


def _check_option_names(
    groups: Sequence[str], options: dict, where: str = "extract()"
) -> None:
    unknown = [k for k in options if k not in _OPTION_GROUP]
    if unknown:
        hints = []
        for k in unknown:
            close = difflib.get_close_matches(k, list(_OPTION_GROUP), n=1)
            if close:
                hints.append(f"{k!r} (did you mean {close[0]!r}?)")
            else:
                hints.append(repr(k))
        allowed = "; ".join(
            f"{g}: {', '.join(opts) or '(none)'}" for g, opts in GROUP_OPTIONS.items()
        )
        raise TypeError(
            f"{where}: unknown keyword argument(s) {', '.join(hints)}. "
            f"Options by group: {allowed}"
        )
    stray = [k for k in options if _OPTION_GROUP[k] not in groups]
    if stray:
        needs = sorted({_OPTION_GROUP[k] for k in stray})
        raise DataError(
            f"option(s) {stray} belong to group(s) {needs}, which are not in "
            f"groups={list(groups)}; add the group or drop the option"
        )


def _check_batch_size(batch_size, allow_none: bool) -> int | None:
    if batch_size is None and allow_none:
        return None
    if isinstance(batch_size, bool) or not isinstance(batch_size, int | np.integer):
        raise DataError(f"batch_size must be a positive integer, got {batch_size!r}")
    if batch_size < 1:
        raise DataError(f"batch_size must be a positive integer, got {batch_size}")
    return int(batch_size)


def _check_workers(workers) -> int:
    if workers is None or workers == -1:
        return _cpu_count()
    if (
        isinstance(workers, bool)
        or not isinstance(workers, int | np.integer)
        or workers < 1
    ):
        raise DataError(
            f"workers must be a positive number of threads, or None / -1 for all cores; "
            f"got {workers!r}"
        )
    return int(workers)


def _cpu_count() -> int:
    count = getattr(os, "process_cpu_count", None)  # Python >= 3.13: respects affinity
    if count is not None:
        return max(1, count() or 1)
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def _resolve(groups, options: dict, n_samples: int, n_members: int, fs: float) -> dict:
    """Validate every group's options against the data; return per-group settings."""
    plan = {}
    for group in groups:
        given = {k: v for k, v in options.items() if _OPTION_GROUP[k] == group}
        if group == "stats":
            plan[group] = {}
        elif group == "harmonic":
            nh = given.get("n_harmonics", 6)
            if isinstance(nh, bool) or not isinstance(nh, int | np.integer) or nh < 2:
                raise DataError(
                    "n_harmonics must be an integer >= 2 (fundamental + harmonics), "
                    f"got {nh!r}"
                )
            plan[group] = {"n_harmonics": int(nh)}
        elif group == "spectral":
            plan[group] = resolve_spectral_options(n_samples, fs, name="signals", **given)
        elif group == "envelope":
            resolved = resolve_envelope_options(
                fs,
                bearing=given.get("bearing"),
                shaft_hz=given.get("shaft_hz"),
                band=given.get("envelope_band"),
                tolerance=given.get("tolerance", 0.02),
                n_harmonics=given.get("envelope_harmonics", 3),
            )
            shaft = resolved["shaft_hz"]
            if shaft.ndim == 1 and shaft.size != n_members:
                raise DataError(
                    f"shaft_hz has {shaft.size} values but signals has {n_members} "
                    "members; pass one speed, or one per member"
                )
            plan[group] = resolved
        elif group == "cycle":
            resolved = resolve_cycle_options(
                fs,
                period=given.get("cycle_period"),
                start=given.get("cycle_start", 0.0),
                phases=given.get("cycle_phases", (0.0, 0.5)),
                levels=given.get("cycle_levels", CYCLE_LEVELS),
                n_windows=given.get("cycle_windows", 8),
                event_windows=given.get("event_windows", EVENT_WINDOWS),
                prefix="cycle_",
            )
            for name in ("period", "start"):
                if resolved[name].ndim == 1 and resolved[name].size != n_members:
                    raise DataError(
                        f"cycle_{name} has {resolved[name].size} values but signals has "
                        f"{n_members} members; pass one value, or one per member"
                    )
            plan[group] = resolved
        elif group == "ar":
            plan[group] = resolve_ar_options(
                given.get("ar_order", AR_DEFAULT_ORDER), n_samples
            )
        elif group in MODEL_GROUP_OPTIONS:
            plan[group] = resolve_model_options(group, n_members, n_samples, **given)
    return plan


def _feature_names(group: str, settings: dict) -> list[str]:
    if group == "stats":
        return list(STATS_FEATURES)
    if group == "harmonic":
        return list(HARMONIC_FEATURES)
    if group == "spectral":
        return spectral_feature_names(settings["n_peaks"], settings["bands"])
    if group == "cycle":
        return cycle_feature_names(
            settings["phases"],
            settings["levels"],
            settings["n_windows"],
            settings["event_windows"],
        )
    if group == "ar":
        return ar_feature_names(settings["order"])
    if group in MODEL_GROUP_OPTIONS:
        return model_feature_names(group, settings)
    return envelope_feature_names(settings["n_harmonics"])


def _compute(group: str, x: np.ndarray, fs: float, settings: dict, rows: slice):
    if group == "stats":
        return _stats_rows(x)
    if group == "harmonic":
        return _harmonic_rows(x, fs, settings["n_harmonics"])
    if group == "spectral":
        return _spectral_rows(x, fs, settings)
    if group == "cycle":
        per_member = {
            name: settings[name][rows] if settings[name].ndim == 1 else settings[name]
            for name in ("period", "start")
        }
        return _cycle_feature_rows(x, fs, {**settings, **per_member})
    if group == "ar":
        return _ar_feature_rows(x, fs, settings)
    if group in MODEL_GROUP_OPTIONS:
        return _model_feature_rows(group, x, fs, settings, rows)
    if settings["shaft_hz"].ndim == 1:
        settings = {**settings, "shaft_hz": settings["shaft_hz"][rows]}
    return _envelope_feature_rows(x, fs, settings)


def _as_members(signals, axis: int) -> np.ndarray:
    try:
        arr = np.asarray(signals)
    except ValueError:  # numpy >= 1.24 refuses ragged nested sequences
        arr = np.asarray(signals, dtype=object)
    if arr.dtype.kind not in "fiub":
        raise DataError(
            f"signals must hold real numbers, got dtype {arr.dtype}; a ragged list of "
            "members of different lengths cannot form a 2-D array: extract them in groups "
            "of equal length (or use extract_ensemble)"
        )
    if arr.ndim not in (1, 2):
        raise DataError(
            "signals must be 1-D (one member) or 2-D (members x samples), got "
            f"{arr.ndim}-D with shape {arr.shape}; reshape it, e.g. "
            "x.reshape(-1, x.shape[-1])"
        )
    try:
        arr = np.moveaxis(arr, axis, -1)
    except np.exceptions.AxisError:
        raise DataError(
            f"axis={axis} is out of range for signals of shape {arr.shape}; the samples "
            "axis is -1 (default) or 0 for a (samples x members) array"
        ) from None
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.shape[0] == 0:
        raise DataError(
            f"signals has 0 members (shape {np.shape(signals)}); pass at least one member"
        )
    if arr.shape[1] == 0:
        raise DataError(
            f"signals is empty: {arr.shape[0]} member(s) with 0 samples (shape "
            f"{np.shape(signals)}); pass at least one sample per member"
        )
    return arr


# --------------------------------------------------------------------------- extract
def extract(
    signals,
    fs: float,
    groups: Sequence[str] = ("stats", "spectral"),
    *,
    axis: int = -1,
    batch_size: int | None = None,
    workers: int | None = None,
    **options,
) -> pd.DataFrame:
    """Condition indicators of one signal or a batch of members, as a feature table.

    Vectorised over members: each group runs as array operations on a chunk of members
    (one batched Welch PSD per chunk for ``"spectral"``); there is no
    Python loop over members. Chunks run on ``workers`` threads.

    Parameters
    ----------
    signals : array_like
        1-D (one member) or 2-D ``(members, samples)``, all members of equal length,
        sampled at ``fs``.
    fs : float
        Sampling rate in Hz.
    groups : sequence of str, default ("stats", "spectral")
        Indicator groups, in column order:

        ``"stats"``
            Mean, Std, RMS, PeakValue, PeakToPeak, Skewness, Kurtosis, CrestFactor,
            ClearanceFactor, ImpulseFactor, ShapeFactor (see :func:`stats`).
        ``"harmonic"``
            SINAD, SNR, THD in dB as MATLAB computes them (see :func:`harmonic`); a
            full-length FFT per member, hence a separate group.
        ``"spectral"``
            Welch-PSD peaks, total and band power, spectral centroid, spread, kurtosis,
            entropy, flatness (see :func:`spectral`).
        ``"envelope"``
            Envelope-spectrum amplitude at the bearing defect frequencies and their
            harmonics (see :func:`envelope_features`); needs ``bearing`` and ``shaft_hz``.
        ``"cycle"``
            Per-stroke transition and event indicators and phase-window statistics of
            a cyclic machine (see :func:`cycle_features`); needs ``cycle_period``.
        ``"ar"``
            Natural frequencies and damping ratios of the poles of an AR model fitted
            to each member, its fit and residual level (see :func:`ar_features`).
        ``"frf"``, ``"hw"``, ``"fractional"``
            Model-based indicators between a known input and each member: the H1
            frequency response and a rational fit to it, Hammerstein-Wiener
            coefficients, fractional-order transfer-function coefficients (see
            :func:`frf_features`, :func:`hw_features`, :func:`fractional_features`);
            each needs ``<group>_input``.
    axis : int, default -1
        Axis of ``signals`` holding the samples (0 for a ``(samples, members)`` array).
    batch_size : int, optional
        Members per chunk; default: as many as make about half a million samples. Bounds
        the memory of the intermediates, not the result.
    workers : int, optional
        Threads working on chunks in parallel; default (None or -1): one per CPU core.
        numpy and scipy release the GIL, so threads scale without copying the data.
    **options
        Group options (an option of a group not in ``groups`` is an error):

        - ``"harmonic"``: ``n_harmonics=6`` (harmonics including the fundamental).
        - ``"spectral"``: ``nperseg=None`` (``min(1024, n_samples)``),
          ``noverlap=None`` (``nperseg // 2``), ``bands=None`` (list of ``(lo, hi)`` Hz),
          ``n_peaks=5``, ``detrend="constant"``, ``frange=None`` (``(lo, hi)`` Hz:
          every spectral indicator of that band only).
        - ``"envelope"``: ``bearing`` (:class:`BearingGeometry`), ``shaft_hz`` (Hz, one
          value or one per member), ``envelope_band=None`` (band-pass before the
          envelope, Hz), ``tolerance=0.02``, ``envelope_harmonics=3``.
        - ``"ar"``: ``ar_order=8``.
        - ``"frf"``: ``frf_input`` (array, shared or one row per member),
          ``frf_nperseg``, ``frf_fmin``, ``frf_fmax``, ``frf_order=2``.
        - ``"hw"``: ``hw_input``, ``hw_input_nl``, ``hw_output_nl``, ``hw_nb``,
          ``hw_nf``, ``hw_nk``, ``hw_initial``.
        - ``"fractional"``: ``fractional_input``, ``fractional_nperseg``,
          ``fractional_fmax``.

    Returns
    -------
    pandas.DataFrame
        One row per member (index 0..n-1), columns ``<group>/<Feature>``, e.g.
        ``stats/Kurtosis``, ``spectral/PeakFreq1``.

    Raises
    ------
    pdmkit.errors.DataError
        Members with NaN/inf samples (naming the rows), 0 members or 0 samples, more than
        2 dimensions, or members shorter than the Welch segment.
    ValueError
        Unknown group, or a bad option value.
    TypeError
        Unknown keyword argument (the message lists the options of every group).

    See Also
    --------
    extract_ensemble : the same for an ensemble, with member ids and conditions.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.features import extract
    >>> fs = 1000.0
    >>> t = np.arange(2000) / fs
    >>> x = np.stack([np.sin(2 * np.pi * 50 * t), 2 * np.sin(2 * np.pi * 120 * t)])
    >>> table = extract(x, fs, bands=[(0, 100), (100, 200)])
    >>> table[["stats/RMS", "spectral/PeakFreq1"]].round(3)
       stats/RMS  spectral/PeakFreq1
    0      0.707              49.805
    1      1.414             120.117
    >>> list(table.columns[:3])
    ['stats/Mean', 'stats/Std', 'stats/RMS']
    >>> extract(x, fs, groups=("stats",), n_peaks=3)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    pdmkit.errors.DataError: option(s) ['n_peaks'] belong to group(s) ['spectral'], ...
    """
    fs = check_fs(fs)
    group_list = _check_groups(groups)
    _check_option_names(group_list, options)
    bs = _check_batch_size(batch_size, allow_none=True)
    _check_workers(workers)
    arr = _as_members(signals, axis)
    m, n = arr.shape
    plan = _resolve(group_list, options, n, m, fs)
    if bs is None:
        bs = max(1, min(m, _AUTO_CHUNK_SAMPLES // n))

    bad: list[int] = []
    details: list[str] = []
    for start in range(0, m, bs):  # all offending rows in one message
        rows_bad, rows_details = nonfinite_rows(arr[start : start + bs], row_offset=start)
        bad += rows_bad
        details += rows_details
    raise_nonfinite(bad, details, name="signals")

    names = {g: _feature_names(g, plan[g]) for g in group_list}
    columns = {f"{g}/{f}": np.empty(m) for g in group_list for f in names[g]}

    def run(start: int) -> None:
        # each chunk fills its own rows of the preallocated columns: no shared writes
        rows = slice(start, min(start + bs, m))
        chunk = np.ascontiguousarray(arr[rows], dtype=np.float64)
        for g in group_list:
            values = _compute(g, chunk, fs, plan[g], rows)
            for f in names[g]:
                columns[f"{g}/{f}"][rows] = values[f]

    starts = range(0, m, bs)
    n_threads = min(_check_workers(workers), len(starts))
    if n_threads <= 1:
        for start in starts:
            run(start)
    else:
        # numpy and scipy.fft release the GIL in their loops: threads over chunks of
        # members use the cores without copying the data to other processes
        with ThreadPoolExecutor(max_workers=n_threads) as pool:
            for future in [pool.submit(run, s) for s in starts]:
                future.result()
    return pd.DataFrame(columns, index=pd.RangeIndex(m))


# --------------------------------------------------------------------------- ensembles
def _is_ensemble(obj) -> bool:
    return all(hasattr(obj, a) for a in ("stack", "signal_names", "member_ids", "fs"))


def _describe_ids(ids: Sequence) -> str:
    ids = list(ids)
    shown = ", ".join(repr(i) for i in ids[:8])
    return shown + (f" and {len(ids) - 8} more" if len(ids) > 8 else "")


def _wrap_error(err: DataError, signal: str, present: pd.Index) -> DataError:
    rows = getattr(err, "rows", None)
    if rows:
        ids = [present[r] for r in rows]
        word = "member" if len(ids) == 1 else "members"
        problem = getattr(err, "problem", str(err))
        msg = f"signal {signal!r}, {word} {_describe_ids(ids)}: {problem}"
        new = MemberDataError(msg, rows=rows, problem=problem)
    else:
        msg = f"signal {signal!r} (members {_describe_ids(present)}): {err}"
        new = MemberDataError(msg, rows=(), problem=str(err))
    new.signal = signal
    new.member_ids = [present[r] for r in rows] if rows else list(present)
    return new


def _error_row(member, signal, source, message) -> dict:
    return {"member": str(member), "signal": signal, "source": source, "error": message}


def _present_same_length(batch, name, ids, skip, errors):
    """``batch.stack(name)``; with ``skip``, members of an odd length are set aside."""
    try:
        return batch.stack(name)
    except DataError:
        if not skip:
            raise
    xs = batch.signal(name)
    lengths = np.array([-1 if x is None else len(x) for x in xs])
    values, counts = np.unique(lengths[lengths >= 0], return_counts=True)
    common = values[counts == counts.max()].max()  # the most common; ties: longest
    mask = lengths == common
    for i in np.flatnonzero((lengths >= 0) & ~mask):
        errors.append(
            _error_row(
                ids[i],
                name,
                None,
                f"signal {name!r} of member {ids[i]!r} has {lengths[i]} samples; the "
                f"other members of its batch have {common}; member skipped (cut the "
                "members to one length with frames())",
            )
        )
    return np.stack([xs[i] for i in np.flatnonzero(mask)]), mask


def _named_inputs(batch, options, ids, skip, errors):
    """Model-group inputs given as a signal name (``frf_input="Force"``), per member.

    Returns ``({option: array (members, samples)}, has_all_inputs mask)``; members
    lacking an input signal are errors (skipped with ``skip``).
    """
    named = {
        k: v for k, v in options.items() if k.endswith("_input") and isinstance(v, str)
    }
    has_all = np.ones(len(ids), dtype=bool)
    inputs = {}
    for key, signal in named.items():
        if signal not in batch.signal_names:
            raise DataError(
                f"{key}={signal!r} names no signal of the ensemble; its signals are "
                f"{list(batch.signal_names)}"
            )
        values, mask = _present_same_length(batch, signal, ids, skip, errors)
        mask = np.asarray(mask, dtype=bool)
        missing = ids[~mask]
        if len(missing) and not skip:
            raise DataError(
                f"{key}={signal!r}: members {list(missing[:5])} lack that input signal "
                "(pass on_error='skip' to leave them out)"
            )
        for member in missing:
            errors.append(
                _error_row(
                    member,
                    signal,
                    None,
                    f"member {member!r} lacks the input signal "
                    f"{signal!r} of {key}; member skipped",
                )
            )
        full = np.full((len(ids), values.shape[1]), np.nan)
        full[mask] = values
        inputs[key] = full
        has_all &= mask
    return inputs, has_all


def _worker_threads() -> int | None:
    """Threads of the Dask worker running this task (None outside a worker)."""
    import sys

    if "distributed" not in sys.modules:
        return None
    try:
        from distributed import get_worker

        return int(get_worker().state.nthreads)
    except (ImportError, ValueError, AttributeError):
        return None


def _batch_table(
    batch, signals, groups, options, shaft_column, on_error="raise", errors=None
) -> pd.DataFrame:
    skip = on_error == "skip"
    errors = [] if errors is None else errors
    ids = pd.Index(batch.member_ids)
    conditions = batch.conditions
    conditions = (
        pd.DataFrame(index=ids) if conditions is None else conditions.reindex(ids).copy()
    )
    available = list(batch.signal_names)
    names = available if signals is None else list(signals)
    unknown = [s for s in names if s not in available]
    if unknown:
        raise DataError(
            f"signal(s) {unknown} are not in the ensemble; its signals are {available}"
        )
    parts = [conditions]
    n_errors = len(errors)
    inputs, has_inputs = _named_inputs(batch, options, ids, skip, errors)
    for name in names:
        array, mask = _present_same_length(batch, name, ids, skip, errors)
        mask = np.asarray(mask, dtype=bool)
        if inputs:  # model groups: keep the members that have their input signals too
            array = array[has_inputs[mask]]
            mask = mask & has_inputs
        if skip and signals is not None:  # a signal asked for by name must be there
            for i in np.flatnonzero(~batch.has_signal(name)):
                errors.append(
                    _error_row(
                        ids[i],
                        name,
                        None,
                        f"member {ids[i]!r} lacks signal {name!r}; member skipped",
                    )
                )
        present = ids[mask]
        if len(present) == 0:
            continue
        opts = dict(options)
        if shaft_column is not None:
            if shaft_column not in conditions.columns:
                raise DataError(
                    f"shaft_hz={shaft_column!r} names no condition column; the conditions "
                    f"are {list(conditions.columns)}"
                )
        while len(present):
            rows_of = ids.get_indexer(present)
            for key, values in inputs.items():
                opts[key] = values[rows_of]
            if shaft_column is not None:
                opts["shaft_hz"] = conditions.loc[present, shaft_column].to_numpy(
                    dtype=float
                )
            try:
                # in a Dask worker, use its threads, not every core of the machine
                feats = extract(
                    array, batch.fs[name], groups, workers=_worker_threads(), **opts
                )
                break
            except DataError as err:
                wrapped = _wrap_error(err, name, present)
                if not skip:
                    raise wrapped from err
                rows = getattr(err, "rows", None) or list(range(len(present)))
                for r in rows:
                    errors.append(
                        _error_row(
                            present[r],
                            name,
                            None,
                            f"signal {name!r} of member {present[r]!r}: "
                            f"{getattr(wrapped, 'problem', str(err))}; member skipped",
                        )
                    )
                keep = np.ones(len(present), dtype=bool)
                keep[rows] = False
                array, present = array[keep], present[keep]
        if len(present) == 0:
            continue
        feats.index = present
        feats.columns = [f"{name}/{c}" for c in feats.columns]
        parts.append(feats)
    table = pd.concat(parts, axis=1).reindex(ids)
    if len(errors) > n_errors:
        failed = {e["member"] for e in errors[n_errors:]}
        table = table[~table.index.isin(failed)]
    return table


def _extract_task(item, signals, groups, options, shaft_column, on_error):
    """One unit of work (a batch or a Parquet partition): (table, errors, signals)."""
    from pdmkit.ensembles import Partition, read_partition

    errors: list = []
    source = None
    if isinstance(item, Partition):
        source = f"{item.root} (members {item.start}:{item.stop})"
        wanted = signals
        if signals is not None:  # model groups' input signals are read too
            named = [v for k, v in options.items() if k.endswith("_input")]
            wanted = list(
                dict.fromkeys([*signals, *(v for v in named if isinstance(v, str))])
            )
        try:
            batch = read_partition(
                item, signals=wanted, errors=errors if on_error == "skip" else None
            )
        except DataError as exc:
            if on_error != "skip":
                raise
            # an unreadable part file: its members' ids are unknown, name positions
            message = f"{exc}; member skipped"
            rows = [
                _error_row(f"#{i}", None, source, message)
                for i in range(item.start, item.stop)
            ]
            return None, rows, []
    else:
        batch = item
    if len(batch) == 0:
        return None, errors, []
    start = len(errors)
    table = _batch_table(batch, signals, groups, options, shaft_column, on_error, errors)
    for e in errors[start:]:
        e["source"] = e["source"] or source
    names = list(signals) if signals is not None else list(batch.signal_names)
    return table, errors, names


ERROR_COLUMNS = ("member", "signal", "source", "error")


def extract_ensemble(
    ensemble,
    *,
    signals: Sequence[str] | None = None,
    groups: Sequence[str] = ("stats", "spectral"),
    batch_size: int = 512,
    progress: bool | None = None,
    client=None,
    on_error: str = "raise",
    return_errors: bool = False,
    **options,
):
    """Feature table of an ensemble: :func:`extract` per signal, members by id.

    Members stream through in batches of ``batch_size``, so an on-disk ensemble is
    never loaded whole: memory stays bounded by one batch plus the (small) feature rows.
    With ``client`` the batches run as tasks on a Dask cluster (an on-disk ensemble is
    then read by the workers, partition by partition); the table is the same.

    Parameters
    ----------
    ensemble : Ensemble, path, URL, or iterable of Ensemble
        A :class:`pdmkit.ensembles.Ensemble`; a path or fsspec URL (``s3://...``,
        ``file://...``) of an on-disk Parquet ensemble, read ``batch_size`` members at a
        time (the batches of :func:`pdmkit.ensembles.iter_parquet`); or an iterable of
        Ensemble batches.
    signals : sequence of str, optional
        Signals to use; default all of ``ensemble.signal_names``.
    groups : sequence of str, default ("stats", "spectral")
        Indicator groups (see :func:`extract`).
    batch_size : int, default 512
        Members per batch (per Dask task).
    progress : bool, optional
        Show a progress bar (in-process runs); default only when stderr is a terminal.
    client : dask.distributed.Client, str, int, optional
        Run on Dask: a client, a scheduler address (``"tcp://host:8786"``) or a number
        of local worker processes to start; default in-process. See
        :func:`pdmkit.ensembles.dask_client`.
    on_error : {"raise", "skip"}, default "raise"
        ``"skip"``: a member with bad data (NaN/inf samples, a length that differs
        from its batch, a signal named in ``signals`` that it lacks, a signal too short
        for the indicators) is left out of the table and described in the errors table;
        the other members go on. ``"raise"``: the first bad member raises.
    return_errors : bool, default False
        Also return the errors table (columns ``member``, ``signal``, ``source``,
        ``error``; empty when nothing went wrong).
    **options
        Group options, as for :func:`extract`. ``<group>_input`` of a model group
        (``frf``, ``hw``, ``fractional``) may name a signal of the ensemble: each
        member's own recording of it is the input. ``shaft_hz`` may also name a condition
        column holding each member's shaft speed in Hz.

    Returns
    -------
    pandas.DataFrame, or (DataFrame, DataFrame) with ``return_errors``
        Indexed by member id: the condition columns, then ``<signal>/<group>/<Feature>``
        columns (e.g. ``DE/stats/Kurtosis``); NaN where a member lacks a signal.

    Raises
    ------
    pdmkit.errors.DataError
        Bad signal data, naming the signal and the member ids (``on_error="raise"``);
        unknown signal names.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.ensembles import Ensemble
    >>> from pdmkit.features import extract_ensemble
    >>> rng = np.random.default_rng(0)
    >>> ens = Ensemble({"vib": rng.normal(size=(4, 2048))}, fs=1000.0,
    ...                conditions={"fault": ["none", "none", "ir", "ir"]})
    >>> table = extract_ensemble(ens, groups=("stats",))
    >>> table.shape
    (4, 12)
    >>> list(table.columns[:3])
    ['fault', 'vib/stats/Mean', 'vib/stats/Std']
    >>> short = Ensemble({"vib": [rng.normal(size=2048), rng.normal(size=100)]}, fs=1e3)
    >>> table, errors = extract_ensemble(short, on_error="skip", return_errors=True)
    >>> table.index.tolist(), errors["member"].tolist()
    (['m00000'], ['m00001'])
    """
    group_list = _check_groups(groups)
    _check_option_names(group_list, options, where="extract_ensemble()")
    batch_size = _check_batch_size(batch_size, allow_none=False)
    if on_error not in ("raise", "skip"):
        raise DataError(f"on_error must be 'raise' or 'skip'; got {on_error!r}")
    if signals is not None:
        if isinstance(signals, str):
            signals = [signals]
        signals = list(signals)
    shaft_column = (
        options.get("shaft_hz") if isinstance(options.get("shaft_hz"), str) else None
    )

    total = None
    if isinstance(ensemble, str | os.PathLike):
        from pdmkit.ensembles import parquet_partitions

        items: Iterable = parquet_partitions(ensemble, batch_size=batch_size)
        total = len(items)
    elif _is_ensemble(ensemble):
        n = len(ensemble)
        if n == 0:
            raise DataError("the ensemble has 0 members; nothing to extract")
        total = math.ceil(n / batch_size)
        items = [ensemble] if n <= batch_size else ensemble.batches(batch_size)
    elif isinstance(ensemble, Iterable):
        items = ensemble
    else:
        raise TypeError(
            "ensemble must be a pdmkit.ensembles.Ensemble, a path to a Parquet ensemble "
            f"or an iterable of Ensemble batches, got {type(ensemble).__name__}"
        )

    def checked(batches):
        for batch in batches:
            if not (_is_ensemble(batch) or hasattr(batch, "manifest")):
                raise TypeError(
                    f"the batches must be pdmkit.ensembles.Ensemble objects, got "
                    f"{type(batch).__name__}"
                )
            yield batch

    args = (signals, group_list, options, shaft_column, on_error)
    if client is None:
        results = (
            _extract_task(item, *args)
            for item in _progress_bar(
                checked(items), desc="features", total=total, enable=progress
            )
        )
    else:
        from pdmkit.ensembles import dask_map

        results = dask_map(
            _extract_task,
            list(checked(items)),
            client=client,
            signals=signals,
            groups=group_list,
            options=options,
            shaft_column=shaft_column,
            on_error=on_error,
        )

    return _combine(results, return_errors)


def _combine(results, return_errors: bool = False):
    """The feature table (and errors) from the ``_extract_task`` results, in order."""
    tables, errors = [], []
    order: list[str] = []
    for table, errs, names in results:
        errors.extend(errs)
        if table is None:
            continue
        for s in names:
            if s not in order:
                order.append(s)
        tables.append(table)
    error_table = pd.DataFrame(errors, columns=list(ERROR_COLUMNS))
    if not tables or not sum(len(t) for t in tables):
        if len(error_table):
            raise DataError(
                f"every member was skipped for bad data ({len(error_table)} problem(s)), "
                f"e.g. {error_table['error'].iloc[0]}"
            )
        raise DataError("the ensemble has 0 members; nothing to extract")
    table = pd.concat(tables, axis=0) if len(tables) > 1 else tables[0]

    # batches lacking a signal put its columns late: order by signal, conditions first
    def key(column) -> int:
        head = str(column).split("/", 1)[0]
        return 1 + order.index(head) if "/" in str(column) and head in order else 0

    columns = sorted(table.columns, key=key)
    table = table[columns]
    duplicated = table.index[table.index.duplicated()].unique()
    if len(duplicated):
        raise DataError(
            f"member ids {_describe_ids(duplicated)} occur in more than one batch; "
            "member ids must be unique"
        )
    if len(error_table) and not return_errors:
        import warnings

        warnings.warn(
            f"{error_table['member'].nunique()} member(s) skipped for bad data, e.g. "
            f"{error_table['error'].iloc[0]}; pass return_errors=True to get the table",
            UserWarning,
            stacklevel=3,
        )
    return (table, error_table) if return_errors else table
