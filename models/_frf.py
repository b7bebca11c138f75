"""Frequency-domain identification: FRF estimates, rational fits, grey-box fits, reduction.

The frequency-domain path of seeds ``002`` (Khatkhate, Ray & Keller 2007, section 4:
swept-sine FRFs of a mass-beam rig, an ``invfreqz`` rational fit, minimal realisation and
balanced reduction) and ``003`` (FRFs at several excitation amplitudes, filtered by
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
  FRFs with the coherence-weighted error of seed 003;
- :func:`hankel_singular_values`, :func:`balanced_truncation` - square-root balanced
  truncation (Laub et al. 1987; Glover 1984 for the error bound) with scipy.linalg only, so
  that it works without slycot (python-control's ``balred`` needs slycot).

Frequencies are in Hz in the public arguments (``freq``), angular frequency ``omega`` in
rad/s is given beside them in results.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
import scipy.linalg as sla
import scipy.optimize as sopt
import scipy.signal as ss
import scipy.stats as sst

from pdmkit._checks import check_fs as _check_fs
from pdmkit.errors import DataError, ModelError

__all__ = [
    "FRF",
    "AmplitudeDependence",
    "GreyBoxFit",
    "ReducedModel",
    "TFFit",
    "align_phase",
    "amplitude_dependence",
    "balanced_truncation",
    "fit_frf_params",
    "fit_tf",
    "frf_comparison",
    "frf_estimate",
    "hankel_singular_values",
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
    >>> from pdmkit.models._frf import FRF
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

    def plot(self, ax=None):
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
    u,
    y,
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
    >>> from pdmkit.models._frf import frf_estimate
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


def align_phase(model_deg, data_deg) -> np.ndarray:
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
    u,
    y,
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

    def plot(self, ax=None):
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
    and saturation make gain and phase depend on it (seed 003, section 3). Each row is
    compared with the reference row (default: the largest amplitude) at the frequencies
    where both coherences reach ``coherence_min``; the difference of ``ln H`` is tested
    against the random error of H1 estimates (chi-square with one degree of freedom per
    frequency line after normalising by the expected variance).

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
    >>> from pdmkit.models._frf import frf_estimate, amplitude_dependence
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


# ----------------------------------------------------------------------------- TF fit
@dataclass
class TFFit:
    """Rational transfer function fitted to FRF data by :func:`fit_tf`.

    Attributes
    ----------
    num, den : ndarray
        Coefficients: for ``domain="s"`` in descending powers of ``s`` (as
        :func:`scipy.signal.freqs`), for ``"z"`` in ascending powers of ``z^-1`` (as
        :func:`scipy.signal.freqz`); ``den[0] == 1``.
    domain : {"s", "z"}
    dt : float or None
        Sampling period (s) of a ``z`` model.
    poles, zeros : ndarray
    fit_percent : float
        ``100 (1 - ||H - H_model|| / ||H - mean(H)||)`` over the fitted points.
    n_iter : int
        Sanathanan-Koerner iterations done.
    reflected : int
        Unstable poles reflected into the stable region.


    Examples
    --------
    >>> import numpy as np, scipy.signal as ss
    >>> from pdmkit.models import fit_tf
    >>> f = np.linspace(0.1, 20, 200)
    >>> _, H = ss.freqs([25.0], [1.0, 1.0, 25.0], worN=2 * np.pi * f)
    >>> fit = fit_tf(f, H, nb=0, na=2)
    >>> np.round(np.abs(fit.poles), 3)  # natural frequency 5 rad/s
    array([5., 5.])
    """

    num: np.ndarray
    den: np.ndarray
    domain: str
    dt: float | None
    fit_percent: float
    n_iter: int = 0
    reflected: int = 0
    freq: np.ndarray | None = None
    H: np.ndarray | None = None

    @property
    def poles(self) -> np.ndarray:
        """Roots of the denominator (in ``s``, or in ``z``)."""
        return np.roots(self.den)

    @property
    def zeros(self) -> np.ndarray:
        """Roots of the numerator (in ``s``, or in ``z``)."""
        b = np.trim_zeros(self.num, "f")
        return np.roots(b) if b.size > 1 else np.array([])

    def frequency_response(self, freq) -> np.ndarray:
        """Complex response at frequencies ``freq`` (Hz)."""
        w = 2 * np.pi * np.asarray(freq, dtype=float)
        return _tf_eval(self.num, self.den, w, self.domain, self.dt)

    def to_control(self):
        """A :class:`control.TransferFunction`."""
        import control

        if self.domain == "s":
            return control.tf(self.num, self.den)
        n = max(self.num.size, self.den.size)
        b = np.pad(self.num, (0, n - self.num.size))
        a = np.pad(self.den, (0, n - self.den.size))
        return control.tf(b, a, self.dt)

    def to_pandas(self) -> pd.DataFrame:
        """Poles with natural frequency (rad/s) and damping ratio."""
        p = self.poles
        s = p if self.domain == "s" else np.log(p.astype(complex)) / self.dt
        wn = np.abs(s)
        zeta = np.where(wn > 0, -s.real / np.where(wn > 0, wn, 1.0), np.nan)
        return pd.DataFrame(
            {"pole_real": p.real, "pole_imag": p.imag, "wn_rad_s": wn, "zeta": zeta}
        )

    def plot(self, ax=None):
        """Data and model magnitude (dB) against frequency; returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        if self.freq is not None:
            ax.semilogx(self.freq, _DB * np.log(np.abs(self.H) + 1e-300), ".", label="data")
            ax.semilogx(
                self.freq,
                _DB * np.log(np.abs(self.frequency_response(self.freq)) + 1e-300),
                label="model",
            )
            ax.legend()
        ax.set_xlabel("frequency (Hz)")
        ax.set_ylabel("|H| (dB)")
        return ax


