"""Rational transfer functions fitted to FRF data (MATLAB's ``invfreqs`` / ``invfreqz``).

Levy's linearised least squares, Sanathanan-Koerner iterations, an optional Gauss-Newton
output-error refinement, unstable poles reflected into the stable region (Levy 1959;
Sanathanan & Koerner 1963); ``s`` or ``z`` domain.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
import scipy.optimize as sopt

from pdmkit._checks import check_fs as _check_fs
from pdmkit.errors import DataError, ModelError
from pdmkit.models.frequency._frf import _DB, _as_float_array

if TYPE_CHECKING:
    import control
    from matplotlib.axes import Axes
    from numpy.typing import ArrayLike

__all__ = ["TFFit", "fit_tf"]


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

    def frequency_response(self, freq: ArrayLike) -> np.ndarray:
        """Complex response at frequencies ``freq`` (Hz)."""
        w = 2 * np.pi * np.asarray(freq, dtype=float)
        return _tf_eval(self.num, self.den, w, self.domain, self.dt)

    def to_control(self) -> control.TransferFunction:
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

    def plot(self, ax: Axes | None = None) -> Axes:
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
    freq: ArrayLike,
    H: ArrayLike,
    nb: int,
    na: int,
    *,
    domain: str = "s",
    fs: float | None = None,
    weight: ArrayLike | None = None,
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
        Non-negative weight per frequency (e.g. coherence; Khatkhate, Ray & Keller
        (2007) use ``1/|H|`` for a relative error). Default ones.
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
    >>> from pdmkit.models.frequency import fit_tf
    >>> f = np.linspace(0.1, 20, 200)
    >>> _, H = ss.freqs([100.0], [1.0, 2.0, 100.0], worN=2 * np.pi * f)
    >>> fit = fit_tf(f, H, nb=0, na=2)
    >>> np.round(fit.den, 4), np.round(fit.num, 4)
    (array([  1.,   2., 100.]), array([100.]))
    """
    freq, H, nb, na, w = _checked_tf_data(freq, H, nb, na, domain, weight)
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

    b, a, n_done = _sanathanan_koerner(H, x, nb, na, sw, domain, n_iter, tol)
    if refine:
        b, a = _refine_output_error(H, x, b, a, sw, domain)
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


def _checked_tf_data(freq, H, nb, na, domain, weight):
    """``fit_tf``'s data and orders checked: ``(freq, H, nb, na, weight)``."""
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
    return freq, H, nb, na, w


def _sanathanan_koerner(H, x, nb, na, sw, domain, n_iter, tol):
    """Levy's start, then SK re-weighting by ``1/|A_prev|``; ``(b, a, iterations)``."""
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
    return b, a, n_done


def _refine_output_error(H, x, b, a, sw, domain):
    """Gauss-Newton on the output error ``(B/A - H) sw``; kept only if it lowers it."""
    nb = b.size - 1
    na = a.size - 1

    def resid(theta):
        bb, aa = theta[: nb + 1], np.concatenate([[1.0], theta[nb + 1 :]])
        e = (_basis(x, nb, domain) @ bb / (_basis(x, na, domain) @ aa) - H) * sw
        return np.concatenate([e.real, e.imag])

    theta0 = np.concatenate([b, a[1:]])
    try:
        sol = sopt.least_squares(resid, theta0, method="lm", xtol=1e-12, ftol=1e-12)
        if np.sum(sol.fun**2) <= np.sum(resid(theta0) ** 2):
            b, a = sol.x[: nb + 1], np.concatenate([[1.0], sol.x[nb + 1 :]])
    except ValueError:  # fewer residuals than unknowns: keep SK's answer
        pass
    return b, a


# ----------------------------------------------------------------------------- grey box
