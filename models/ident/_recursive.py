"""Recursive (adaptive) AR/ARX estimation and pole tracking over time.

:class:`RecursiveARX` runs recursive least squares with exponential forgetting
(Ljung 1999, sec. 11.2): the estimate at time ``t`` weighs the sample ``t - k`` by
``lambda**k``, so it forgets with a time constant of about ``1 / (1 - lambda)`` samples.
The poles of every estimate are tracked over time with each pole matched to the
nearest pole of the previous step (an optimal assignment), so that modes keep their
track and do not swap when they are sorted afresh.

As in the rotor-diagnostics monograph's processing chain (identification -> preprocessing ->
diagnosis), the tracks of natural frequency and damping are cleaned by a median filter
(impulse-like outliers) and then a Savitzky-Golay filter (smoothing); the defaults are
its Table 15: median buffer 50, Savitzky-Golay order 2 over 151 samples.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from scipy import ndimage, optimize, signal
from sklearn.base import BaseEstimator

from pdmkit.errors import DataError, ModelError, NotFittedError
from pdmkit.models.ident._model import _as_signal, _check_fs, _check_order, modes_from_poles

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from numpy.typing import ArrayLike

__all__ = ["PoleTracks", "RecursiveARX", "smooth_tracks", "track_poles"]


def smooth_tracks(
    x: ArrayLike, median: int = 50, savgol: int = 151, polyorder: int = 2, axis: int = 0
) -> np.ndarray:
    """Median filter, then Savitzky-Golay smoothing, along ``axis`` (time).

    Parameters
    ----------
    x : array_like
        Tracks, time along ``axis``.
    median : int, default 50
        Median-filter length in samples (0 or 1: none).
    savgol : int, default 151
        Savitzky-Golay window in samples (made odd; 0: none); shortened to the record.
    polyorder : int, default 2

    Examples
    --------
    >>> import numpy as np
    >>> x = np.r_[np.zeros(200), np.ones(200)]
    >>> x[50] = 100.0  # an impulse
    >>> y = smooth_tracks(x, median=9, savgol=31)
    >>> bool(abs(y[50]) < 1e-9), round(float(y[-1]), 6)
    (True, 1.0)
    """
    x = np.asarray(x, dtype=float)
    n = x.shape[axis]
    out = x
    if median and median > 1:
        size = [1] * x.ndim
        size[axis] = int(min(median, n))
        out = ndimage.median_filter(out, size=tuple(size), mode="nearest")
    if savgol and savgol > polyorder + 1:
        w = int(min(savgol, n))
        w = w if w % 2 else w - 1
        if w > polyorder:
            out = signal.savgol_filter(out, w, polyorder, axis=axis, mode="interp")
    return out


def track_poles(pole_sets: ArrayLike) -> np.ndarray:
    """Order poles so that each column follows one pole over time.

    Each row's poles are assigned to the previous row's (already ordered) poles by
    minimum total distance (:func:`scipy.optimize.linear_sum_assignment`).

    Parameters
    ----------
    pole_sets : array_like, shape (n_steps, n_poles), complex

    Returns
    -------
    ndarray, same shape, columns are tracks.

    Examples
    --------
    >>> import numpy as np
    >>> rows = np.array([[0.5, 0.9], [0.91, 0.52], [0.53, 0.92]])
    >>> track_poles(rows).real
    array([[0.5 , 0.9 ],
           [0.52, 0.91],
           [0.53, 0.92]])
    """
    p = np.array(pole_sets, dtype=complex)
    if p.ndim != 2:
        raise DataError(f"pole_sets must be (n_steps, n_poles); got shape {p.shape}.")
    for t in range(1, p.shape[0]):
        cost = np.abs(p[t - 1][:, None] - p[t][None, :])
        _, cols = optimize.linear_sum_assignment(cost)
        p[t] = p[t][cols]
    return p


@dataclass(eq=False)
class PoleTracks:
    """Poles, natural frequencies and damping ratios over time.

    Attributes
    ----------
    time : ndarray (n_steps,)
        Seconds.
    poles : ndarray (n_steps, n_poles), complex
        One column per tracked pole.
    natural_frequencies_hz, damping : ndarray (n_steps, n_modes)
        Per mode (tracks with non-negative mean imaginary part; a complex pair counts
        once), columns ordered by the mean frequency.
    fs : float

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(3) / 10.0
    >>> z = np.exp((-1 + 20j) / 10.0)
    >>> tr = PoleTracks.from_poles(t, np.array([[z, z.conjugate()]] * 3), fs=10.0)
    >>> tr.natural_frequencies_hz.shape, tr.to_pandas().columns.tolist()[:2]
    ((3, 1), ['time', 'f1_hz'])
    """

    time: np.ndarray
    poles: np.ndarray
    natural_frequencies_hz: np.ndarray
    damping: np.ndarray
    fs: float
    smoothed: dict = field(default_factory=dict, repr=False)

    @classmethod
    def from_poles(cls, time: ArrayLike, poles: ArrayLike, fs: float) -> PoleTracks:
        """Build tracks (modes ordered by mean frequency) from ordered pole columns."""
        poles = np.asarray(poles, dtype=complex)
        keep = np.mean(poles.imag, axis=0) >= -1e-12
        sel = poles[:, keep]
        s = np.log(np.where(np.abs(sel) > 0, sel, np.finfo(float).tiny)) * fs
        # conjugate-side samples of a kept track: use |Im| so the mode is continuous
        s = s.real + 1j * np.abs(s.imag)
        wn = np.abs(s)
        zeta = np.where(wn > 0, -s.real / np.where(wn > 0, wn, 1.0), -1.0)
        fn = wn / (2 * np.pi)
        order = np.argsort(np.nanmean(fn, axis=0), kind="stable")
        return cls(np.asarray(time, dtype=float), poles, fn[:, order], zeta[:, order], fs)

    def smooth(self, median: int = 50, savgol: int = 151, polyorder: int = 2) -> PoleTracks:
        """Median then Savitzky-Golay filtered copy (see :func:`smooth_tracks`)."""
        return PoleTracks(
            self.time,
            self.poles,
            smooth_tracks(self.natural_frequencies_hz, median, savgol, polyorder),
            smooth_tracks(self.damping, median, savgol, polyorder),
            self.fs,
            {"median": median, "savgol": savgol, "polyorder": polyorder},
        )

    def to_pandas(self) -> pd.DataFrame:
        """Columns ``time``, ``f<k>_hz``, ``zeta<k>`` for every mode ``k``."""
        data = {"time": self.time}
        for k in range(self.natural_frequencies_hz.shape[1]):
            data[f"f{k + 1}_hz"] = self.natural_frequencies_hz[:, k]
            data[f"zeta{k + 1}"] = self.damping[:, k]
        return pd.DataFrame(data)

    def plot(self, ax: Axes | None = None) -> Axes:
        """Natural frequencies (and damping on a twin axis) against time; the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 3.5))
        for k in range(self.natural_frequencies_hz.shape[1]):
            ax.plot(self.time, self.natural_frequencies_hz[:, k], label=f"mode {k + 1}")
        ax.set_xlabel("time [s]")
        ax.set_ylabel("natural frequency [Hz]")
        ax.legend(loc="best", fontsize="small")
        return ax


