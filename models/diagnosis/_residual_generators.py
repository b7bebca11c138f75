"""Residual generators from identified models: channel-to-channel ARX, parity, input.

The rotor-diagnostics monograph (sections 2.4, 2.5) generates residuals three ways when
the excitation of a machine (its unbalance force) cannot be measured:

- **channel to channel** (sec. 2.4.1, "joint signal analysis"): two measured outputs,
  e.g. the vertical vibration at both bearings, are taken as the input and output of
  a virtual local model, an ARX model ``A(q) y_out = B(q) y_in + e`` identified on
  healthy data (:func:`channel_to_channel`);
- **parity equations**: that model, kept fixed, is a parity relation: its equation error
  ``r = A(q) y_out - B(q) y_in`` stays white with the healthy variance while the
  machine stays as it was, and grows when the transmission path between the two
  channels changes (a rub, a loose support) or the excitation moves (an unbalance on
  another disk); several relations give a structured residual vector
  (:class:`ParityEquations`, Gertler, *Fault Detection and Diagnosis in Engineering
  Systems*, 1998, ch. 6);
- **input-based residuals** (sec. 2.5): the identified model inverted,
  ``u_hat = B(q)^-1 A(q) y``, reconstructs the excitation (:func:`reconstruct_input`),
  compared with a reference input.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from scipy import signal
from sklearn.base import BaseEstimator

from pdmkit._checks import check_fs
from pdmkit.errors import DataError, ModelError, NotFittedError
from pdmkit.models.ident import IdentifiedModel, arx, select_order

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from numpy.typing import ArrayLike

__all__ = [
    "ParityEquations",
    "ParityResult",
    "channel_to_channel",
    "parity_residual",
    "reconstruct_input",
]


def _signal(x, name: str) -> np.ndarray:
    arr = np.asarray(x, dtype=float)
    if arr.ndim != 1 or arr.size < 10:
        raise DataError(
            f"{name} must be a 1-D record of at least 10 samples; got {arr.shape}."
        )
    if not np.all(np.isfinite(arr)):
        raise DataError(f"{name} holds NaN or inf values; clean them first.")
    return arr


def channel_to_channel(
    y_in: ArrayLike,
    y_out: ArrayLike,
    fs: float,
    *,
    order: int | None = None,
    nk: int = 0,
    criterion: str = "mdl",
    orders: Sequence[int] = tuple(range(2, 21, 2)),
) -> IdentifiedModel:
    """ARX model from one measured output to another (rotor monograph, sec. 2.4.1).

    Parameters
    ----------
    y_in, y_out : array_like (n,)
        The channel taken as the virtual input (the monograph: ``#2``) and as the output
        (``#4``); both are responses of the machine to the same unmeasured excitation.
    fs : float
        Sampling rate (Hz).
    order : int, optional
        ``na = nb = order``; None selects it from ``orders`` by ``criterion``
        (:func:`pdmkit.models.ident.select_order`, the monograph's appendix A, sec. 6.5).
    nk : int, default 0
        Delay of the input channel in samples (0: both channels see the excitation at
        the same time, the usual case for vibration probes).
    criterion : {"aic", "bic", "mdl"}, default "mdl"
    orders : sequence of int

    Returns
    -------
    IdentifiedModel
        ``info["selection"]`` holds the order comparison when the order was selected.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy import signal
    >>> rng = np.random.default_rng(0)
    >>> a = np.real(np.poly([0.95 * np.exp(0.4j), 0.95 * np.exp(-0.4j)]))
    >>> y_in = signal.lfilter([1.0], a, rng.normal(size=4000))
    >>> y_out = signal.lfilter([0.5, 0.2], [1.0, -0.3], y_in)  # the path between them
    >>> m = channel_to_channel(y_in, y_out, fs=100.0, order=1)
    >>> np.round(m.A, 3).tolist(), np.round(m.B, 3).tolist()
    ([1.0, -0.3], [0.5, 0.2])
    """
    fs = check_fs(fs)
    y_in, y_out = _signal(y_in, "y_in"), _signal(y_out, "y_out")
    if y_in.size != y_out.size:
        raise DataError(
            f"y_in has {y_in.size} samples, y_out {y_out.size}; they must match."
        )
    if order is not None:
        return arx(y_in, y_out, int(order), int(order) + 1, nk, fs=fs)
    cands = [{"na": int(n), "nb": int(n) + 1, "nk": int(nk)} for n in orders]
    sel = select_order(y_in, y_out, "arx", cands, criterion, fs=fs)
    model = sel.best_model
    model.info["selection"] = sel
    return model


def parity_residual(
    model: IdentifiedModel, y_in: ArrayLike, y_out: ArrayLike
) -> np.ndarray:
    """Equation error ``A(q) y_out - B(q) y_in`` of an ARX parity relation.

    The offsets removed at estimation are removed again; the first ``max(na, nb + nk)``
    samples (filter start-up) are set to zero.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy import signal
    >>> rng = np.random.default_rng(1)
    >>> y_in = rng.normal(size=3000)
    >>> y_out = signal.lfilter([0.4], [1.0, -0.5], y_in) + 0.01 * rng.normal(size=3000)
    >>> m = channel_to_channel(y_in, y_out, fs=1.0, order=1)
    >>> r = parity_residual(m, y_in, y_out)
    >>> bool(abs(r[10:].std() - 0.01) < 0.002)  # white, with the noise's level
    True
    """
    if not isinstance(model, IdentifiedModel) or model.structure != "arx":
        raise ModelError(
            "parity_residual needs an ARX IdentifiedModel (channel_to_channel)."
        )
    y_in, y_out = _signal(y_in, "y_in"), _signal(y_out, "y_out")
    if y_in.size != y_out.size:
        raise DataError(
            f"y_in has {y_in.size} samples, y_out {y_out.size}; they must match."
        )
    r = signal.lfilter(model.A, [1.0], y_out - model.y_offset) - signal.lfilter(
        model.B, [1.0], y_in - model.u_offset
    )
    r[: max(model.A.size, model.B.size) - 1] = 0.0
    return r


def _ewm_rms(x: np.ndarray, forgetting: float) -> np.ndarray:
    """Exponentially weighted RMS (unit DC gain, started at the first value)."""
    lam = float(forgetting)
    ms = signal.lfilter([1 - lam], [1.0, -lam], x**2, axis=0, zi=lam * x[:1] ** 2)[0]
    return np.sqrt(ms)


@dataclass(eq=False)
class ParityResult:
    """Residuals of parity relations over a record.

    Attributes
    ----------
    time : ndarray (n,)
    residuals : ndarray (n, n_relations)
        Equation errors.
    ratio : ndarray (n, n_relations)
        Their running RMS (exponential forgetting) over the healthy RMS: about 1 while
        the machine is as it was at fitting, above 1 when a relation is broken.
    names : list of str
        ``"in->out"`` per relation.

    Examples
    --------
    >>> r = ParityResult(np.arange(3.0), np.zeros((3, 1)), np.ones((3, 1)), ["a->b"])
    >>> r.to_pandas().columns.tolist()
    ['time', 'a->b', 'a->b ratio']
    """

    time: np.ndarray
    residuals: np.ndarray
    ratio: np.ndarray
    names: list

    def to_pandas(self) -> pd.DataFrame:
        """Columns ``time``, each relation's residual and ``<relation> ratio``."""
        data = {"time": self.time}
        for k, name in enumerate(self.names):
            data[name] = self.residuals[:, k]
            data[f"{name} ratio"] = self.ratio[:, k]
        return pd.DataFrame(data)

    def plot(self, ax: Axes | None = None) -> Axes:
        """The RMS ratios against time; returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 3))
        for k, name in enumerate(self.names):
            ax.plot(self.time, self.ratio[:, k], lw=0.8, label=name)
        ax.axhline(1.0, color="k", lw=0.5)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("residual RMS / healthy RMS")
        ax.legend(loc="best", fontsize="small")
        return ax


class ParityEquations(BaseEstimator):
    """Channel-to-channel ARX parity relations fitted on a healthy record.

    Parameters
    ----------
    pairs : sequence of (int, int)
        ``(input column, output column)`` of each relation, e.g. ``[(1, 3), (0, 2)]``
        for the monograph's ``#2 -> #4`` and ``#1 -> #3``.
    order : int, optional
        ARX order of every relation; None selects each by ``criterion``.
    criterion : {"aic", "bic", "mdl"}, default "mdl"
    forgetting : float, default 0.996
        Forgetting factor of the running RMS (memory ``1 / (1 - forgetting)`` samples;
        0.996 is the monograph's 256-sample buffer).
    notch : sequence of float, default ()
        Frequencies (Hz) taken out of the residuals by notch filters (quality factor
        ``notch_q``) before their RMS: on a rotor the synchronous components (1X, 2X)
        are the excitation, watched on their own, while the parity relations watch the
        transmission path.
    notch_q : float, default 30.0
    names : sequence of str, optional
        Channel names (default ``"ch1"``, ``"ch2"``, ...).

    Attributes
    ----------
    relations_ : list of IdentifiedModel
    sigma_ : ndarray
        Healthy RMS of each relation's residual.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy import signal
    >>> rng = np.random.default_rng(2)
    >>> e = rng.normal(size=6000)
    >>> Y = np.column_stack([e, signal.lfilter([0.5], [1, -0.6], e)])
    >>> Y[:, 1] += 0.02 * rng.normal(size=6000)
    >>> pe = ParityEquations([(0, 1)], order=1).fit(Y, fs=100.0)
    >>> Y2 = Y.copy()
    >>> Y2[3000:, 1] = signal.lfilter([0.8], [1, -0.6], e)[3000:]  # the path changed
    >>> res = pe.residuals(Y2)
    >>> bool(res.ratio[2900, 0] < 1.5), bool(res.ratio[-1, 0] > 5)
    (True, True)
    """

    def __init__(
        self,
        pairs: Sequence[tuple[int, int]],
        *,
        order: int | None = None,
        criterion: str = "mdl",
        forgetting: float = 0.996,
        notch: Sequence[float] = (),
        notch_q: float = 30.0,
        names: Sequence[str] | None = None,
    ):
        self.pairs = pairs
        self.order = order
        self.criterion = criterion
        self.forgetting = forgetting
        self.notch = notch
        self.notch_q = notch_q
        self.names = names

    def _columns(self, Y) -> np.ndarray:
        Y = np.asarray(Y, dtype=float)
        if Y.ndim != 2:
            raise DataError(f"Y must be (n_samples, n_channels); got shape {Y.shape}.")
        for a, b in self.pairs:
            if not (0 <= a < Y.shape[1] and 0 <= b < Y.shape[1]) or a == b:
                raise DataError(
                    f"pair ({a}, {b}) does not name two different columns of Y "
                    f"({Y.shape[1]} channels)."
                )
        return Y

    def fit(self, Y: ArrayLike, fs: float) -> ParityEquations:
        """Identify every relation on the healthy record ``Y`` (n_samples, n_channels)."""
        if not 0 < float(self.forgetting) < 1:
            raise ModelError(f"forgetting must be in (0, 1); got {self.forgetting!r}.")
        Y = self._columns(Y)
        names = (
            list(self.names) if self.names else [f"ch{i + 1}" for i in range(Y.shape[1])]
        )
        self.fs_ = check_fs(fs)
        self.relations_ = [
            channel_to_channel(
                Y[:, a], Y[:, b], fs, order=self.order, criterion=self.criterion
            )
            for a, b in self.pairs
        ]
        res = self._residuals(Y)
        skip = min(res.shape[0] // 10, 100)
        self.sigma_ = np.sqrt(np.mean(res[skip:] ** 2, axis=0))
        self.names_ = [f"{names[a]}->{names[b]}" for a, b in self.pairs]
        return self

    def _residuals(self, Y: np.ndarray) -> np.ndarray:
        res = np.column_stack(
            [
                parity_residual(m, Y[:, a], Y[:, b])
                for m, (a, b) in zip(self.relations_, self.pairs, strict=True)
            ]
        )
        for f0 in self.notch:
            if not 0 < float(f0) < self.fs_ / 2:
                raise ModelError(f"notch frequency {f0!r} Hz is not below Nyquist.")
            b, a = signal.iirnotch(float(f0), float(self.notch_q), fs=self.fs_)
            res = signal.lfilter(b, a, res, axis=0)
        return res

    def residuals(self, Y: ArrayLike) -> ParityResult:
        """Residuals and RMS ratios of the record ``Y`` (same channels as at fit)."""
        if not hasattr(self, "relations_"):
            raise NotFittedError("ParityEquations is not fitted; call fit(Y, fs) first.")
        res = self._residuals(self._columns(Y))
        ratio = _ewm_rms(res, self.forgetting) / self.sigma_
        return ParityResult(np.arange(Y.shape[0]) / self.fs_, res, ratio, self.names_)


def reconstruct_input(model: IdentifiedModel, y: ArrayLike) -> np.ndarray:
    """The input an ARX model needs to produce ``y``: ``u_hat = B(q)^-1 A(q) y``.

    The monograph's input-based residual (sec. 2.5, Fig. 12): the inverse model connected
    after the system gives back its excitation, ``H(z) H_inv(z) = 1``. The delay
    ``nk`` is undone by shifting (``u_hat[t]`` is the input at ``t``; the last ``nk``
    samples are NaN). A zero of ``B`` outside the unit circle makes the exact inverse
    unstable; it is reflected inside (same magnitude response, the phase of an
    all-pass is lost), as the monograph's "feasible inversion" does.

    Parameters
    ----------
    model : IdentifiedModel
        An ARX model with an input (:func:`pdmkit.models.ident.arx`).
    y : array_like (n,)
        Output record.

    Returns
    -------
    ndarray (n,)

    Examples
    --------
    >>> import numpy as np
    >>> from scipy import signal
    >>> from pdmkit.models.ident import arx
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=3000)
    >>> y = signal.lfilter([0, 1.0, 0.5], [1, -1.2, 0.5], u)
    >>> m = arx(u, y, 2, 2, 1, remove_mean=False)
    >>> u_hat = reconstruct_input(m, y)
    >>> bool(np.max(np.abs(u_hat[10:-1] - u[10:-1])) < 1e-6)
    True
    """
    if not isinstance(model, IdentifiedModel) or model.structure != "arx":
        raise ModelError("reconstruct_input needs an ARX IdentifiedModel with an input.")
    y = _signal(y, "y")
    nk = int(model.orders.get("nk", 0))
    b = np.trim_zeros(np.asarray(model.B, dtype=float), "f")
    if b.size == 0 or not np.any(b):
        raise ModelError(
            "the model's B polynomial is zero: it has no input to reconstruct."
        )
    zeros = np.roots(b) if b.size > 1 else np.zeros(0)
    outside = np.abs(zeros) > 1.0
    if np.any(outside):
        gain = b[0] * np.prod(np.abs(zeros[outside]))
        zeros = np.where(outside, 1.0 / np.conj(zeros), zeros)
        b = np.real(gain * np.poly(zeros)) if zeros.size else np.array([gain])
    v = signal.lfilter(model.A, b, y - model.y_offset) + model.u_offset
    out = np.full(y.size, np.nan)
    out[: y.size - nk] = v[nk:]
    return out
