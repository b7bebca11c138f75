"""Fractional-order models: simulation, approximation, fitting and condition distances.

The fractional-calculus paper (condition-based diagnosis of a motor + gearbox) models
the empirical transfer function of each machine condition with

    G(s) = 1 / (a s^alpha + b s^beta + c)

fitted by the simplex method, uses the distance of a member's empirical transfer function
to each condition's model as failure index, and classifies with kNN. Its table 1 shows the
fractional model fitting better than the integer one (alpha = 2, beta = 1).

- :class:`FractionalTF` - ``sum_j b_j s^nu_j / sum_i a_i s^alpha_i``: frequency response,
  Grünwald-Letnikov simulation (:func:`gl_simulate`), Oustaloup rational approximation
  (:func:`oustaloup`);
- :func:`fit_fractional_frf` - fit the paper's structure (or one with 1 or 3 denominator
  terms, or fixed orders such as the integer model) to FRF data: for fixed orders the
  coefficients are linear in ``1/H``, so the orders are searched on a grid and refined
  (variable projection), then all parameters polished on the relative error of ``H``;
- :func:`fit_fractional_tf` - the same from input/output records, in the frequency domain
  (H1 estimate) or in the time domain (output error of the GL simulation);
- :func:`model_distance`, :class:`FractionalConditionClassifier` - the paper's failure
  indices and kNN diagnosis.

This module holds the models, their simulation and the distance; the fits live in
``_fractional_fit.py`` and the classifier in ``_fractional_classify.py``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
import scipy.signal as ss

from pdmkit.errors import DataError, ModelError
from pdmkit.models.frequency._frf import _as_float_array

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from numpy.typing import ArrayLike

__all__ = ["FractionalTF", "gl_simulate", "gl_weights", "model_distance", "oustaloup"]


# ----------------------------------------------------------------------------- GL
def gl_weights(alpha: float, n: int) -> np.ndarray:
    """Grünwald-Letnikov weights ``w_k = (-1)^k binom(alpha, k)``, ``k = 0..n-1``.

    Computed by the recursion ``w_k = w_{k-1} (1 - (alpha + 1) / k)`` (Podlubny,
    *Fractional Differential Equations*, 1999, eq. 7.23).

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.frequency import gl_weights
    >>> bool(np.all(gl_weights(1.0, 4) == [1, -1, 0, 0]))  # first difference
    True
    >>> bool(np.all(gl_weights(2.0, 4) == [1, -2, 1, 0]))  # second difference
    True
    """
    k = np.arange(1, int(n))
    w = np.empty(int(n))
    w[0] = 1.0
    w[1:] = np.cumprod(1.0 - (float(alpha) + 1.0) / k)
    return w


def gl_simulate(
    u: ArrayLike,
    dt: float,
    den_coefs: Sequence[float],
    den_orders: Sequence[float],
    num_coefs: Sequence[float] = (1.0,),
    num_orders: Sequence[float] = (0.0,),
    *,
    memory: int | None = None,
) -> np.ndarray:
    """Simulate ``sum a_i D^alpha_i y = sum b_j D^nu_j u`` by Grünwald-Letnikov.

    Zero initial conditions (the system rests before ``t = 0``), so Grünwald-Letnikov,
    Riemann-Liouville and Caputo derivatives coincide. Each derivative is
    ``D^alpha y(t_n) ~ dt^-alpha sum_k w_k y_{n-k}``; the implicit equation for ``y_n``
    is solved at each step. First-order accurate in ``dt``.

    Parameters
    ----------
    u : array_like, shape (n,)
        Input samples at ``t = 0, dt, 2 dt, ...``.
    dt : float
        Time step (s).
    den_coefs, den_orders : sequence of float
        ``a_i`` and ``alpha_i`` (orders >= 0).
    num_coefs, num_orders : sequence of float
        ``b_j`` and ``nu_j``; default a unit gain.
    memory : int, optional
        Short-memory principle: keep only the last ``memory`` samples in the sums.

    Returns
    -------
    ndarray, shape (n,)

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.frequency import gl_simulate
    >>> t = np.arange(0, 5, 1e-3)
    >>> y = gl_simulate(np.ones_like(t), 1e-3, [1.0, 1.0], [1.0, 0.0])  # 1/(s + 1)
    >>> bool(abs(y[-1] - (1 - np.exp(-t[-1]))) < 1e-3)
    True
    """
    u = _as_float_array(u, "u (input)").reshape(-1)
    dt = float(dt)
    if not dt > 0:
        raise DataError(f"dt must be positive (s); got {dt!r}.")
    a = np.asarray(den_coefs, float)
    al = np.asarray(den_orders, float)
    b = np.asarray(num_coefs, float)
    nu = np.asarray(num_orders, float)
    if a.shape != al.shape or b.shape != nu.shape or a.size == 0:
        raise ModelError(
            "den_coefs/den_orders and num_coefs/num_orders must pair up one coefficient "
            f"per order; got {a.size}/{al.size} and {b.size}/{nu.size}."
        )
    if np.any(al < 0) or np.any(nu < 0):
        raise ModelError("orders must be >= 0.")
    n = u.size
    m = n if memory is None else max(1, min(n, int(memory)))
    # right-hand side: sum_j b_j dt^-nu_j (w^nu * u)
    rhs = np.zeros(n)
    for bj, nj in zip(b, nu, strict=True):
        rhs += bj * dt**-nj * _causal_conv(u, gl_weights(nj, m))
    # combined weights of the left-hand side
    W = np.zeros(m)
    for ai, alpha in zip(a, al, strict=True):
        W += ai * dt**-alpha * gl_weights(alpha, m)
    if W[0] == 0:
        raise ModelError("the denominator vanishes at high frequency; check den_coefs.")
    tail = W[1:][::-1]  # tail[-k] multiplies y_{n-k}
    y = np.zeros(n)
    inv = 1.0 / W[0]
    for i in range(n):
        k = min(i, m - 1)
        acc = tail[tail.size - k :] @ y[i - k : i] if k else 0.0
        y[i] = (rhs[i] - acc) * inv
    return y


def _causal_conv(x: np.ndarray, w: np.ndarray) -> np.ndarray:
    return ss.fftconvolve(x, w)[: x.size] if w.size > 64 else np.convolve(x, w)[: x.size]


# ----------------------------------------------------------------------------- model
@dataclass(frozen=True)
class FractionalTF:
    """A fractional-order transfer function ``sum_j b_j s^nu_j / sum_i a_i s^alpha_i``.

    Parameters
    ----------
    den_coefs, den_orders : tuple of float
    num_coefs, num_orders : tuple of float
        Default a unit numerator.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.frequency import FractionalTF
    >>> g = FractionalTF((2.0, 0.5, 1.0), (1.6, 0.7, 0.0))   # the paper's structure
    >>> complex(np.round(g.frequency_response([0.0])[0], 6))
    (1+0j)
    """

    den_coefs: tuple
    den_orders: tuple
    num_coefs: tuple = (1.0,)
    num_orders: tuple = (0.0,)

    @classmethod
    def seed004(
        cls, a: float, alpha: float, b: float, beta: float, c: float
    ) -> FractionalTF:
        """``1 / (a s^alpha + b s^beta + c)`` (the fractional-calculus paper, eq. 8)."""
        return cls((a, b, c), (alpha, beta, 0.0))

    def frequency_response(
        self, omega: ArrayLike, *, dt: float | None = None
    ) -> np.ndarray:
        """Complex response at angular frequencies ``omega`` (rad/s).

        With ``dt`` the response of the Grünwald-Letnikov discretisation
        (:meth:`simulate`): ``s`` is replaced by ``(1 - exp(-j omega dt)) / dt``.
        """
        omega = np.asarray(omega, dtype=float)
        s = 1j * omega if dt is None else (1 - np.exp(-1j * omega * dt)) / dt
        with np.errstate(divide="ignore", invalid="ignore"):
            num = sum(
                b * (s**n if n else 1.0)
                for b, n in zip(self.num_coefs, self.num_orders, strict=True)
            )
            den = sum(
                a * (s**q if q else 1.0)
                for a, q in zip(self.den_coefs, self.den_orders, strict=True)
            )
        return num / den

    def simulate(self, u: ArrayLike, dt: float, *, memory: int | None = None) -> np.ndarray:
        """Grünwald-Letnikov simulation from rest (:func:`gl_simulate`)."""
        return gl_simulate(
            u,
            dt,
            self.den_coefs,
            self.den_orders,
            self.num_coefs,
            self.num_orders,
            memory=memory,
        )

    def to_pandas(self) -> pd.DataFrame:
        """One row per term."""
        rows = [("num", c, o) for c, o in zip(self.num_coefs, self.num_orders, strict=True)]
        rows += [
            ("den", c, o) for c, o in zip(self.den_coefs, self.den_orders, strict=True)
        ]
        return pd.DataFrame(rows, columns=["part", "coef", "order"])

    def plot(self, ax: Axes | None = None, *, omega: ArrayLike | None = None) -> Axes:
        """Magnitude response (dB) over ``omega`` (default 0.01 to 1000 rad/s)."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        w = np.logspace(-2, 3, 400) if omega is None else np.asarray(omega)
        ax.semilogx(w, 20 * np.log10(np.abs(self.frequency_response(w))))
        ax.set_xlabel("omega (rad/s)")
        ax.set_ylabel("|G| (dB)")
        return ax


