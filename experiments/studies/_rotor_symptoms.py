"""Symptoms of the rotor study: from recursive AR estimates to diagnostic quantities.

The rotor-diagnostics monograph's section 5.3 ("technical summary") is the recipe:
identify an AR model on each probe signal, determine its poles, *sort them by value so
that modes do not switch*, filter them (median, then Savitzky-Golay; Table 15), and put
masks on them. The quantities here follow it:

- **line prominence** at 1X and 2X (dB): how far the AR spectrum ``1 / |A(e^jw)|^2``
  rises at the synchronous frequency over its level 2 Hz either side. A synchronous
  component (the seed's "forced vibration", Table 2) is a pole pair on the unit circle
  at that frequency; its prominence grows with its amplitude (unbalance at 1X,
  misalignment at 2X).
- **mode frequencies**: the natural frequency of each reference mode of the healthy
  machine (from the rig's linear model, the seed's "analytical-linearised solution",
  sec. 4.3.2) followed as the frequency of the lightly damped pole nearest to it (the
  seed's sorting by value, instead of following tracks that can swap); synchronous
  poles (``nX +- 3 %``) are no modes.
- **parity ratios** of channel-to-channel relations
  (:class:`pdmkit.models.diagnosis.ParityEquations`).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from pdmkit.models.diagnosis import DiagnosticMask
from pdmkit.models.ident import RecursiveARX, smooth_tracks

__all__ = ["line_prominence", "mode_frequencies", "rls_theta", "tune_masks"]

#: poles with a damping ratio below this count as modes (lightly damped)
MODE_DAMPING = 0.15
#: relative half-width of the band in which a mode is searched
MODE_BAND = 0.45


def rls_theta(y: np.ndarray, na: int, forgetting: float, fs: float) -> np.ndarray:
    """AR parameters ``[a1..a_na]`` after each sample (recursive least squares)."""
    scale = float(np.std(y)) or 1.0
    est = RecursiveARX(na=na, forgetting=forgetting, fs=fs, track_every=10**9)
    return est.fit(y / scale).theta_


def _a_on_circle(theta: np.ndarray, freqs, fs: float) -> np.ndarray:
    """``|A(e^{j 2 pi f / fs})|`` for every row of ``theta``, shape (n, len(freqs))."""
    k = np.arange(1, theta.shape[1] + 1)
    E = np.exp(-2j * np.pi * np.outer(k, np.asarray(freqs, float)) / fs)
    return np.abs(1.0 + theta @ E)


def line_prominence(theta: np.ndarray, f0: float, fs: float, offset: float = 2.0):
    """Rise (dB) of the AR spectrum at ``f0`` over its mean level at ``f0 +- offset``.

    Examples
    --------
    >>> import numpy as np
    >>> fs = 100.0
    >>> z = 0.999 * np.exp(2j * np.pi * 20.0 / fs)  # a pole pair at 20 Hz
    >>> theta = np.real(np.poly([z, np.conj(z)]))[1:][None, :]
    >>> bool(line_prominence(theta, 20.0, fs)[0] > 30)
    True
    """
    a = _a_on_circle(theta, [f0 - offset, f0, f0 + offset], fs)
    side = 0.5 * (a[:, 0] ** -2 + a[:, 2] ** -2)
    return 10 * np.log10(a[:, 1] ** -2 / side)


def _poles(theta: np.ndarray, fs: float):
    """Frequency (Hz) and damping ratio of every pole (upper half-plane), per row."""
    n, na = theta.shape
    comp = np.zeros((n, na, na))
    comp[:, 0, :] = -theta
    comp[:, np.arange(1, na), np.arange(na - 1)] = 1.0
    z = np.linalg.eigvals(comp)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.log(z.astype(complex)) * fs
        wn = np.abs(s)
        zeta = np.where(wn > 0, -s.real / wn, 1.0)
    freq = np.where(s.imag > 0, s.imag / (2 * np.pi), np.nan)
    return freq, zeta


def mode_frequencies(
    theta: np.ndarray,
    fs: float,
    references,
    speed_hz: float,
    orders=(1, 2, 3),
    every: int = 1,
) -> np.ndarray:
    """Frequency of the lightly damped pole nearest each reference mode, per sample.

    Parameters
    ----------
    theta : ndarray (n, na)
        AR parameters over time (:func:`rls_theta`).
    fs : float
    references : sequence of float
        Healthy natural frequencies (Hz) to follow.
    speed_hz : float
        Shaft speed; poles within 3 % of its multiples ``orders`` are synchronous
        components, not modes.
    every : int, default 1
        Compute the poles every this many samples (held in between).

    Returns
    -------
    ndarray (n, len(references))
        Where no mode lies within ``MODE_BAND`` of a reference, the last value found is
        held (the reference itself before the first).
    """
    n_rows = theta.shape[0]
    freq, zeta = _poles(theta[:: int(every)], fs)
    ok = np.isfinite(freq) & (zeta < MODE_DAMPING) & (zeta > 0)
    for k in orders:
        ok &= np.abs(freq - k * speed_hz) > 0.03 * k * speed_hz
    out = np.empty((freq.shape[0], len(references)))
    refs = np.asarray(references, dtype=float)
    for j, ref in enumerate(refs):
        # a pole belongs to the reference it is nearest to (log-frequency)
        dist = np.abs(np.log(np.where(ok, freq, np.nan) / ref))
        others = np.delete(refs, j)
        if others.size:
            d_other = np.min(
                np.abs(np.log(np.where(ok, freq, np.nan)[..., None] / others)), axis=-1
            )
            dist = np.where(d_other < dist, np.nan, dist)
        dist = np.where(dist <= MODE_BAND, dist, np.nan)
        has = np.any(np.isfinite(dist), axis=1)
        pick = np.nanargmin(np.where(has[:, None], dist, 0.0), axis=1)
        f = np.where(has, freq[np.arange(freq.shape[0]), pick], np.nan)
        out[:, j] = pd.Series(f).ffill().fillna(ref).to_numpy()
    return np.repeat(out, int(every), axis=0)[:n_rows]


def tune_masks(
    history: pd.DataFrame,
    specs: dict,
    *,
    k: float = 5.0,
    delay: int = 0,
    hysteresis: float = 1.0,
) -> dict:
    """One :class:`DiagnosticMask` per symptom, self-tuned on a healthy history.

    ``specs`` maps a symptom to ``(column, side, floor)``. The band is ``median +- k *
    spread`` of the column (spread: the scaled median absolute deviation, at least
    ``floor``, so that a quantity that hardly moves on a healthy record does not alarm
    on a tiny change), open on the side the symptom does not use (``side``:
    ``"upper"``, ``"lower"`` or ``"both"``); hysteresis ``hysteresis`` spreads, alarm
    delay ``delay`` samples.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> hist = pd.DataFrame({"f": 50 + 0.1 * np.random.default_rng(0).normal(size=500)})
    >>> m = tune_masks(hist, {"f up": ("f", "upper", 0.2)})["f up"]
    >>> round(m.upper_, 1), m.lower_
    (51.0, -inf)
    """
    masks = {}
    for name, (col, side, floor) in specs.items():
        h = history[col].to_numpy()
        h = h[np.isfinite(h)]
        centre = float(np.median(h))
        spread = max(1.4826 * float(np.median(np.abs(h - centre))), float(floor))
        lo = centre - k * spread if side in ("lower", "both") else None
        hi = centre + k * spread if side in ("upper", "both") else None
        masks[name] = DiagnosticMask(
            lower=lo, upper=hi, hysteresis=hysteresis * spread, delay=int(delay)
        ).fit()
    return masks


def smooth_frame(frame: pd.DataFrame, median: int = 50, savgol: int = 151) -> pd.DataFrame:
    """Every column median- then Savitzky-Golay-filtered (seed Table 15)."""
    return pd.DataFrame(
        smooth_tracks(frame.to_numpy(), median=median, savgol=savgol),
        columns=frame.columns,
        index=frame.index,
    )
