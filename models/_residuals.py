"""Tests on residuals shared by every model subpackage.

:func:`whiteness_test` (is a residual noise: Ljung-Box and the ``2.58 / sqrt(N)`` band on
its auto-correlation and its cross-correlation with the inputs; Ljung, *System
Identification*, 2nd ed., 1999, sec. 16.6) and :func:`dm_test` (does one model predict
better than another: the one-sided Diebold-Mariano test with a Newey-West variance;
Diebold & Mariano 1995, Newey & West 1994).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np

from pdmkit.errors import DataError

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["dm_test", "effective_samples", "whiteness_test"]


def _acf(r: np.ndarray, max_lag: int) -> np.ndarray:
    """Autocorrelation at lags ``1..max_lag`` (zero past the record), by FFT."""
    r = r - r.mean()
    n = r.size
    f = np.fft.rfft(r, 2 * n)  # zero-padded: the linear, not circular, correlation
    c = np.fft.irfft(f * np.conj(f), 2 * n)[: min(max_lag, n - 1) + 1]
    out = np.zeros(max_lag)
    out[: c.size - 1] = c[1:] / (float(c[0]) or 1.0)
    return out


def _xcf(r: np.ndarray, u: np.ndarray, max_lag: int) -> np.ndarray:
    """Cross-correlation rho_ru(k) = corr(r[t], u[t-k]) for k in -max_lag..max_lag."""
    r = r - r.mean()
    u = u - u.mean()
    d = math.sqrt(float(np.dot(r, r)) * float(np.dot(u, u))) or 1.0
    out = []
    n = r.size
    for k in range(-max_lag, max_lag + 1):
        if k >= 0:
            out.append(np.dot(r[k:], u[: n - k]) / d)
        else:
            out.append(np.dot(r[: n + k], u[-k:]) / d)
    return np.array(out)


def effective_samples(r: np.ndarray) -> float:
    """Independent samples a residual is worth: its length over its autocorrelation time.

    ``tau = 1 + 2 sum rho_k`` over the lags before the autocorrelation first drops to
    zero (Geyer's initial positive sequence), per output column, the largest ``tau``
    kept. A simulation's residual on a real recording is smooth: on the rig's lever
    position (1000 samples at 100 Hz) its lag-1 correlation is 0.98, which an AR(1)
    model reads as 10 independent samples; its autocorrelation is gone after 14 lags
    (``tau`` 13: 75 samples).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> round(effective_samples(rng.normal(size=(4000, 1))) / 4000, 1)   # white: all
    1.0
    >>> smooth = np.convolve(rng.normal(size=4020), np.ones(20) / 20, "valid")[:, None]
    >>> 100 < effective_samples(smooth) < 400   # a 20-sample moving average: ~ n / 20
    True
    """
    r = np.asarray(r, dtype=float).reshape(len(r), -1)
    n = r.shape[0]
    if n < 3:
        return float(n)
    tau = 1.0
    for col in r.T:
        if not np.any(col - col.mean()):
            continue
        acf = _acf(col, n - 1)
        stop = np.flatnonzero(acf <= 0.0)
        k = int(stop[0]) if stop.size else n - 1
        tau = max(tau, 1.0 + 2.0 * float(np.sum(acf[:k])))
    return float(min(max(n / tau, 1.0), n))


def whiteness_test(
    residual: ArrayLike,
    inputs: Mapping[str, np.ndarray] | None = None,
    max_lag: int | None = None,
) -> dict:
    """Whether anything systematic is left in the residual (Ljung-Box, correlation bands).

    Parameters
    ----------
    residual : array_like, shape (N,)
    inputs : dict of str to array_like (N,), optional
        Inputs for the cross-correlation test.
    max_lag : int, optional
        Lags tested (default ``min(25, N // 5)``).

    Returns
    -------
    dict
        ``ljung_box_q``, ``p_value`` (chi-square with ``max_lag`` degrees of freedom),
        ``bound`` (2.58/sqrt(N)), ``acf_outside`` (fraction of autocorrelations outside
        the bound), ``acf_max``, ``white`` (p_value > 0.01), and per input
        ``xcorr_max``, ``xcorr_lag`` (samples; positive: the residual follows the
        input), ``xcorr_outside``, ``uncorrelated``.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.mismatch._locate import whiteness_test
    >>> rng = np.random.default_rng(0)
    >>> whiteness_test(rng.normal(size=2000))["white"]
    True
    >>> u = rng.normal(size=2000)
    >>> res = whiteness_test(np.roll(u, 3) + 0.1 * rng.normal(size=2000), {"u": u})
    >>> res["white"], res["inputs"]["u"]["xcorr_lag"]
    (True, 3)
    """
    from scipy import stats

    r = np.asarray(residual, dtype=float).ravel()
    n = r.size
    max_lag = int(min(25, max(1, n // 5)) if max_lag is None else max_lag)
    rho = _acf(r, max_lag)
    bound = 2.58 / math.sqrt(n)
    k = np.arange(1, max_lag + 1)
    q = float(n * (n + 2) * np.sum(rho**2 / (n - k)))
    p = float(stats.chi2.sf(q, max_lag))
    out = {
        "n": n,
        "max_lag": max_lag,
        "ljung_box_q": q,
        "p_value": p,
        "bound": bound,
        "acf_outside": float(np.mean(np.abs(rho) > bound)),
        "acf_max": float(np.max(np.abs(rho))),
        "white": bool(p > 0.01),
        "inputs": {},
    }
    for name, u in (inputs or {}).items():
        u = np.asarray(u, dtype=float).ravel()
        if u.size != n:
            raise DataError(f"input {name!r} has {u.size} samples, the residual {n}.")
        if np.std(u) == 0:
            continue
        x = _xcf(r, u, max_lag)
        i = int(np.argmax(np.abs(x)))
        out["inputs"][name] = {
            "xcorr_max": float(abs(x[i])),
            "xcorr_lag": i - max_lag,
            "xcorr_outside": float(np.mean(np.abs(x) > bound)),
            "uncorrelated": bool(np.all(np.abs(x) <= bound)),
        }
    return out


def dm_test(e_ref: np.ndarray, e_new: np.ndarray) -> tuple[float, float]:
    """One-sided Diebold-Mariano test that ``e_new`` has smaller squared errors.

    ``d_t = sum(e_ref**2) - sum(e_new**2)`` (over outputs); the variance of its mean is
    a Bartlett (Newey-West) HAC estimate with the plug-in bandwidth
    ``floor(4 (N/100)^(2/9))``.

    Returns
    -------
    (statistic, p_value)

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.mismatch import dm_test
    >>> rng = np.random.default_rng(0)
    >>> noise = rng.normal(size=500)
    >>> round(dm_test(noise + 1.0, noise)[1], 6)
    0.0
    >>> bool(dm_test(noise, noise + 0.01 * rng.normal(size=500))[1] > 0.01)
    True
    """
    from scipy import stats

    a = np.asarray(e_ref, dtype=float)
    b = np.asarray(e_new, dtype=float)
    a = a[:, None] if a.ndim == 1 else a
    b = b[:, None] if b.ndim == 1 else b
    with np.errstate(over="ignore", invalid="ignore"):
        d = np.sum(a**2, axis=1) - np.sum(b**2, axis=1)
    if not np.all(np.isfinite(d)):  # a diverged simulation: infinitely worse
        worse = bool(np.any(np.isnan(d)) or np.any(d == -np.inf))
        return (-math.inf, 1.0) if worse else (math.inf, 0.0)
    n = d.size
    dc = d - d.mean()
    g0 = float(np.dot(dc, dc) / n)
    if g0 <= 0:
        return (math.inf if d.mean() > 0 else 0.0), (0.0 if d.mean() > 0 else 1.0)
    var = g0
    # Newey-West (1994) plug-in bandwidth
    L = int(min(max(1, math.floor(4.0 * (n / 100.0) ** (2.0 / 9.0))), n - 1))
    for k in range(1, L + 1):
        gk = float(np.dot(dc[k:], dc[: n - k]) / n)
        var += 2.0 * (1.0 - k / (L + 1)) * gk
    var = max(var, g0 / n)
    stat = float(d.mean() / math.sqrt(var / n))
    return stat, float(stats.norm.sf(stat))