def _tf_eval(num, den, w, domain, dt):
    if domain == "s":
        s = 1j * w
        return np.polyval(num, s) / np.polyval(den, s)
    zi = np.exp(-1j * w * dt)
    b = np.polyval(np.asarray(num)[::-1], zi)
    a = np.polyval(np.asarray(den)[::-1], zi)
    return b / a


def _basis(x: np.ndarray, order: int, domain: str) -> np.ndarray:
    """Columns: for ``s`` descending powers x^order..x^0, for ``z`` x^0..x^order."""
    k = np.arange(order, -1, -1) if domain == "s" else np.arange(order + 1)
    return x[:, None] ** k[None, :]


def _levy(H, x, nb, na, weight, domain):
    """Weighted linear least squares of ``B(x) - H A(x)`` with A monic."""
    Xb = _basis(x, nb, domain)
    Xa = _basis(x, na, domain)
    # A = lead + sum a_k (others); s: lead is x^na (column 0); z: lead is x^0 (column 0)
    lead = Xa[:, 0]
    rest = Xa[:, 1:]
    M = np.hstack([Xb, -H[:, None] * rest]) * weight[:, None]
    rhs = H * lead * weight
    Mr = np.vstack([M.real, M.imag])
    rr = np.concatenate([rhs.real, rhs.imag])
    scale = np.linalg.norm(Mr, axis=0)
    scale[scale == 0] = 1.0
    theta, *_ = np.linalg.lstsq(Mr / scale, rr, rcond=None)
    theta = theta / scale
    b = theta[: nb + 1]
    a = np.concatenate([[1.0], theta[nb + 1 :]])
    return b, a


def _fit_num(H, x, nb, a, weight, domain):
    Xb = _basis(x, nb, domain)
    den = _basis(x, a.size - 1, domain) @ a
    M = Xb / den[:, None] * weight[:, None]
    r = H * weight
    Mr = np.vstack([M.real, M.imag])
    rr = np.concatenate([r.real, r.imag])
    b, *_ = np.linalg.lstsq(Mr, rr, rcond=None)
    return b


