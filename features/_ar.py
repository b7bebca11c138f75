"""Model-based condition indicators from an AR model of each member (group ``"ar"``).

Each member's signal (mean removed) is fitted with an autoregressive model
``y(t) + a1 y(t-1) + ... + a_p y(t-p) = e(t)`` by least squares (the covariance
method: normal equations over the samples with a complete past), for all members of a
chunk at once. The poles of the model are the roots of ``A``; every complex pair is a
resonance with natural frequency ``|s| / 2 pi`` and damping ratio ``-Re(s) / |s|``,
``s = fs ln(z)``, the usual indicators of rotor and structure vibration (a crack lowers
a natural frequency, a loosening raises the damping). The fit quality says how much of
the signal the model explains.

=================  ==============================================================
Freq<k>, Damp<k>   natural frequency (Hz) and damping ratio of the ``k``-th
                   resonance (complex pole pair), ascending in frequency;
                   ``k = 1 .. order // 2``, NaN when the model has fewer pairs
Fit                one-step prediction fit in percent,
                   ``100 (1 - ||e|| / ||y - mean(y)||)``
ResidualStd        standard deviation of the one-step prediction error ``e``
=================  ==============================================================
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from pdmkit.errors import DataError
from pdmkit.features._common import check_fs, nonfinite_rows, raise_nonfinite

__all__ = [
    "AR_DEFAULT_ORDER",
    "ar_feature_names",
    "ar_features",
    "resolve_ar_options",
]

#: Default AR model order (four resonances).
AR_DEFAULT_ORDER = 8


def resolve_ar_options(order=AR_DEFAULT_ORDER, n_samples: int | None = None) -> dict:
    """Check the options of group ``"ar"``; returns ``{"order": int}``.

    Examples
    --------
    >>> resolve_ar_options(6)
    {'order': 6}
    """
    if isinstance(order, bool) or not isinstance(order, int | np.integer) or order < 1:
        raise DataError(f"ar order must be an integer >= 1; got {order!r}")
    if n_samples is not None and n_samples <= 3 * order:
        raise DataError(
            f"members have {n_samples} samples; an AR({order}) model needs more than "
            f"{3 * order}: lower the order or use longer records"
        )
    return {"order": int(order)}


def ar_feature_names(order: int = AR_DEFAULT_ORDER) -> list[str]:
    """Feature names of group ``"ar"`` for a model of ``order``.

    Examples
    --------
    >>> ar_feature_names(4)
    ['Freq1', 'Damp1', 'Freq2', 'Damp2', 'Fit', 'ResidualStd']
    """
    names = []
    for k in range(1, int(order) // 2 + 1):
        names += [f"Freq{k}", f"Damp{k}"]
    return [*names, "Fit", "ResidualStd"]


def _ar_feature_rows(x: np.ndarray, fs: float, opts: dict) -> dict[str, np.ndarray]:
    """Indicators of every row of a finite 2-D array ``(members, samples)``."""
    p = int(opts["order"])
    m, n = x.shape
    y = x - x.mean(axis=1, keepdims=True)
    # normal equations: R[i, j] = sum_t y(t-i) y(t-j), t = p .. n-1, i, j = 0 .. p
    lagged = [y[:, p - i : n - i] for i in range(p + 1)]
    R = np.empty((m, p + 1, p + 1))
    for i in range(p + 1):
        for j in range(i, p + 1):
            R[:, i, j] = R[:, j, i] = np.einsum("mt,mt->m", lagged[i], lagged[j])
    # A y = e  ->  sum_j a_j y(t-j) = -y(t): R11 a = -r10
    R11 = (
        R[:, 1:, 1:]
        + np.eye(p) * 1e-12 * np.trace(R[:, 1:, 1:], axis1=1, axis2=2)[:, None, None] / p
    )
    a = np.linalg.solve(R11, -R[:, 1:, 0][:, :, None])[:, :, 0]
    e = lagged[0].copy()
    for i in range(1, p + 1):
        e += a[:, i - 1 : i] * lagged[i]
    comp = np.zeros((m, p, p))
    comp[:, 0, :] = -a
    if p > 1:
        comp[:, np.arange(1, p), np.arange(p - 1)] = 1.0
    z = np.linalg.eigvals(comp)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.log(z) * fs
        wn = np.abs(s)
        zeta = -s.real / wn
    pair = z.imag > 1e-12 * np.maximum(1.0, np.abs(z))
    fn = np.where(pair, wn / (2 * np.pi), np.nan)
    zeta = np.where(pair, zeta, np.nan)
    order = np.argsort(fn, axis=1)  # NaN last
    fn = np.take_along_axis(fn, order, axis=1)
    zeta = np.take_along_axis(zeta, order, axis=1)
    out: dict[str, np.ndarray] = {}
    for k in range(p // 2):
        out[f"Freq{k + 1}"] = fn[:, k]
        out[f"Damp{k + 1}"] = zeta[:, k]
    den = np.linalg.norm(lagged[0], axis=1)
    den = np.where(den > 0, den, np.finfo(float).tiny)
    out["Fit"] = 100.0 * (1.0 - np.linalg.norm(e, axis=1) / den)
    out["ResidualStd"] = e.std(axis=1)
    return out


def ar_features(
    signals: ArrayLike, fs: float, *, order: int = AR_DEFAULT_ORDER, axis: int = -1
) -> pd.DataFrame:
    """AR-model indicators (resonances, damping, fit) of one signal or a batch.

    Parameters
    ----------
    signals : array_like
        1-D (one member) or 2-D ``(members, samples)``, finite.
    fs : float
        Sampling rate in Hz.
    order : int, default 8
        AR model order (``order // 2`` resonances at most).
    axis : int, default -1
        Axis holding the samples.

    Returns
    -------
    pandas.DataFrame
        One row per member, columns ``ar/<Name>`` (see the module notes).

    Raises
    ------
    pdmkit.errors.DataError
        NaN/inf samples (naming the rows), or members too short for the order.

    Examples
    --------
    Two members, each a resonance at 50 or 80 Hz (damping 0.02) driven by noise:

    >>> import numpy as np
    >>> from scipy import signal
    >>> fs, rng = 1000.0, np.random.default_rng(0)
    >>> def member(fn, zeta=0.02):
    ...     s = 2 * np.pi * fn * (-zeta + 1j * np.sqrt(1 - zeta**2))
    ...     a = np.real(np.poly(np.exp(np.array([s, s.conjugate()]) / fs)))
    ...     return signal.lfilter([1.0], a, rng.normal(size=20000))
    >>> table = ar_features(np.stack([member(50.0), member(80.0)]), fs, order=2)
    >>> table[["ar/Freq1", "ar/Damp1"]].round({"ar/Freq1": 0, "ar/Damp1": 2})
       ar/Freq1  ar/Damp1
    0      50.0      0.02
    1      80.0      0.02
    """
    fs = check_fs(fs)
    arr = np.asarray(signals, dtype=float)
    if arr.ndim not in (1, 2):
        raise DataError(
            f"signals must be 1-D or 2-D (members x samples); got shape {arr.shape}"
        )
    arr = np.moveaxis(arr, axis, -1) if arr.ndim == 2 else arr
    if arr.ndim == 1:
        arr = arr[None, :]
    opts = resolve_ar_options(order, arr.shape[1])
    bad, details = nonfinite_rows(arr)
    raise_nonfinite(bad, details, name="signals")
    rows = _ar_feature_rows(np.ascontiguousarray(arr), fs, opts)
    return pd.DataFrame({f"ar/{k}": v for k, v in rows.items()})
