"""AR and ARX models by linear least squares (Ljung 1999, sec. 7.3)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from pdmkit._checks import check_fs as _check_fs
from pdmkit.errors import DataError
from pdmkit.models.ident._model import (
    IdentifiedModel,
    _as_signal,
    _check_order,
    _finish,
    _lag_matrix,
)

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["ar", "arx"]


def ar(y: ArrayLike, na: int, *, fs: float = 1.0) -> IdentifiedModel:
    """AR model ``A(q) y = e`` of order ``na`` by least squares (covariance method).

    Parameters
    ----------
    y : array_like, shape (N,)
        The time series (its mean is removed and kept as ``y_offset``).
    na : int
        Model order (number of poles).
    fs : float, default 1.0
        Sampling rate in Hz.

    Returns
    -------
    IdentifiedModel

    Examples
    --------
    >>> import numpy as np
    >>> from scipy import signal
    >>> rng = np.random.default_rng(1)
    >>> fs, fn, zeta = 1000.0, 50.0, 0.02
    >>> s = -zeta * 2 * np.pi * fn + 2j * np.pi * fn * np.sqrt(1 - zeta**2)
    >>> a = np.real(np.poly(np.exp(np.array([s, s.conjugate()]) / fs)))
    >>> y = signal.lfilter([1.0], a, rng.normal(size=20000))
    >>> m = ar(y, 2, fs=fs)
    >>> round(float(m.natural_frequencies_hz[0]), 1), round(float(m.damping[0]), 3)
    (50.0, 0.02)
    """
    fs = _check_fs(fs)
    na = _check_order(na, "na", 1)
    y = _as_signal(y, "y")
    if y.size <= 2 * na:
        raise DataError(f"y has {y.size} samples; an AR({na}) needs more than {2 * na}.")
    off = float(y.mean())
    yc = y - off
    phi = -_lag_matrix(yc, range(1, na + 1), na)
    theta = np.linalg.lstsq(phi, yc[na:], rcond=None)[0]
    m = IdentifiedModel(
        "ar",
        fs,
        {"na": na},
        A=np.r_[1.0, theta],
        n_params=na,
        n_samples=y.size - na,
        y_offset=off,
    )
    return _finish(m, None, y)


def _arx_theta(uc: np.ndarray, yc: np.ndarray, na: int, nb: int, nk: int) -> np.ndarray:
    start = max(na, nb + nk - 1, 1)
    cols = []
    if na:
        cols.append(-_lag_matrix(yc, range(1, na + 1), start))
    cols.append(_lag_matrix(uc, range(nk, nk + nb), start))
    phi = np.concatenate(cols, axis=1)
    return np.linalg.lstsq(phi, yc[start:], rcond=None)[0]


def arx(
    u: ArrayLike,
    y: ArrayLike,
    na: int,
    nb: int,
    nk: int = 1,
    *,
    fs: float = 1.0,
    remove_mean: bool = True,
) -> IdentifiedModel:
    """ARX model ``A(q) y = B(q) u + e`` by linear least squares.

    Parameters
    ----------
    u, y : array_like, shape (N,)
        Input and output.
    na, nb, nk : int
        Poles, numerator coefficients and input delay in samples
        (``B = [0]*nk + [b0, ..., b_{nb-1}]``).
    fs : float, default 1.0
        Sampling rate in Hz.
    remove_mean : bool, default True
        Remove the means of ``u`` and ``y`` first (kept as offsets).

    Returns
    -------
    IdentifiedModel

    Examples
    --------
    >>> import numpy as np
    >>> from scipy import signal
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=5000)
    >>> y = signal.lfilter([0, 1.0, 0.5], [1, -1.2, 0.5], u) + 0.01 * rng.normal(size=5000)
    >>> m = arx(u, y, na=2, nb=2, nk=1)
    >>> np.round(m.B, 2), np.round(m.A, 2)
    (array([0. , 1. , 0.5]), array([ 1. , -1.2,  0.5]))
    """
    fs = _check_fs(fs)
    na = _check_order(na, "na", 0)
    nb = _check_order(nb, "nb", 1)
    nk = _check_order(nk, "nk", 0)
    u = _as_signal(u, "u")
    y = _as_signal(y, "y")
    if u.size != y.size:
        raise DataError(f"u has {u.size} samples but y has {y.size}; they must match.")
    if y.size <= 2 * (na + nb + nk):
        raise DataError(f"y has {y.size} samples; too few for ARX({na},{nb},{nk}).")
    uo, yo = (float(u.mean()), float(y.mean())) if remove_mean else (0.0, 0.0)
    theta = _arx_theta(u - uo, y - yo, na, nb, nk)
    m = IdentifiedModel(
        "arx",
        fs,
        {"na": na, "nb": nb, "nk": nk},
        A=np.r_[1.0, theta[:na]],
        B=np.r_[np.zeros(nk), theta[na:]],
        n_params=na + nb,
        n_samples=y.size - max(na, nb + nk - 1, 1),
        u_offset=uo,
        y_offset=yo,
    )
    return _finish(m, u, y)