class RecursiveARX(BaseEstimator):
    """Recursive least squares for AR/ARX models with a forgetting factor.

    Parameters
    ----------
    na : int
        Poles (order of ``A``).
    nb : int, default 0
        Input coefficients (0: AR model, ``fit(y)`` without input).
    nk : int, default 1
        Input delay in samples.
    forgetting : float, default 0.99
        ``lambda`` in (0, 1]; memory about ``1 / (1 - lambda)`` samples.
    fs : float, default 1.0
        Sampling rate in Hz.
    delta : float, default 1000.0
        Initial covariance ``P0 = delta * I`` (large: little trust in ``theta0 = 0``).
    track_every : int, default 1
        Compute and track poles every this many samples.

    Attributes
    ----------
    theta_ : ndarray (N, na + nb)
        Parameter estimate after each sample ``[a1..a_na, b0..b_{nb-1}]``.
    residuals_ : ndarray (N,)
        A-priori prediction errors.
    tracks_ : PoleTracks
        Poles of ``A`` over time (every ``track_every`` samples), tracked.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy import signal
    >>> rng = np.random.default_rng(0)
    >>> y = signal.lfilter([1.0], [1, -1.5, 0.9], rng.normal(size=3000))
    >>> est = RecursiveARX(na=2, forgetting=0.995).fit(y)
    >>> np.round(est.theta_[-1], 1)
    array([-1.5,  0.9])
    """

    def __init__(
        self,
        na: int,
        nb: int = 0,
        nk: int = 1,
        forgetting: float = 0.99,
        fs: float = 1.0,
        delta: float = 1000.0,
        track_every: int = 1,
    ):
        self.na = na
        self.nb = nb
        self.nk = nk
        self.forgetting = forgetting
        self.fs = fs
        self.delta = delta
        self.track_every = track_every

    def _check(self):
        na = _check_order(self.na, "na", 1)
        nb = _check_order(self.nb, "nb", 0)
        nk = _check_order(self.nk, "nk", 0)
        lam = float(self.forgetting)
        if not 0 < lam <= 1:
            raise ModelError(f"forgetting must be in (0, 1]; got {self.forgetting!r}.")
        every = _check_order(self.track_every, "track_every", 1)
        return na, nb, nk, lam, _check_fs(self.fs), every

    @property
    def time_constant(self) -> float:
        """Memory of the estimator in samples, ``1 / (1 - lambda)`` (inf for 1)."""
        lam = float(self.forgetting)
        return float("inf") if lam >= 1 else 1.0 / (1.0 - lam)

    def fit(self, y: ArrayLike, u: ArrayLike | None = None) -> RecursiveARX:
        """Run the recursion over the record ``y`` (and input ``u`` for ARX).

        The output comes first and the input is optional: tracking mostly runs on the
        output alone (AR). pdmkit's other models take ``fit(u, y)``.
        """
        na, nb, nk, lam, fs, every = self._check()
        y = _as_signal(y, "y")
        if nb:
            if u is None:
                raise DataError(f"nb={nb} needs an input u; got None (use nb=0 for AR).")
            u = _as_signal(u, "u")
            if u.size != y.size:
                raise DataError(f"u has {u.size} samples but y has {y.size}.")
        n = y.size
        p = na + nb
        cols = [np.r_[np.zeros(k), y[: n - k]] for k in range(1, na + 1)]
        cols = [-c for c in cols]
        if nb:
            cols += [np.r_[np.zeros(k), u[: n - k]] for k in range(nk, nk + nb)]
        phi = np.stack(cols, axis=1)
        # Exponentially weighted normal equations R_t theta_t = r_t with
        # R_t = lam R_{t-1} + phi phi^T, r_t = lam r_{t-1} + phi y(t) (R_0 = I / delta):
        # the same estimate as the covariance-form RLS recursion, but solved afresh
        # every step, which stays accurate when the regressors are nearly collinear
        # (lightly damped modes sampled fast), where the P-update loses precision.
        hist = np.empty((n, p))
        zr = (np.eye(p) / float(self.delta)).reshape(1, -1) * lam
        zq = np.zeros((1, p))
        chunk = max(1, 2**20 // (p * p + p))
        for a in range(0, n, chunk):
            b = min(n, a + chunk)
            ph = phi[a:b]
            outer = (ph[:, :, None] * ph[:, None, :]).reshape(b - a, p * p)
            R, zr = signal.lfilter([1.0], [1.0, -lam], outer, axis=0, zi=zr)
            r, zq = signal.lfilter([1.0], [1.0, -lam], ph * y[a:b, None], axis=0, zi=zq)
            hist[a:b] = np.linalg.solve(R.reshape(-1, p, p), r[:, :, None])[:, :, 0]
        prev = np.vstack([np.zeros((1, p)), hist[:-1]])
        res = y - np.einsum("tp,tp->t", phi, prev)
        self.theta_ = hist
        self.residuals_ = res
        idx = np.arange(0, n, every)
        A = np.concatenate([np.ones((idx.size, 1)), hist[idx, :na]], axis=1)
        comp = np.zeros((idx.size, na, na))
        comp[:, 0, :] = -A[:, 1:]
        if na > 1:
            comp[:, np.arange(1, na), np.arange(na - 1)] = 1.0
        poles = np.linalg.eigvals(comp)
        self.tracks_ = PoleTracks.from_poles(idx / fs, track_poles(poles), fs)
        return self

    def _fitted(self):
        if not hasattr(self, "theta_"):
            raise NotFittedError("RecursiveARX is not fitted yet; call fit(y) first.")

    def modes(self, t: int = -1) -> tuple[np.ndarray, np.ndarray]:
        """Natural frequencies (Hz) and damping of the estimate at sample ``t``."""
        self._fitted()
        a = np.r_[1.0, self.theta_[t, : self.na]]
        fn, zeta, _ = modes_from_poles(np.roots(a), self.fs)
        return fn, zeta
