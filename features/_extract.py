"""Feature tables of arrays: :func:`extract` (for ensembles see :mod:`._ensemble`)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from pdmkit._checks import check_int
from pdmkit.errors import DataError
from pdmkit.features._common import check_fs, nonfinite_rows, raise_nonfinite
from pdmkit.features._groups import (
    FEATURE_GROUPS,
    check_group_options,
    check_groups,
    group_of_option,
)

__all__ = ["extract"]

#: Rows per chunk when ``batch_size`` is not given: about this many samples per chunk
#: (4 MiB of float64) keeps the intermediates cache-friendly and a few tens of MB
#: (measured: 2000 x 10000 members run fastest with chunks of 16 to 128 rows).
_AUTO_CHUNK_SAMPLES = 1 << 19


# --------------------------------------------------------------------------- checks
def check_batch_size(batch_size, allow_none: bool = False) -> int | None:
    """``batch_size`` as a positive int (None passes when ``allow_none``)."""
    if batch_size is None and allow_none:
        return None
    return check_int(batch_size, "batch_size")


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


def _plan(groups, options: dict, n_samples: int, n_members: int, fs: float) -> dict:
    """Each group's settings, its options checked against the data."""
    plan = {}
    for name in groups:
        given = {k: v for k, v in options.items() if group_of_option(k) == name}
        plan[name] = FEATURE_GROUPS[name].resolve(given, n_samples, n_members, fs)
    return plan


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
    signals: ArrayLike,
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
          every spectral indicator of that band only), ``welch="scipy"``
          (``"matlab"``: MATLAB ``pwelch``'s defaults, the Diagnostic Feature
          Designer's spectrum, :func:`matlab_pwelch`).
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
    group_list = check_groups(groups)
    check_group_options(group_list, options)
    bs = check_batch_size(batch_size, allow_none=True)
    _check_workers(workers)
    arr = _as_members(signals, axis)
    m, n = arr.shape
    plan = _plan(group_list, options, n, m, fs)
    if bs is None:
        bs = max(1, min(m, _AUTO_CHUNK_SAMPLES // n))

    bad: list[int] = []
    details: list[str] = []
    for start in range(0, m, bs):  # all offending rows in one message
        rows_bad, rows_details = nonfinite_rows(arr[start : start + bs], row_offset=start)
        bad += rows_bad
        details += rows_details
    raise_nonfinite(bad, details, name="signals")

    names = {g: FEATURE_GROUPS[g].feature_names(plan[g]) for g in group_list}
    columns = {f"{g}/{f}": np.empty(m) for g in group_list for f in names[g]}

    def run(start: int) -> None:
        # each chunk fills its own rows of the preallocated columns: no shared writes
        rows = slice(start, min(start + bs, m))
        chunk = np.ascontiguousarray(arr[rows], dtype=np.float64)
        for g in group_list:
            values = FEATURE_GROUPS[g].compute(chunk, fs, plan[g], rows)
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
