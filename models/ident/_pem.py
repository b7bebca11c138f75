"""Prediction-error identification of ARMAX, output-error and Box-Jenkins models.

The parameters minimise the sum of squared one-step prediction errors (Ljung 1999,
ch. 7)::

    e(t) = D(q) / C(q) * (A(q) y(t) - B(q) / F(q) u(t))

with :func:`scipy.optimize.least_squares` (Levenberg-Marquardt). ``C`` and ``F`` are
kept stable by reflecting roots that leave the unit circle (the predictor exists only
for stable ``C`` and ``F``). Starting points are linear estimates: Hannan-Rissanen
(high-order ARX for the innovations, then least squares) for ARMAX and the noise part
of BJ, Steiglitz-McBride iterations for the OE part of OE and BJ.
"""

from __future__ import annotations

import warnings
from typing import TYPE_CHECKING

import numpy as np
from scipy import optimize, signal

from pdmkit.errors import ConvergenceWarning, DataError
from pdmkit.models.ident._arx import _arx_theta
from pdmkit.models.ident._model import (
    IdentifiedModel,
    _as_signal,
    _check_fs,
    _check_order,
    _finish,
    _lag_matrix,
    _stabilise,
)

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["armax", "bj", "oe"]


def _prep(u, y, fs):
    fs = _check_fs(fs)
    u = _as_signal(u, "u")
    y = _as_signal(y, "y")
    if u.size != y.size:
        raise DataError(f"u has {u.size} samples but y has {y.size}; they must match.")
    return u, y, fs, float(u.mean()), float(y.mean())


def _errors(A, B, C, D, F, u, y) -> np.ndarray:
    v = signal.lfilter(A, [1.0], y) - signal.lfilter(B, F, u)
    return signal.lfilter(D, C, v)