def oustaloup(
    alpha: float, wb: float, wh: float, order: int = 5
) -> tuple[np.ndarray, np.ndarray, float]:
    """Oustaloup's recursive rational approximation of ``s^alpha`` on ``[wb, wh]`` rad/s.

    ``s^alpha ~ K prod_{k=-N..N} (s + w'_k) / (s + w_k)`` with
    ``w'_k = wb (wh/wb)^((k + N + (1 - alpha)/2) / (2N + 1))``,
    ``w_k = wb (wh/wb)^((k + N + (1 + alpha)/2) / (2N + 1))`` and ``K = wh^alpha``
    (Oustaloup et al., IEEE Trans. Circuits Syst. I 47(1), 2000).

    Parameters
    ----------
    alpha : float
        Order, usually in (-1, 1); larger orders: ``s^n * s^(alpha - n)``.
    wb, wh : float
        Band (rad/s), ``0 < wb < wh``.
    order : int
        ``N``; the approximation has ``2N + 1`` poles and zeros.

    The phase is accurate only well inside the band (about two decades from either
    edge for a degree); choose ``[wb, wh]`` wider than the band of interest.

    Returns
    -------
    (zeros, poles, gain)
        As :func:`scipy.signal.zpk2tf` takes them (continuous time).

    Examples
    --------
    >>> import numpy as np, scipy.signal as ss
    >>> from pdmkit.models.frequency import oustaloup
    >>> z, p, k = oustaloup(0.5, 1e-3, 1e3, order=6)
    >>> _, H = ss.freqs_zpk(z, p, k, worN=[1.0])   # s^0.5 at 1 rad/s: 1 at 45 degrees
    >>> round(float(abs(H[0])), 2), round(float(np.degrees(np.angle(H[0]))))
    (1.0, 45)
    """
    if not 0 < wb < wh:
        raise ModelError(f"need 0 < wb < wh; got wb={wb}, wh={wh}.")
    N = int(order)
    if N < 1:
        raise ModelError(f"order must be >= 1; got {order}.")
    k = np.arange(-N, N + 1)
    r = wh / wb
    wz = wb * r ** ((k + N + 0.5 * (1 - alpha)) / (2 * N + 1))
    wp = wb * r ** ((k + N + 0.5 * (1 + alpha)) / (2 * N + 1))
    return -wz, -wp, wh**alpha