def _reflect(a: np.ndarray, domain: str) -> tuple[np.ndarray, int]:
    """Reflect unstable roots of the (scaled) denominator; keep it monic."""
    # s: descending powers; z: sum a_k z^-k = z^-n sum a_k z^(n-k), so in both cases
    # ``a`` read as a descending polynomial has the poles as roots
    r = np.roots(a)
    if domain == "s":
        bad = r.real > 0
        r = np.where(bad, -r.real + 1j * r.imag, r)
    else:
        bad = np.abs(r) > 1
        r = np.where(bad, 1 / np.conj(np.where(bad, r, 1.0)), r)
    if not bad.any():
        return a, 0
    new = np.real(np.poly(r))
    return new / new[0], int(bad.sum())


def fit_tf(
    freq,
    H,
    nb: int,
    na: int,
    *,
    domain: str = "s",
    fs: float | None = None,
    weight=None,
    n_iter: int = 30,
    refine: bool = True,
    stable: bool = True,
    tol: float = 1e-10,
) -> TFFit:
    """Fit a rational transfer function ``B/A`` to frequency-response data.

    As MATLAB's ``invfreqs`` (``domain="s"``) and ``invfreqz`` (``domain="z"``): Levy's
    linearised least squares ``min sum w |B - H A|^2`` gives a start; Sanathanan-Koerner
    iterations re-weight it by ``1/|A_prev|^2`` so that it converges to the output-error
    fit ``min sum w |H - B/A|^2``; ``refine`` polishes that with Gauss-Newton
    (:func:`scipy.optimize.least_squares`). With ``stable=True`` unstable poles are
    reflected (``s -> -conj(s)``, ``z -> 1/conj(z)``), which keeps the magnitude response
    of each factor, and the numerator is refitted. In ``s`` the frequencies are scaled by
    their largest value while fitting, which keeps the problem well conditioned.

    Parameters
    ----------
    freq : array_like
        Frequencies in Hz.
    H : array_like of complex
        FRF values at ``freq``.
    nb, na : int
        Numerator and denominator orders (``na >= 1``).
    domain : {"s", "z"}
        Continuous (Laplace) or discrete (``z^-1`` polynomials) model.
    fs : float
        Sampling rate (Hz) of a ``z`` model; required for ``domain="z"``.
    weight : array_like, optional
        Non-negative weight per frequency (e.g. coherence; seed 002 uses ``1/|H|`` for a
        relative error). Default ones.
    n_iter : int
        Maximum Sanathanan-Koerner iterations (0: Levy only).
    refine : bool
        Finish with a Gauss-Newton output-error fit.
    stable : bool
        Reflect unstable poles.

    Returns
    -------
    TFFit

    Examples
    --------
    >>> import numpy as np, scipy.signal as ss
    >>> from pdmkit.models._frf import fit_tf
    >>> f = np.linspace(0.1, 20, 200)
    >>> _, H = ss.freqs([100.0], [1.0, 2.0, 100.0], worN=2 * np.pi * f)
    >>> fit = fit_tf(f, H, nb=0, na=2)
    >>> np.round(fit.den, 4), np.round(fit.num, 4)
    (array([  1.,   2., 100.]), array([100.]))
    """
    freq = _as_float_array(freq, "freq").reshape(-1)
    H = np.asarray(H, dtype=complex).reshape(-1)
    if H.shape != freq.shape:
        raise DataError(f"H has {H.size} values but freq has {freq.size}.")
    if not np.all(np.isfinite(H)):
        raise DataError("H holds NaN/inf values; drop those frequencies first.")
    if domain not in ("s", "z"):
        raise ModelError(f"domain must be 's' or 'z'; got {domain!r}.")
    nb, na = int(nb), int(na)
    if na < 1 or nb < 0:
        raise ModelError(f"need na >= 1 and nb >= 0; got nb={nb}, na={na}.")
    if freq.size < (nb + na + 1) // 2 + 1:
        raise DataError(
            f"{freq.size} frequencies cannot determine {nb + na + 1} real coefficients;"
            " give more frequencies or lower the orders."
        )
    w = np.ones(freq.size) if weight is None else np.asarray(weight, dtype=float)
    if w.shape != freq.shape or np.any(w < 0) or not np.all(np.isfinite(w)):
        raise DataError("weight must be one finite non-negative value per frequency.")
    omega = 2 * np.pi * freq
    if domain == "z":
        if fs is None:
            raise ModelError("domain='z' needs the sampling rate fs (Hz).")
        dt = 1.0 / _check_fs(fs)
        x = np.exp(-1j * omega * dt)
        w0 = 1.0
    else:
        dt = None
        w0 = float(np.max(np.abs(omega))) or 1.0
        x = 1j * omega / w0
    sw = np.sqrt(w)

    b, a = _levy(H, x, nb, na, sw, domain)
    n_done = 0
    while n_done < n_iter:
        n_done += 1
        Ax = _basis(x, na, domain) @ a
        b_new, a_new = _levy(H, x, nb, na, sw / np.maximum(np.abs(Ax), 1e-300), domain)
        change = np.linalg.norm(a_new - a) / max(np.linalg.norm(a), 1e-300)
        b, a = b_new, a_new
        if change < tol:
            break

    def resid(theta):
        bb, aa = theta[: nb + 1], np.concatenate([[1.0], theta[nb + 1 :]])
        e = (_basis(x, nb, domain) @ bb / (_basis(x, na, domain) @ aa) - H) * sw
        return np.concatenate([e.real, e.imag])

    if refine:
        theta0 = np.concatenate([b, a[1:]])
        try:
            sol = sopt.least_squares(resid, theta0, method="lm", xtol=1e-12, ftol=1e-12)
            if np.sum(sol.fun**2) <= np.sum(resid(theta0) ** 2):
                b, a = sol.x[: nb + 1], np.concatenate([[1.0], sol.x[nb + 1 :]])
        except ValueError:  # fewer residuals than unknowns: keep SK's answer
            pass
    n_ref = 0
    if stable:
        a, n_ref = _reflect(a, domain)
        if n_ref:
            b = _fit_num(H, x, nb, a, sw, domain)
    # undo the frequency scaling: coefficient of s^k scales by w0^-k
    if domain == "s":
        kb = np.arange(nb, -1, -1)
        ka = np.arange(na, -1, -1)
        num = b / w0**kb
        den = a / w0**ka
        num, den = num / den[0], den / den[0]
    else:
        num, den = b, a
    Hm = _tf_eval(num, den, omega, domain, dt)
    spread = np.linalg.norm((H - H.mean()) * sw)
    fitp = 100.0 * (1 - np.linalg.norm((H - Hm) * sw) / spread) if spread > 0 else np.nan
    return TFFit(
        np.asarray(num, float),
        np.asarray(den, float),
        domain,
        dt,
        float(fitp),
        n_done,
        n_ref,
        freq,
        H,
    )