def _hannan_rissanen(u, y, na, nb, nc, nk):
    """ARMAX starting point: innovations from a long ARX, then least squares."""
    n = y.size
    nh = int(min(max(20, 3 * (na + nb + nc)), n // 10))
    if u is None:
        th = np.linalg.lstsq(-_lag_matrix(y, range(1, nh + 1), nh), y[nh:], rcond=None)[0]
        e = signal.lfilter(np.r_[1.0, th], [1.0], y)
    else:
        th = _arx_theta(u, y, nh, nh, nk)
        e = signal.lfilter(np.r_[1.0, th[:nh]], [1.0], y) - signal.lfilter(
            np.r_[np.zeros(nk), th[nh:]], [1.0], u
        )
    e[:nh] = 0.0
    start = max(na, nb + nk - 1, nc, 1) + nh
    cols = []
    if na:
        cols.append(-_lag_matrix(y, range(1, na + 1), start))
    if u is not None and nb:
        cols.append(_lag_matrix(u, range(nk, nk + nb), start))
    if nc:
        cols.append(_lag_matrix(e, range(1, nc + 1), start))
    if not cols:
        return np.ones(1), np.zeros(0), np.ones(1)
    phi = np.concatenate(cols, axis=1)
    theta = np.linalg.lstsq(phi, y[start:], rcond=None)[0]
    a = np.r_[1.0, theta[:na]]
    b = np.r_[np.zeros(nk), theta[na : na + nb]] if u is not None else np.zeros(0)
    c = _stabilise(np.r_[1.0, theta[na + nb * (u is not None) :]])
    return a, b, c


def _steiglitz_mcbride(u, y, nb, nf, nk, n_iter: int = 12):
    """OE starting point: ARX on data prefiltered by 1/F, iterated."""
    th = _arx_theta(u, y, nf, nb, nk)
    f = _stabilise(np.r_[1.0, th[:nf]])
    b = np.r_[np.zeros(nk), th[nf:]]
    for _ in range(n_iter):
        uf = signal.lfilter([1.0], f, u)
        yf = signal.lfilter([1.0], f, y)
        th = _arx_theta(uf, yf, nf, nb, nk)
        f_new = _stabilise(np.r_[1.0, th[:nf]])
        b = np.r_[np.zeros(nk), th[nf:]]
        if np.allclose(f_new, f, atol=1e-10):
            f = f_new
            break
        f = f_new
    return b, f


def _pem(u, y, x0, unpack, max_nfev: int):
    """Minimise the prediction errors over theta; returns the final polynomials."""

    def resid(theta):
        A, B, C, D, F = unpack(theta)
        C, F = _stabilise(C), _stabilise(F)
        e = _errors(A, B, C, D, F, u, y)
        if not np.all(np.isfinite(e)):
            return np.full(y.size, 1e6)
        return e

    res = optimize.least_squares(resid, x0, method="lm", max_nfev=max_nfev, x_scale="jac")
    if res.status == 0:
        warnings.warn(
            f"prediction-error fit stopped after {res.nfev} evaluations without "
            "converging; raise max_nfev or check the orders.",
            ConvergenceWarning,
            stacklevel=3,
        )
    A, B, C, D, F = unpack(res.x)
    return A, B, _stabilise(C), D, _stabilise(F), res


def armax(
    u: ArrayLike,
    y: ArrayLike,
    na: int,
    nb: int,
    nc: int,
    nk: int = 1,
    *,
    fs: float = 1.0,
    max_nfev: int = 200,
) -> IdentifiedModel:
    """ARMAX model ``A y = B u + C e`` by the prediction-error method.

    Parameters
    ----------
    u, y : array_like, shape (N,)
        Input and output (means removed and kept as offsets).
    na, nb, nc, nk : int
        Orders of ``A``, ``B`` (coefficients), ``C`` and the input delay.
    fs : float, default 1.0
        Sampling rate in Hz.
    max_nfev : int, default 200
        Cap on residual evaluations of the optimiser.

    Returns
    -------
    IdentifiedModel

    Examples
    --------
    >>> import numpy as np
    >>> from scipy import signal
    >>> rng = np.random.default_rng(0)
    >>> u, e = rng.normal(size=(2, 5000))
    >>> y = signal.lfilter([0, 1.0], [1, -0.8], u) + signal.lfilter([1, 0.6], [1, -0.8], e)
    >>> m = armax(u, y, na=1, nb=1, nc=1)
    >>> np.round(m.A, 1), np.round(m.C, 1)
    (array([ 1. , -0.8]), array([1. , 0.6]))
    """
    u, y, fs, uo, yo = _prep(u, y, fs)
    na = _check_order(na, "na", 0)
    nb = _check_order(nb, "nb", 1)
    nc = _check_order(nc, "nc", 0)
    nk = _check_order(nk, "nk", 0)
    uc, yc = u - uo, y - yo
    a, b, c = _hannan_rissanen(uc, yc, na, nb, nc, nk)

    def unpack(th):
        return (
            np.r_[1.0, th[:na]],
            np.r_[np.zeros(nk), th[na : na + nb]],
            np.r_[1.0, th[na + nb :]],
            np.ones(1),
            np.ones(1),
        )

    x0 = np.r_[a[1:], b[nk:], c[1:]]
    A, B, C, _, _, res = _pem(uc, yc, x0, unpack, max_nfev)
    m = IdentifiedModel(
        "armax",
        fs,
        {"na": na, "nb": nb, "nc": nc, "nk": nk},
        A=A,
        B=B,
        C=C,
        n_params=na + nb + nc,
        n_samples=y.size,
        u_offset=uo,
        y_offset=yo,
        info={"nfev": res.nfev},
    )
    return _finish(m, u, y)


def oe(
    u: ArrayLike,
    y: ArrayLike,
    nb: int,
    nf: int,
    nk: int = 1,
    *,
    fs: float = 1.0,
    max_nfev: int = 200,
) -> IdentifiedModel:
    """Output-error model ``y = B / F u + e`` by the prediction-error method.

    Minimises the simulation error, so it is unbiased under white (or coloured)
    output noise where ARX is not; started from Steiglitz-McBride iterations.

    Parameters
    ----------
    u, y : array_like, shape (N,)
    nb, nf, nk : int
        Coefficients of ``B``, order of ``F`` (poles) and input delay.
    fs : float, default 1.0
    max_nfev : int, default 200

    Returns
    -------
    IdentifiedModel

    Examples
    --------
    >>> import numpy as np
    >>> from scipy import signal
    >>> rng = np.random.default_rng(1)
    >>> u = rng.normal(size=4000)
    >>> y = signal.lfilter([0, 0.3], [1, -1.6, 0.8], u) + 0.3 * rng.normal(size=4000)
    >>> np.round(oe(u, y, nb=1, nf=2).F, 2)
    array([ 1. , -1.6,  0.8])
    """
    u, y, fs, uo, yo = _prep(u, y, fs)
    nb = _check_order(nb, "nb", 1)
    nf = _check_order(nf, "nf", 0)
    nk = _check_order(nk, "nk", 0)
    uc, yc = u - uo, y - yo
    b, f = _steiglitz_mcbride(uc, yc, nb, nf, nk)

    def unpack(th):
        return (
            np.ones(1),
            np.r_[np.zeros(nk), th[:nb]],
            np.ones(1),
            np.ones(1),
            np.r_[1.0, th[nb:]],
        )

    _, B, _, _, F, res = _pem(uc, yc, np.r_[b[nk:], f[1:]], unpack, max_nfev)
    m = IdentifiedModel(
        "oe",
        fs,
        {"nb": nb, "nf": nf, "nk": nk},
        B=B,
        F=F,
        n_params=nb + nf,
        n_samples=y.size,
        u_offset=uo,
        y_offset=yo,
        info={"nfev": res.nfev},
    )
    return _finish(m, u, y)


def bj(
    u: ArrayLike,
    y: ArrayLike,
    nb: int,
    nc: int,
    nd: int,
    nf: int,
    nk: int = 1,
    *,
    fs: float = 1.0,
    max_nfev: int = 300,
) -> IdentifiedModel:
    """Box-Jenkins model ``y = B / F u + C / D e`` by the prediction-error method.

    Started from an OE fit (Steiglitz-McBride) for ``B/F`` and a Hannan-Rissanen
    ARMA fit of its residual for ``C/D``.

    Parameters
    ----------
    u, y : array_like, shape (N,)
    nb, nc, nd, nf, nk : int
        Orders of ``B`` (coefficients), ``C``, ``D``, ``F`` and the input delay.
    fs : float, default 1.0
    max_nfev : int, default 300

    Returns
    -------
    IdentifiedModel

    Examples
    --------
    >>> import numpy as np
    >>> from scipy import signal
    >>> rng = np.random.default_rng(4)
    >>> u, e = rng.normal(size=(2, 6000))
    >>> y = signal.lfilter([0, 0.5], [1, -0.9], u) + signal.lfilter([1], [1, -0.5], e)
    >>> m = bj(u, y, nb=1, nc=0, nd=1, nf=1)
    >>> np.round(m.F, 1), np.round(m.D, 1)
    (array([ 1. , -0.9]), array([ 1. , -0.5]))
    """
    u, y, fs, uo, yo = _prep(u, y, fs)
    nb = _check_order(nb, "nb", 1)
    nc = _check_order(nc, "nc", 0)
    nd = _check_order(nd, "nd", 0)
    nf = _check_order(nf, "nf", 0)
    nk = _check_order(nk, "nk", 0)
    uc, yc = u - uo, y - yo
    b, f = _steiglitz_mcbride(uc, yc, nb, nf, nk)
    v = yc - signal.lfilter(b, f, uc)
    d, _, c = _hannan_rissanen(None, v, nd, 0, nc, 1)
    d = _stabilise(d)

    def unpack(th):
        i = 0
        B = np.r_[np.zeros(nk), th[i : i + nb]]
        i += nb
        C = np.r_[1.0, th[i : i + nc]]
        i += nc
        D = np.r_[1.0, th[i : i + nd]]
        i += nd
        F = np.r_[1.0, th[i : i + nf]]
        return np.ones(1), B, C, D, F

    x0 = np.r_[b[nk:], c[1:], d[1:], f[1:]]
    _, B, C, D, F, res = _pem(uc, yc, x0, unpack, max_nfev)
    m = IdentifiedModel(
        "bj",
        fs,
        {"nb": nb, "nc": nc, "nd": nd, "nf": nf, "nk": nk},
        B=B,
        C=C,
        D=_stabilise(D),
        F=F,
        n_params=nb + nc + nd + nf,
        n_samples=y.size,
        u_offset=uo,
        y_offset=yo,
        info={"nfev": res.nfev},
    )
    return _finish(m, u, y)