# ----------------------------------------------------------------------------- simplex
_SEED_NAMES = ("a", "alpha", "b", "beta", "c")


# ----------------------------------------------------------------------------- diagnosis
def model_distance(
    H: ArrayLike, model: FractionalTF, freq: ArrayLike, *, relative: bool = False
) -> np.ndarray:
    """Failure index: mean squared difference between ETFEs and a model.

    The distance of a member to a condition's model that the fractional-calculus paper
    uses to diagnose.

    Parameters
    ----------
    H : array_like of complex, shape (..., n_freq)
        Empirical transfer functions (one row per member).
    model : FractionalTF
        A condition's model.
    freq : array_like
        Frequencies (Hz) of ``H``.
    relative : bool
        Divide the difference by ``|G|`` (scale-free across decades).

    Returns
    -------
    ndarray, shape (...)

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.frequency import FractionalTF, model_distance
    >>> g = FractionalTF.seed004(1.0, 1.5, 0.5, 0.5, 1.0)
    >>> f = np.linspace(0.1, 5, 20)
    >>> float(model_distance(g.frequency_response(2 * np.pi * f), g, f))
    0.0
    """
    G = model.frequency_response(2 * np.pi * np.asarray(freq, float))
    d = np.asarray(H, complex) - G
    if relative:
        d = d / np.abs(G)
    return np.mean(np.abs(d) ** 2, axis=-1)
