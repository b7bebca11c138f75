"""Frequency-domain identification: FRF estimates, rational fits, grey-box fits, reduction.

The frequency-domain path of Khatkhate, Ray & Keller (2007, section 4: swept-sine FRFs
of a mass-beam rig, an ``invfreqz`` rational fit, minimal realisation and balanced
reduction) and of the S-Mobile paper (FRFs at several excitation amplitudes, filtered by
coherence, and physical parameters fitted to them with a coherence-weighted magnitude +
phase error):

- :func:`frf_estimate` - H1 estimate ``H = S_uy / S_uu`` with the ordinary coherence
  (Welch averaging), for one record or one record per excitation amplitude;
- :func:`amplitude_dependence` - is the FRF the same at every excitation amplitude?
  (a linear system's is; friction, backlash and saturation make it depend on amplitude);
- :func:`fit_tf` - rational transfer function ``B/A`` in ``s`` or ``z`` fitted to FRF data
  (Levy's linearised least squares, Sanathanan-Koerner iterations, an optional
  Gauss-Newton output-error refinement, unstable poles reflected into the stable region),
  as MATLAB's ``invfreqs`` / ``invfreqz``;
- :func:`fit_frf_params` - physical parameters of a user FRF function fitted to measured
  FRFs with the coherence-weighted error of the S-Mobile paper;
- :func:`hankel_singular_values`, :func:`balanced_truncation` - square-root balanced
  truncation (Laub et al. 1987; Glover 1984 for the error bound) with scipy.linalg only, so
  that it works without slycot (python-control's ``balred`` needs slycot).

Frequencies are in Hz in the public arguments (``freq``), angular frequency ``omega`` in
rad/s is given beside them in results.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
import scipy.signal as ss
import scipy.stats as sst

from pdmkit._checks import check_fs as _check_fs
from pdmkit.errors import DataError

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from numpy.typing import ArrayLike

__all__ = [
    "FRF",
    "AmplitudeDependence",
    "align_phase",
    "amplitude_dependence",
    "frf_comparison",
    "frf_estimate",
]

_DB = 20.0 / math.log(10.0)  # dB per neper


# ----------------------------------------------------------------------------- helpers
def _as_float_array(x, name: str) -> np.ndarray:
    try:
        arr = np.asarray(x, dtype=float)
    except (TypeError, ValueError) as exc:
        raise DataError(f"{name} must be a numeric array; got {type(x).__name__}.") from exc
    if arr.ndim == 0 or arr.shape[-1] == 0:
        raise DataError(f"{name} must hold samples along the last axis; got {arr.shape}.")
    if not np.all(np.isfinite(arr)):
        raise DataError(
            f"{name} holds {int(np.sum(~np.isfinite(arr)))} NaN/inf values; clean or "
            "interpolate them first."
        )
    return arr


# ----------------------------------------------------------------------------- FRF
@dataclass
class FRF:
    """A measured frequency response with its coherence.

    Attributes
    ----------
    freq : ndarray, shape (n_freq,)
        Frequencies in Hz.
    H : ndarray of complex, shape (..., n_freq)
        FRF values (output unit per input unit); one row per amplitude / member.
    coherence : ndarray, shape (..., n_freq)
        Ordinary coherence in [0, 1] (ones for noise-free or model data).
    amplitudes : ndarray or None
        Excitation amplitude of each row when estimated at several amplitudes.
    n_averages : int
        Number of Welch segments averaged (sets the estimate's random error).

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.frequency import FRF
    >>> f = FRF(np.array([1.0, 2.0]), np.array([1 + 0j, 0.5j]))
    >>> f.to_pandas().columns.tolist()
    ['freq', 'omega', 'magnitude_db', 'phase_deg', 'coherence']
    """

    freq: np.ndarray
    H: np.ndarray
    coherence: np.ndarray | None = None
    amplitudes: np.ndarray | None = None
    n_averages: int = 1

    def __post_init__(self):
        self.freq = np.asarray(self.freq, dtype=float)
        self.H = np.asarray(self.H, dtype=complex)
        if self.coherence is None:
            self.coherence = np.ones(self.H.shape)
        self.coherence = np.asarray(self.coherence, dtype=float)

    @property
    def omega(self) -> np.ndarray:
        """Angular frequencies in rad/s."""
        return 2.0 * np.pi * self.freq

    @property
    def magnitude_db(self) -> np.ndarray:
        """``20 log10 |H|``."""
        return _DB * np.log(np.maximum(np.abs(self.H), 1e-300))

    @property
    def phase_deg(self) -> np.ndarray:
        """Unwrapped phase in degrees."""
        return np.degrees(np.unwrap(np.angle(self.H), axis=-1))

    def to_pandas(self) -> pd.DataFrame:
        """Long table: one row per frequency (and amplitude / row of ``H``)."""
        H = np.atleast_2d(self.H)
        coh = np.broadcast_to(np.atleast_2d(self.coherence), H.shape)
        mag, ph = _DB * np.log(np.maximum(np.abs(H), 1e-300)), self.phase_deg
        ph = np.atleast_2d(ph)
        frames = []
        for i in range(H.shape[0]):
            df = pd.DataFrame(
                {
                    "freq": self.freq,
                    "omega": self.omega,
                    "magnitude_db": mag[i],
                    "phase_deg": ph[i],
                    "coherence": coh[i],
                }
            )
            if self.amplitudes is not None:
                df.insert(0, "amplitude", float(self.amplitudes[i]))
            elif H.shape[0] > 1:
                df.insert(0, "row", i)
            frames.append(df)
        return pd.concat(frames, ignore_index=True)

    def plot(self, ax: Axes | None = None) -> Axes:
        """Bode magnitude plot (and phase on a twin axis); returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        H = np.atleast_2d(self.H)
        for i, row in enumerate(H):
            lab = None if self.amplitudes is None else f"A={self.amplitudes[i]:g}"
            ax.semilogx(self.freq[1:], _DB * np.log(np.abs(row[1:]) + 1e-300), label=lab)
        ax.set_xlabel("frequency (Hz)")
        ax.set_ylabel("|H| (dB)")
        if self.amplitudes is not None:
            ax.legend()
        return ax


def frf_estimate(
    u: ArrayLike,
    y: ArrayLike,
    fs: float,
    *,
    nperseg: int | None = None,
    noverlap: int | None = None,
    window: str = "hann",
    detrend: str | bool = "constant",
    amplitudes: Sequence[float] | None = None,
    fmin: float = 0.0,
    fmax: float | None = None,
) -> FRF:
    """H1 frequency-response estimate with coherence, from input and output records.

    ``H1(f) = S_uy(f) / S_uu(f)`` and ``gamma^2 = |S_uy|^2 / (S_uu S_yy)`` with Welch
    averaging (``scipy.signal.csd`` / ``welch``). H1 is unbiased by output noise; input
    noise biases it low where the input's SNR is poor, which the coherence shows.

    Parameters
    ----------
    u, y : array_like, shape (..., n_samples)
        Input and output, same shape; leading axes (members, or one row per excitation
        amplitude) are estimated independently.
    fs : float
        Sampling rate in Hz.
    nperseg, noverlap : int, optional
        Welch segment length (default ``min(n, 1024)``) and overlap (default half).
    window, detrend
        As in :func:`scipy.signal.csd`.
    amplitudes : sequence of float, optional
        Excitation amplitude of each row of ``u`` (for :func:`amplitude_dependence`);
        default the RMS of each row of ``u`` times sqrt(2).
    fmin, fmax : float
        Frequency band kept, in Hz (default 0 to Nyquist).

    Returns
    -------
    FRF

    Raises
    ------
    pdmkit.errors.DataError
        Shapes differ, non-finite samples, or a segment longer than the record.

    Examples
    --------
    >>> import numpy as np, scipy.signal as ss
    >>> from pdmkit.models.frequency import frf_estimate
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=20000)
    >>> y = ss.lfilter([0.5], [1.0, -0.5], u)
    >>> frf = frf_estimate(u, y, fs=100.0, nperseg=256)
    >>> _, H_true = ss.freqz([0.5], [1.0, -0.5], worN=frf.freq, fs=100.0)
    >>> err = np.abs(frf.H - H_true)[1:]
    >>> bool(err.max() < 0.02), bool(frf.coherence[1:].min() > 0.99)
    (True, True)
    """
    fs = _check_fs(fs)
    u = _as_float_array(u, "u (input)")
    y = _as_float_array(y, "y (output)")
    if u.shape != y.shape:
        raise DataError(
            f"u (input) and y (output) must have the same shape; got {u.shape} and "
            f"{y.shape}."
        )
    n = u.shape[-1]
    nperseg = min(n, 1024) if nperseg is None else int(nperseg)
    if nperseg < 8 or nperseg > n:
        raise DataError(
            f"nperseg must be between 8 and the record length {n}; got {nperseg}."
        )
    noverlap = nperseg // 2 if noverlap is None else int(noverlap)
    kw = dict(fs=fs, window=window, nperseg=nperseg, noverlap=noverlap, detrend=detrend)
    f, suy = ss.csd(u, y, axis=-1, **kw)
    _, suu = ss.welch(u, axis=-1, **kw)
    _, syy = ss.welch(y, axis=-1, **kw)
    tiny = np.finfo(float).tiny
    H = suy / np.maximum(suu, tiny)
    coh = np.abs(suy) ** 2 / np.maximum(suu * syy, tiny)
    coh = np.clip(coh, 0.0, 1.0)
    keep = f >= fmin
    if fmax is not None:
        keep &= f <= fmax
    if not keep.any():
        raise DataError(f"no frequency between fmin={fmin} and fmax={fmax} Hz.")
    step = nperseg - noverlap
    n_avg = 1 + (n - nperseg) // step
    amps = None
    if u.ndim > 1 or amplitudes is not None:
        amps = (
            np.sqrt(2.0) * np.std(u, axis=-1).reshape(-1)
            if amplitudes is None
            else np.asarray(amplitudes, dtype=float).reshape(-1)
        )
        if amps.size != int(np.prod(u.shape[:-1])):
            raise DataError(
                f"amplitudes has {amps.size} values but u has "
                f"{int(np.prod(u.shape[:-1]))} rows; give one amplitude per row."
            )
    return FRF(f[keep], H[..., keep], coh[..., keep], amps, int(n_avg))


def align_phase(model_deg: ArrayLike, data_deg: ArrayLike) -> np.ndarray:
    """Unwrapped model phase moved by whole turns onto the data phase's branch.

    Both phases are unwrapped along frequency; the model's is then shifted by the
    multiple of 360 degrees that brings it nearest the data's at the first frequency,
    so that the two curves are compared on the same branch (an unwrapped phase is
    defined only up to whole turns, and two unwrappings from different starts can lie
    hundreds of degrees apart).

    Parameters
    ----------
    model_deg, data_deg : array_like
        Phases in degrees at the same ascending frequencies.

    Returns
    -------
    ndarray
        The model phase (degrees).

    Examples
    --------
    >>> import numpy as np
    >>> data = np.array([-170.0, -190.0, -210.0])       # already unwrapped
    >>> model = np.array([185.0, 165.0, 150.0])          # wrapped, other branch
    >>> align_phase(model, data)
    array([-175., -195., -210.])
    """
    m = np.degrees(np.unwrap(np.radians(np.asarray(model_deg, dtype=float))))
    d = np.degrees(np.unwrap(np.radians(np.asarray(data_deg, dtype=float))))
    if m.size == 0:
        return m
    return m + 360.0 * np.round((d[0] - m[0]) / 360.0)


def frf_comparison(
    u: ArrayLike,
    y: ArrayLike,
    fs: float,
    response: Callable,
    *,
    band: tuple[float, float] | None = None,
    nperseg: int | None = None,
) -> dict:
    """A model's frequency response beside the H1 estimate and the coherence.

    The H1 estimate and the coherence come from :func:`frf_estimate` (Welch:
    ``scipy.signal.csd`` / ``welch``; its coherence is that of
    :func:`scipy.signal.coherence`). Over ``band`` (Hz; default the first non-zero
    line to Nyquist) both phases are unwrapped and the model's is put on the data's
    branch (:func:`align_phase`). The segment length (default) resolves the band:
    about ``fs / (band width / 200)`` samples, at most a quarter of the record.

    Parameters
    ----------
    u, y : array_like, shape (n,)
    fs : float
    response : callable
        ``response(freq_hz) -> complex array`` (e.g. a model's
        ``frequency_response``).
    band : (float, float), optional
    nperseg : int, optional

    Returns
    -------
    dict
        ``freq``, ``H`` (data), ``G`` (model), ``coherence``, ``phase_data_deg``,
        ``phase_model_deg``, ``nperseg``.

    Examples
    --------
    >>> import numpy as np, scipy.signal as ss
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=20000)
    >>> b, a = [0.0, 0.05], [1.0, -1.6, 0.9]
    >>> y = ss.lfilter(b, a, u)
    >>> G = lambda f: ss.freqz(b, a, worN=f, fs=100.0)[1]
    >>> c = frf_comparison(u, y, 100.0, G, band=(2.0, 20.0))
    >>> bool(np.max(np.abs(c["phase_model_deg"] - c["phase_data_deg"])) < 5)
    True
    """
    fs = _check_fs(fs)
    u = _as_float_array(u, "u (input)").reshape(-1)
    y = _as_float_array(y, "y (output)").reshape(-1)
    n = u.size
    lo, hi = (0.0, fs / 2) if band is None else (float(band[0]), float(band[1]))
    if nperseg is None:
        width = max(hi - lo, fs / n)
        target = fs / (width / 200.0)
        nperseg = int(2 ** np.ceil(np.log2(max(target, 64))))
        nperseg = int(max(min(nperseg, n // 4 if n >= 256 else n), min(64, n)))
    frf = frf_estimate(u, y, fs, nperseg=nperseg)
    keep = (frf.freq > 0) & (frf.freq >= lo) & (frf.freq <= hi)
    if keep.sum() < 2:
        raise DataError(
            f"the band {lo:g}-{hi:g} Hz holds {int(keep.sum())} frequency line(s) of "
            f"the estimate (resolution {fs / nperseg:.3g} Hz); widen it or give a "
            "longer record."
        )
    f, H, coh = frf.freq[keep], frf.H[keep], frf.coherence[keep]
    G = np.asarray(response(f), dtype=complex).reshape(-1)
    ph_d = np.degrees(np.unwrap(np.angle(H)))
    ph_m = align_phase(np.degrees(np.angle(G)), ph_d)
    return {
        "freq": f,
        "H": H,
        "G": G,
        "coherence": coh,
        "phase_data_deg": ph_d,
        "phase_model_deg": ph_m,
        "nperseg": int(nperseg),
    }


@dataclass
class AmplitudeDependence:
    """Result of :func:`amplitude_dependence`.

    Attributes
    ----------
    amplitudes : ndarray
        Excitation amplitudes compared (rows of the FRF).
    deviation_db : ndarray, shape (n_amplitudes,)
        Coherence-weighted RMS of the magnitude difference (dB) to the reference row.
    deviation_deg : ndarray, shape (n_amplitudes,)
        Coherence-weighted RMS of the phase difference (degrees) to the reference row.
    statistic, p_value : ndarray, shape (n_amplitudes,)
        Chi-square statistic of the log-FRF differences against their random error
        (Bendat & Piersol, *Random Data*, eq. 9.72: ``var(ln|H1|) ~ (1 - g2) /
        (2 n_d g2)``) and its p-value; the reference row has p = 1.
    nonlinear : bool
        Some row has a p-value below ``alpha`` and a deviation above ``min_db``.


    Examples
    --------
    >>> import numpy as np, scipy.signal as ss
    >>> from pdmkit.models import amplitude_dependence, frf_estimate
    >>> rng = np.random.default_rng(1)
    >>> u = np.array([a * rng.normal(size=8192) for a in (0.5, 1.0, 2.0)])
    >>> y = np.clip(ss.lfilter([0.2], [1, -0.8], u), -0.5, 0.5)  # saturates at large u
    >>> result = amplitude_dependence(frf_estimate(u, y, 100.0, nperseg=256))
    >>> result.nonlinear, result.amplitudes.size
    (True, 3)
    """

    amplitudes: np.ndarray
    deviation_db: np.ndarray
    deviation_deg: np.ndarray
    statistic: np.ndarray
    p_value: np.ndarray
    nonlinear: bool
    alpha: float = 0.01

    def to_pandas(self) -> pd.DataFrame:
        """One row per amplitude."""
        return pd.DataFrame(
            {
                "amplitude": self.amplitudes,
                "deviation_db": self.deviation_db,
                "deviation_deg": self.deviation_deg,
                "statistic": self.statistic,
                "p_value": self.p_value,
            }
        )

    def plot(self, ax: Axes | None = None) -> Axes:
        """Magnitude deviation against amplitude; returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        ax.plot(self.amplitudes, self.deviation_db, "o-")
        ax.set_xlabel("excitation amplitude")
        ax.set_ylabel("RMS |H| deviation (dB)")
        return ax


def amplitude_dependence(
    frf: FRF,
    *,
    reference: int | None = None,
    coherence_min: float = 0.7,
    alpha: float = 0.01,
    min_db: float = 0.5,
) -> AmplitudeDependence:
    """Detect a nonlinearity from FRFs measured at several excitation amplitudes.

    A linear system has the same FRF at every amplitude; friction, backlash, dead zones
    and saturation make gain and phase depend on it (the S-Mobile paper, section 3).
    Each row is compared with the reference row (default: the largest amplitude) at the
    frequencies where both coherences reach ``coherence_min``; the difference of ``ln H``
    is tested against the random error of H1 estimates (chi-square with one degree of
    freedom per frequency line after normalising by the expected variance).

    Parameters
    ----------
    frf : FRF
        From :func:`frf_estimate` with one row per amplitude (``amplitudes`` set).
    reference : int, optional
        Row used as reference (default the largest amplitude).
    coherence_min : float
        Frequencies below this coherence (in either row) are ignored.
    alpha : float
        Significance level of the verdict.
    min_db : float
        Smallest RMS magnitude deviation (dB) that counts: the verdict needs a
        statistically significant *and* practically relevant difference.

    Returns
    -------
    AmplitudeDependence

    Examples
    --------
    >>> import numpy as np, scipy.signal as ss
    >>> from pdmkit.models.frequency import frf_estimate, amplitude_dependence
    >>> rng = np.random.default_rng(1)
    >>> u = np.array([a * rng.normal(size=8192) for a in (0.5, 1.0, 2.0)])
    >>> y = ss.lfilter([0.2], [1, -0.8], u) + 0.01 * rng.normal(size=u.shape)
    >>> res = amplitude_dependence(frf_estimate(u, y, 100.0, nperseg=256))
    >>> res.nonlinear
    False
    """
    H = np.atleast_2d(frf.H)
    coh = np.broadcast_to(np.atleast_2d(frf.coherence), H.shape)
    if H.shape[0] < 2:
        raise DataError(
            "frf must hold one FRF row per excitation amplitude (at least 2); got "
            f"{H.shape[0]}. Estimate it with frf_estimate(u, y, fs) on 2-D u, y."
        )
    amps = (
        np.arange(H.shape[0], dtype=float)
        if frf.amplitudes is None
        else np.asarray(frf.amplitudes, dtype=float)
    )
    ref = int(np.argmax(amps)) if reference is None else int(reference)
    nd = max(int(frf.n_averages), 1)
    g_ref = np.clip(coh[ref], 1e-12, 1 - 1e-12)
    dev_db, dev_deg, stat, pval = [], [], [], []
    for i in range(H.shape[0]):
        if i == ref:
            dev_db.append(0.0)
            dev_deg.append(0.0)
            stat.append(0.0)
            pval.append(1.0)
            continue
        g = np.clip(coh[i], 1e-12, 1 - 1e-12)
        m = (g >= coherence_min) & (g_ref >= coherence_min) & (frf.freq > 0)
        m &= (np.abs(H[i]) > 0) & (np.abs(H[ref]) > 0)
        if not m.any():
            raise DataError(
                f"no frequency where the coherence of rows {i} and {ref} reaches "
                f"coherence_min={coherence_min}; lower it or measure longer."
            )
        d = np.log(H[i, m] / H[ref, m])  # complex: ln|ratio| + j phase difference
        w = np.minimum(g[m], g_ref[m])
        dev_db.append(float(np.sqrt(np.sum(w * (_DB * d.real) ** 2) / np.sum(w))))
        dev_deg.append(float(np.sqrt(np.sum(w * np.degrees(d.imag) ** 2) / np.sum(w))))
        var = (1 - g[m]) / (2 * nd * g[m]) + (1 - g_ref[m]) / (2 * nd * g_ref[m])
        # E|d|^2 = 2 var per line (magnitude and phase); the 1.25 allows for the
        # correlation of overlapped Welch segments and the first-order variance formula
        chi_eff = np.sum((d.real**2 + d.imag**2) / var) / (2.0 * 1.25)
        dof = max(1.0, float(m.sum()))
        stat.append(float(chi_eff))
        pval.append(float(sst.chi2.sf(chi_eff, dof)))
    pval = np.asarray(pval)
    return AmplitudeDependence(
        amps,
        np.asarray(dev_db),
        np.asarray(dev_deg),
        np.asarray(stat),
        pval,
        bool(np.any((pval < alpha) & (np.asarray(dev_db) > min_db))),
        alpha,
    )
