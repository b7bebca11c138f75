"""Time-domain statistics (group ``"stats"``) and harmonic distortion (``"harmonic"``).

The definitions follow MATLAB's Predictive Maintenance Toolbox (Diagnostic Feature
Designer, "signal statistics") so that tables made with either tool agree:

=================  ==============================================================
Mean               ``mean(x)``
Std                ``std(x)`` with the ``n - 1`` normalisation (MATLAB's default)
RMS                ``sqrt(mean(x**2))``
PeakValue          ``max(|x|)``
PeakToPeak         ``max(x) - min(x)``
Skewness           biased sample skewness (MATLAB ``skewness(x)``)
Kurtosis           biased, *non-excess* kurtosis (MATLAB ``kurtosis(x)``; 3 for Gauss)
CrestFactor        ``PeakValue / RMS``
ClearanceFactor    ``PeakValue / mean(sqrt(|x|))**2``
ImpulseFactor      ``PeakValue / mean(|x|)``
ShapeFactor        ``RMS / mean(|x|)``
=================  ==============================================================

``SINAD``, ``SNR`` and ``THD`` (dB) are MATLAB's ``sinad(x)``, ``snr(x)`` and ``thd(x)``:
a periodogram of the whole mean-removed record with a Kaiser window (beta 38), the
fundamental taken as the largest non-DC tone and harmonics 2..6 located near multiples
of it. They cost a full-length FFT per member, so they form the separate group
``"harmonic"`` and are computed only when asked for.
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.fft
import scipy.signal
from numpy.typing import ArrayLike

from pdmkit.errors import DataError
from pdmkit.features._common import check_finite, check_fs, from_rows, to_rows

__all__ = ["HARMONIC_FEATURES", "STATS_FEATURES", "harmonic", "stats"]

STATS_FEATURES = (
    "Mean",
    "Std",
    "RMS",
    "PeakValue",
    "PeakToPeak",
    "Skewness",
    "Kurtosis",
    "CrestFactor",
    "ClearanceFactor",
    "ImpulseFactor",
    "ShapeFactor",
)
HARMONIC_FEATURES = ("SINAD", "SNR", "THD")


# --------------------------------------------------------------------------- stats
def _stats_rows(x: np.ndarray) -> dict[str, np.ndarray]:
    """Statistics of each row of a finite float64 2-D array (no validation)."""
    n = x.shape[1]
    mean = np.add.reduce(x, axis=1) / n
    xc = x - mean[:, None]
    m2 = np.einsum("ij,ij->i", xc, xc) / n
    buf = np.square(xc)
    m3 = np.einsum("ij,ij->i", buf, xc) / n
    m4 = np.einsum("ij,ij->i", buf, buf) / n
    xmax = x.max(axis=1)
    xmin = x.min(axis=1)
    peak = np.maximum(xmax, -xmin)
    absx = np.abs(x, out=xc)  # reuse the centred buffer
    mean_abs = np.add.reduce(absx, axis=1) / n
    mean_sqrt_abs = np.add.reduce(np.sqrt(absx, out=buf), axis=1) / n
    p2p = xmax - xmin
    rms = np.sqrt(m2 + mean * mean)
    std = np.sqrt(m2 * n / (n - 1)) if n > 1 else np.zeros_like(m2)
    with np.errstate(divide="ignore", invalid="ignore"):
        # a constant row has m2 == 0: skewness and kurtosis are undefined (NaN), as in
        # scipy.stats and MATLAB
        defined = m2 > 0
        skew = np.where(defined, m3 / np.where(defined, m2, 1.0) ** 1.5, np.nan)
        kurt = np.where(defined, m4 / np.where(defined, m2, 1.0) ** 2, np.nan)
        return {
            "Mean": mean,
            "Std": std,
            "RMS": rms,
            "PeakValue": peak,
            "PeakToPeak": p2p,
            "Skewness": skew,
            "Kurtosis": kurt,
            "CrestFactor": peak / rms,
            "ClearanceFactor": peak / mean_sqrt_abs**2,
            "ImpulseFactor": peak / mean_abs,
            "ShapeFactor": rms / mean_abs,
        }


def stats(x: ArrayLike, axis: int = -1) -> dict[str, np.ndarray | float]:
    """Time-domain condition indicators of one signal or a batch of members.

    Parameters
    ----------
    x : array_like
        Signal samples along ``axis``: 1-D for one member, 2-D ``(members, samples)`` or
        any shape for a batch. Must be finite.
    axis : int, default -1
        Axis holding the samples.

    Returns
    -------
    dict of str -> float or ndarray
        ``Mean, Std, RMS, PeakValue, PeakToPeak, Skewness, Kurtosis, CrestFactor,
        ClearanceFactor, ImpulseFactor, ShapeFactor`` (see the module notes for the
        definitions; ``Std`` uses ``n - 1``, ``Kurtosis`` is non-excess). Floats for a 1-D
        input, otherwise arrays of the batch shape. Ratios of an all-zero signal and the
        moments of a constant one are NaN.

    Raises
    ------
    pdmkit.errors.DataError
        Empty input, non-numeric data, or NaN/inf samples (the message names the rows).

    See Also
    --------
    extract : the same indicators as a feature table, with other groups beside them.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.features import stats
    >>> t = np.arange(1000) / 1000.0
    >>> s = stats(np.sin(2 * np.pi * 5 * t))
    >>> round(s["RMS"], 4), round(s["CrestFactor"], 4), round(s["Kurtosis"], 2)
    (0.7071, 1.4142, 1.5)
    >>> stats(np.ones((3, 10)))["PeakToPeak"]
    array([0., 0., 0.])
    """
    rows, batch_shape = to_rows(x, axis, "x")
    check_finite(rows, "x")
    return {k: from_rows(v, batch_shape) for k, v in _stats_rows(rows).items()}


# --------------------------------------------------------------------------- harmonic
def _kaiser_periodogram(x: np.ndarray, fs: float) -> tuple[np.ndarray, float, float]:
    """One-sided PSD of mean-removed rows with a symmetric Kaiser(38) window.

    Returns ``(psd, df, rbw)``: the PSD (rows x bins at ``k * fs / n``), the bin width and
    the resolution (equivalent noise) bandwidth of the window, as MATLAB's
    ``periodogram(x, kaiser(n, 38), n, fs)`` and ``enbw``.
    """
    n = x.shape[1]
    w = scipy.signal.windows.kaiser(n, 38.0, sym=True)
    spec = scipy.fft.rfft((x - x.mean(axis=1, keepdims=True)) * w, axis=1)
    psd = (spec.real**2 + spec.imag**2) / (fs * np.dot(w, w))
    if n % 2 == 0:
        psd[:, 1:-1] *= 2.0
    else:
        psd[:, 1:] *= 2.0
    rbw = fs * np.dot(w, w) / w.sum() ** 2
    return psd, fs / n, rbw


def _tone(psd: np.ndarray, df: float, rbw: float, target=None):
    """Vectorised MATLAB ``signal.internal.getToneFromPSD`` over the rows of ``psd``.

    Without ``target`` the tone is the largest bin of each row; with ``target`` (Hz, one
    per row) the local maximum among the bins next to the one nearest the target. The
    tone extends left and right while the PSD keeps falling. Returns ``power`` (integrated
    over the tone's bins, at least ``rbw`` times its peak), the power-weighted ``freq``,
    and the boolean ``band`` mask of its bins; rows whose target lies outside
    ``[0, fs/2]`` get NaN and an empty band.
    """
    m, k = psd.shape
    rows = np.arange(m)
    bins = np.arange(k)
    if target is None:
        valid = np.ones(m, dtype=bool)
        idx = psd.argmax(axis=1)
    else:
        target = np.broadcast_to(np.asarray(target, dtype=float), (m,))
        with np.errstate(invalid="ignore"):
            valid = np.isfinite(target) & (target >= 0) & (target <= (k - 1) * df)
        # nearest bin (the lower one on an exact tie, as MATLAB's min), then the largest
        # of it and its two neighbours (the first one on a tie, as MATLAB's max)
        near = np.where(valid, np.ceil(np.where(valid, target, 0.0) / df - 0.5), 0)
        near = np.clip(near.astype(np.intp), 0, k - 1)
        lo = np.maximum(near - 1, 0)
        hi = np.minimum(near + 1, k - 1)
        cand = np.stack([lo, np.minimum(lo + 1, hi), np.minimum(lo + 2, hi)], axis=1)
        pick = psd[rows[:, None], cand].argmax(axis=1)
        idx = cand[rows, pick]
    # roll down the slope: left edge after the last rise before the peak, right edge at
    # the first rise after it
    falls = psd[:, :-1] > psd[:, 1:]
    last_fall = np.maximum.accumulate(np.where(falls, bins[:-1], -1), axis=1)
    left = np.where(idx >= 1, last_fall[rows, np.maximum(idx - 1, 0)] + 1, 0)
    rises = psd[:, :-1] < psd[:, 1:]
    next_rise = np.minimum.accumulate(np.where(rises, bins[:-1], k - 1)[:, ::-1], axis=1)
    next_rise = next_rise[:, ::-1]
    right = np.where(idx <= k - 2, next_rise[rows, np.minimum(idx, k - 2)], k - 1)
    band = (bins >= left[:, None]) & (bins <= right[:, None]) & valid[:, None]
    inband = np.where(band, psd, 0.0)
    total = inband.sum(axis=1)
    peak = psd[rows, idx]
    with np.errstate(invalid="ignore", divide="ignore"):
        freq = (inband @ (bins * df)) / total
    power = total * df
    small = power < rbw * peak  # a neighbouring tone invades the window kernel
    power = np.where(small, rbw * peak, power)
    freq = np.where(small, idx * df, freq)
    power = np.where(valid, power, np.nan)
    freq = np.where(valid, freq, np.nan)
    return power, freq, band


def _noise_power(work: np.ndarray, original: np.ndarray, df: float) -> np.ndarray:
    """MATLAB's noise estimate: fill removed bins with the median, cap by the original."""
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN row: median is NaN
        floor = np.nanmedian(np.where(work > 0, work, np.nan), axis=1)
    filled = np.where(work == 0, floor[:, None], work)
    return np.minimum(filled, original).sum(axis=1) * df


def _harmonic_rows(x: np.ndarray, fs: float, n_harmonics: int = 6) -> dict[str, np.ndarray]:
    """SINAD, SNR and THD (dB) of each row (no validation)."""
    original, df, rbw = _kaiser_periodogram(x, fs)
    psd = original.copy()
    psd[:, 0] *= 2.0  # bump DC by 3 dB and remove it
    _, _, dc_band = _tone(psd, df, rbw, np.zeros(len(psd)))
    psd[dc_band] = 0.0
    p_fund, f_fund, fund_band = _tone(psd, df, rbw)

    # THD: harmonics searched in the spectrum with DC removed (fundamental kept)
    harm_sum = np.zeros(len(psd))
    for h in range(2, n_harmonics + 1):
        p_h, _, _ = _tone(psd, df, rbw, h * f_fund)
        harm_sum += np.nan_to_num(p_h, nan=0.0)

    # SINAD: everything but the fundamental (and DC) is noise and distortion
    psd[fund_band] = 0.0
    sinad_noise = _noise_power(psd, original, df)

    # SNR: also remove harmonics 2..n, each searched after the previous one was removed
    for h in range(2, n_harmonics + 1):
        p_h, _, band = _tone(psd, df, rbw, h * f_fund)
        psd[band] = 0.0
    snr_noise = _noise_power(psd, original, df)

    with np.errstate(divide="ignore", invalid="ignore"):
        return {
            "SINAD": 10.0 * np.log10(p_fund / sinad_noise),
            "SNR": 10.0 * np.log10(p_fund / snr_noise),
            "THD": 10.0 * np.log10(harm_sum / p_fund),
        }


def harmonic(
    x: ArrayLike, fs: float, *, n_harmonics: int = 6, axis: int = -1
) -> dict[str, np.ndarray | float]:
    """SINAD, SNR and THD (dB) as MATLAB's ``sinad``, ``snr`` and ``thd`` compute them.

    The record's mean is removed, a periodogram of the whole record is taken with a
    Kaiser window (beta 38), and the DC component is removed. The fundamental is the
    largest remaining tone; harmonic ``h`` is the local maximum next to the bin nearest
    ``h`` times the fundamental's frequency (harmonics above ``fs/2`` are skipped). Each
    tone spans the bins around its peak while the PSD keeps falling.

    - ``SNR``: fundamental power over the noise power, the noise being the spectrum
      without DC, fundamental and harmonics ``2..n_harmonics``, the removed bins filled
      with the median noise density.
    - ``SINAD``: the same with the harmonics counted as noise.
    - ``THD``: total power of harmonics ``2..n_harmonics`` over the fundamental's.

    These need a full-length FFT per member, which is why :func:`extract` computes them
    only for the group ``"harmonic"``.

    Parameters
    ----------
    x : array_like
        Signal samples along ``axis`` (1-D for one member, 2-D ``(members, samples)``).
    fs : float
        Sampling rate in Hz.
    n_harmonics : int, default 6
        Number of harmonics including the fundamental (MATLAB's ``N``), at least 2.
    axis : int, default -1
        Axis holding the samples.

    Returns
    -------
    dict of str -> float or ndarray
        ``SINAD``, ``SNR`` and ``THD`` in dB (floats for a 1-D input).

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.features import harmonic
    >>> fs = 10_000.0
    >>> t = np.arange(20_000) / fs
    >>> x = np.sin(2 * np.pi * 100 * t) + 0.1 * np.sin(2 * np.pi * 200 * t)
    >>> round(harmonic(x, fs)["THD"], 1)  # 20 log10(0.1)
    -20.0
    """
    fs = check_fs(fs)
    if isinstance(n_harmonics, bool) or not isinstance(n_harmonics, int | np.integer):
        raise DataError(f"n_harmonics must be an integer >= 2, got {n_harmonics!r}")
    if n_harmonics < 2:
        raise DataError(f"n_harmonics must be >= 2 (fundamental + 1), got {n_harmonics}")
    rows, batch_shape = to_rows(x, axis, "x")
    check_finite(rows, "x")
    out = _harmonic_rows(rows, fs, int(n_harmonics))
    return {k: from_rows(v, batch_shape) for k, v in out.items()}