# ----------------------------------------------------------------------------- grey box
@dataclass
class GreyBoxFit:
    """Physical parameters fitted to FRFs by :func:`fit_frf_params`.

    Attributes
    ----------
    params : dict of str to float
        Fitted values.
    rms_db, rms_deg : float
        Coherence-weighted RMS magnitude (dB) and phase (degrees) error at the optimum.
    cost : float
        The minimised error (``rms_db**2 + (phase_weight * rms_phase_in_dB_units)**2``).
    freq, H, H_model, weight : ndarray
        The data, the fitted model's response and the weights used.
    success : bool


    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models import FRF, fit_frf_params
    >>> def spring_mass(omega, m, k):
    ...     return 1.0 / (k - m * omega**2 + 0.5j * omega)
    >>> f = np.linspace(0.5, 5, 50)
    >>> data = FRF(f, spring_mass(2 * np.pi * f, 1.0, 80.0))
    >>> fit = fit_frf_params(spring_mass, {"k": 50.0}, data, fixed={"m": 1.0})
    >>> round(fit.params["k"], 2), fit.rms_db < 1e-6
    (80.0, True)
    """

    params: dict
    rms_db: float
    rms_deg: float
    cost: float
    freq: np.ndarray
    H: np.ndarray
    H_model: np.ndarray
    weight: np.ndarray
    success: bool = True
    message: str = ""
    extra: dict = field(default_factory=dict)

    def to_pandas(self) -> pd.Series:
        """Fitted parameters and errors as a Series."""
        return pd.Series(
            {**self.params, "rms_db": self.rms_db, "rms_deg": self.rms_deg}, dtype=float
        )

    def plot(self, ax=None):
        """Measured and fitted magnitude; returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        H = np.atleast_2d(self.H)
        for row in H:
            ax.semilogx(self.freq, _DB * np.log(np.abs(row) + 1e-300), ".", alpha=0.5)
        ax.semilogx(self.freq, _DB * np.log(np.abs(self.H_model) + 1e-300), "k-")
        ax.set_xlabel("frequency (Hz)")
        ax.set_ylabel("|H| (dB)")
        return ax


def fit_frf_params(
    frf_model: Callable[..., np.ndarray],
    params0: Mapping[str, float],
    frf: FRF,
    *,
    fixed: Mapping[str, float] | None = None,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    coherence_min: float = 0.0,
    phase_weight: float = 1.0,
    method: str = "least_squares",
    log_params: bool = True,
) -> GreyBoxFit:
    """Fit physical parameters of a model FRF to measured FRFs (seed 003, section 4).

    The error at each frequency is the complex-log difference ``ln(H_meas / H_model)``:
    its real part times 8.69 is the magnitude error in dB, its imaginary part the phase
    error (radians, wrapped to (-pi, pi], so no unwrapping is needed). Each frequency
    is weighted by the measurement's coherence (zero below ``coherence_min``), as seed
    003 weights its RMS amplitude and phase errors by the coherence-dependent factor
    ``k_eval``; several rows (amplitudes) are fitted together.

    Parameters
    ----------
    frf_model : callable
        ``frf_model(omega, **params) -> complex array`` with ``omega`` in rad/s.
    params0 : dict of str to float
        Free parameters and their starting values.
    frf : FRF
        Measured FRF(s) (:func:`frf_estimate`).
    fixed : dict, optional
        Parameters passed to ``frf_model`` unchanged.
    bounds : dict of name -> (low, high), optional
        Bounds of the free parameters.
    coherence_min : float
        Frequencies with lower coherence get zero weight.
    phase_weight : float
        Weight of the phase error relative to the magnitude error (1: one radian counts
        as one neper, 8.69 dB).
    method : {"least_squares", "nelder-mead"}
        Trust-region least squares, or the Nelder-Mead simplex seed 003 uses.
    log_params : bool
        Optimise ``log(p)`` of positive parameters (scale-free; keeps them positive).

    Returns
    -------
    GreyBoxFit

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models._frf import FRF, fit_frf_params
    >>> def msd(omega, m, c, k):
    ...     s = 1j * omega
    ...     return 1.0 / (m * s**2 + c * s + k)
    >>> f = np.linspace(0.5, 10, 100)
    >>> data = FRF(f, msd(2 * np.pi * f, 1.0, 2.0, 400.0))
    >>> fit = fit_frf_params(msd, {"c": 1.0, "k": 300.0}, data, fixed={"m": 1.0})
    >>> round(fit.params["c"], 3), round(fit.params["k"], 2)
    (2.0, 400.0)
    """
    if not isinstance(frf, FRF):
        raise DataError(f"frf must be an FRF (see frf_estimate); got {type(frf).__name__}.")
    names = list(params0)
    if not names:
        raise ModelError("params0 is empty; give at least one free parameter.")
    fixed = dict(fixed or {})
    p0 = np.array([float(params0[k]) for k in names])
    logm = np.array([log_params and v > 0 for v in p0])
    lo = np.full(p0.size, -np.inf)
    hi = np.full(p0.size, np.inf)
    for i, k in enumerate(names):
        if bounds and k in bounds:
            lo[i], hi[i] = bounds[k]
            if logm[i]:
                lo[i] = np.log(lo[i]) if lo[i] > 0 else -np.inf
                hi[i] = np.log(hi[i]) if np.isfinite(hi[i]) else np.inf
    H = np.atleast_2d(frf.H)
    coh = np.broadcast_to(np.atleast_2d(frf.coherence), H.shape)
    wgt = np.where(coh >= coherence_min, coh, 0.0) * (np.abs(H) > 0)
    if not np.any(wgt > 0):
        raise DataError(
            f"no frequency has coherence >= coherence_min={coherence_min}; lower it."
        )
    omega = frf.omega
    sw = np.sqrt(wgt / wgt.sum())

    def to_params(theta):
        v = np.where(logm, np.exp(np.clip(theta, -700, 700)), theta)
        return dict(zip(names, v.tolist(), strict=True))

    def model(theta):
        Hm = np.asarray(frf_model(omega, **to_params(theta), **fixed), dtype=complex)
        if Hm.shape != omega.shape:
            raise ModelError(
                f"frf_model must return one complex value per frequency {omega.shape}; "
                f"got shape {Hm.shape}."
            )
        return Hm

    def resid(theta):
        Hm = model(theta)
        with np.errstate(divide="ignore", invalid="ignore"):
            d = np.log(np.where(wgt > 0, H, 1.0) / Hm[None, :])
        d = np.where(np.isfinite(d), d, 50.0)
        r = np.concatenate([(sw * d.real).ravel(), (sw * phase_weight * d.imag).ravel()])
        return r

    theta0 = np.where(logm, np.log(np.where(logm, p0, 1.0)), p0)
    if method == "least_squares":
        sol = sopt.least_squares(resid, theta0, bounds=(lo, hi), x_scale="jac")
        theta, ok, msg = sol.x, bool(sol.success), str(sol.message)
    elif method == "nelder-mead":
        bnds = list(zip(lo, hi, strict=True)) if bounds else None
        sol = sopt.minimize(
            lambda t: float(np.sum(resid(t) ** 2)),
            theta0,
            method="Nelder-Mead",
            bounds=bnds,
            options={"xatol": 1e-8, "fatol": 1e-12, "maxiter": 4000 * p0.size},
        )
        theta, ok, msg = sol.x, bool(sol.success), str(sol.message)
    else:
        raise ModelError(
            f"method must be 'least_squares' or 'nelder-mead'; got {method!r}."
        )
    Hm = model(theta)
    d = np.log(np.where(wgt > 0, H, 1.0) / Hm[None, :])
    ws = wgt.sum()
    rms_db = float(np.sqrt(np.sum(wgt * (_DB * d.real) ** 2) / ws))
    rms_deg = float(np.sqrt(np.sum(wgt * np.degrees(d.imag) ** 2) / ws))
    return GreyBoxFit(
        to_params(theta),
        rms_db,
        rms_deg,
        float(np.sum(resid(theta) ** 2)),
        frf.freq,
        frf.H,
        Hm,
        wgt,
        ok,
        msg,
    )


# ----------------------------------------------------------------------------- reduction
def _as_abcd(sys) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float | None]:
    """(A, B, C, D, dt) from a tuple, a python-control or a scipy.signal system."""
    dt = None
    if isinstance(sys, tuple | list):
        if len(sys) not in (4, 5):
            raise ModelError(f"sys must be (A, B, C, D[, dt]); got {len(sys)} items.")
        A, B, C, D = (np.atleast_2d(np.asarray(m, dtype=float)) for m in sys[:4])
        dt = sys[4] if len(sys) == 5 else None
    elif hasattr(sys, "A") and hasattr(sys, "B"):
        A, B, C, D = (np.atleast_2d(np.asarray(getattr(sys, k), float)) for k in "ABCD")
        dt = getattr(sys, "dt", None)
        if dt is True or dt == 0:
            dt = None if dt == 0 else dt
    else:
        try:
            import control

            s2 = control.ss(sys)
            return _as_abcd(s2)
        except Exception as exc:
            raise ModelError(
                "sys must be (A, B, C, D), a control.StateSpace/TransferFunction or a "
                f"scipy.signal StateSpace; got {type(sys).__name__}."
            ) from exc
    n = A.shape[0]
    if A.shape != (n, n) or B.shape[0] != n or C.shape[1] != n:
        raise ModelError(
            f"inconsistent state-space shapes A{A.shape}, B{B.shape}, C{C.shape}."
        )
    if dt is not None and dt is not False:
        dt = float(dt) if dt is not True else 1.0
    else:
        dt = None
    return A, B, C, D, dt


def _gramians(A, B, C, dt):
    if dt is None:
        if np.any(np.linalg.eigvals(A).real >= 0):
            raise ModelError(
                "balanced truncation needs a stable system; A has eigenvalues with "
                "real part >= 0. Split off the unstable part first."
            )
        P = sla.solve_continuous_lyapunov(A, -B @ B.T)
        Q = sla.solve_continuous_lyapunov(A.T, -C.T @ C)
    else:
        if np.any(np.abs(np.linalg.eigvals(A)) >= 1):
            raise ModelError(
                "balanced truncation needs a stable system; A has eigenvalues with "
                "|z| >= 1."
            )
        P = sla.solve_discrete_lyapunov(A, B @ B.T)
        Q = sla.solve_discrete_lyapunov(A.T, C.T @ C)
    return (P + P.T) / 2, (Q + Q.T) / 2


def _psd_factor(M):
    """L with M ~= L L^T for a symmetric positive semi-definite M."""
    w, V = np.linalg.eigh(M)
    return V * np.sqrt(np.clip(w, 0.0, None))[None, :]


def hankel_singular_values(sys) -> np.ndarray:
    """Hankel singular values of a stable state-space system, largest first.

    ``sigma_i = sqrt(lambda_i(P Q))`` with the controllability and observability
    Gramians ``P``, ``Q`` (continuous or discrete Lyapunov equations).

    Parameters
    ----------
    sys : (A, B, C, D[, dt]) tuple, control.StateSpace or scipy.signal.StateSpace

    Returns
    -------
    ndarray

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models._frf import hankel_singular_values
    >>> # 1/(s+1): P = Q = 1/2, so sigma = 1/2
    >>> hankel_singular_values((np.array([[-1.0]]), [[1.0]], [[1.0]], [[0.0]]))
    array([0.5])
    """
    A, B, C, _, dt = _as_abcd(sys)
    P, Q = _gramians(A, B, C, dt)
    Lp, Lq = _psd_factor(P), _psd_factor(Q)
    return np.linalg.svd(Lq.T @ Lp, compute_uv=False)


@dataclass
class ReducedModel:
    """A balanced-truncation reduced model (:func:`balanced_truncation`).

    Attributes
    ----------
    A, B, C, D : ndarray
        Reduced state-space matrices (balanced coordinates).
    dt : float or None
        Sampling period of a discrete model.
    hsv : ndarray
        Hankel singular values of the full model.
    order : int
        Kept states.
    error_bound : float
        ``2 * sum(hsv[order:])``: bound on the H-infinity norm of the error (Glover
        1984; Enns 1984).


    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models import balanced_truncation
    >>> A = np.diag([-1.0, -2.0, -100.0])
    >>> B, C = np.ones((3, 1)), np.array([[1.0, 1.0, 0.01]])
    >>> reduced = balanced_truncation((A, B, C, np.zeros((1, 1))), order=2)
    >>> reduced.order, reduced.A.shape, bool(reduced.error_bound < 1e-3)
    (2, (2, 2), True)
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    dt: float | None
    hsv: np.ndarray
    order: int
    error_bound: float

    @property
    def poles(self) -> np.ndarray:
        """Eigenvalues of the reduced ``A``."""
        return np.linalg.eigvals(self.A)

    def frequency_response(self, freq) -> np.ndarray:
        """Complex response, shape ``(n_out, n_in, n_freq)``, at ``freq`` (Hz)."""
        return _ss_freqresp(self.A, self.B, self.C, self.D, self.dt, freq)

    def to_control(self):
        """A :class:`control.StateSpace`."""
        import control

        return control.ss(self.A, self.B, self.C, self.D, 0 if self.dt is None else self.dt)

    def to_pandas(self) -> pd.DataFrame:
        """Hankel singular values with a flag for the kept states."""
        return pd.DataFrame(
            {"hsv": self.hsv, "kept": np.arange(self.hsv.size) < self.order}
        )

    def plot(self, ax=None):
        """Bar plot of the Hankel singular values; returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        i = np.arange(1, self.hsv.size + 1)
        ax.semilogy(i, self.hsv, "o")
        ax.axvline(self.order + 0.5, color="k", ls="--")
        ax.set_xlabel("state")
        ax.set_ylabel("Hankel singular value")
        return ax


def _ss_freqresp(A, B, C, D, dt, freq):
    w = 2 * np.pi * np.asarray(freq, dtype=float).reshape(-1)
    x = 1j * w if dt is None else np.exp(1j * w * dt)
    n = A.shape[0]
    out = np.empty((C.shape[0], B.shape[1], w.size), dtype=complex)
    eye = np.eye(n)
    for i, xi in enumerate(x):
        out[:, :, i] = C @ np.linalg.solve(xi * eye - A, B) + D
    return out


def balanced_truncation(sys, order: int | None = None, *, tol: float | None = None):
    """Reduce a stable state-space model by square-root balanced truncation.

    The Gramians' factors ``P = Lp Lp^T`` and ``Q = Lq Lq^T`` give the Hankel singular
    values as the singular values of ``Lq^T Lp = U S V^T``; the projection
    ``T = Lp V_r S_r^-1/2``, ``T_i = S_r^-1/2 U_r^T Lq^T`` keeps the ``order`` most
    controllable-and-observable states (Laub, Heath, Paige & Ward 1987). The reduced
    model is stable and ``||G - G_r||_inf <= 2 sum(sigma_{r+1..n})`` (Glover 1984). This
    is what seed 002 does with MATLAB's ``sysbal`` + ``modred``; python-control's
    ``balred`` needs slycot, which this function does not.

    Parameters
    ----------
    sys : (A, B, C, D[, dt]) tuple, control.StateSpace or scipy.signal.StateSpace
    order : int, optional
        States to keep.
    tol : float, optional
        Instead of ``order``: keep the smallest order whose error bound is below ``tol``.

    Returns
    -------
    ReducedModel

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models._frf import balanced_truncation
    >>> A = np.diag([-1.0, -50.0]); B = np.array([[1.0], [1.0]])
    >>> C = np.array([[1.0, 0.01]]); D = np.zeros((1, 1))
    >>> red = balanced_truncation((A, B, C, D), order=1)
    >>> np.round(red.poles.real, 2), bool(red.error_bound < 1e-3)
    (array([-1.]), True)
    """
    A, B, C, D, dt = _as_abcd(sys)
    n = A.shape[0]
    P, Q = _gramians(A, B, C, dt)
    Lp, Lq = _psd_factor(P), _psd_factor(Q)
    U, s, Vt = np.linalg.svd(Lq.T @ Lp)
    if order is None:
        if tol is None:
            raise ModelError("give order= (states to keep) or tol= (error bound).")
        tails = 2 * np.concatenate([np.cumsum(s[::-1])[::-1], [0.0]])
        order = int(np.argmax(tails <= tol))
    order = int(order)
    if not 1 <= order <= n:
        raise ModelError(f"order must be between 1 and {n}; got {order}.")
    if s[order - 1] <= 1e-14 * s[0]:
        raise ModelError(
            f"the model has only {int(np.sum(s > 1e-14 * s[0]))} states that are both "
            f"controllable and observable; order={order} is too high."
        )
    sr = s[:order] ** -0.5
    T = Lp @ Vt[:order].T * sr[None, :]
    Ti = (sr[:, None] * U[:, :order].T) @ Lq.T
    return ReducedModel(
        Ti @ A @ T, Ti @ B, C @ T, D.copy(), dt, s, order, float(2 * s[order:].sum())
    )
