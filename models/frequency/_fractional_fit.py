"""Fitting fractional-order transfer functions ``1/(a s^alpha + b s^beta + c)`` to data.

In the frequency domain (:func:`fit_fractional_frf`: a grid over the orders and least
squares for the coefficients) and in the time domain (:func:`fit_fractional_tf`); the
fractional-calculus paper's simplex fit (:func:`fit_fractional_simplex`) is in
``_fractional_simplex.py``.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
import scipy.optimize as sopt

from pdmkit.errors import DataError, ModelError
from pdmkit.models.frequency._fractional import FractionalTF, _causal_conv, gl_weights
from pdmkit.models.frequency._frf import _as_float_array, _check_fs, frf_estimate

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from numpy.typing import ArrayLike

__all__ = [
    "FractionalFit",
    "fit_fractional_frf",
    "fit_fractional_tf",
]


# ----------------------------------------------------------------------------- fitting
@dataclass
class FractionalFit:
    """A fractional model fitted by :func:`fit_fractional_frf` / :func:`fit_fractional_tf`.

    Attributes
    ----------
    model : FractionalTF
    alpha, beta : float
        The two largest denominator orders (``beta`` is NaN with one term).
    a, b, c : float
        Their coefficients and the constant term (the fractional-calculus paper's
        notation).
    error : float
        RMS relative error ``sqrt(mean |H - G|^2 / |H|^2)`` on the fitted data (frequency
        fits), RMS output error (time fits), or the fractional-calculus paper's
        objective ``mean |G_EETF - G|`` (:func:`fit_fractional_simplex`).
    fit_percent : float
        ``100 (1 - ||H - G|| / ||H - mean H||)`` (or the same on the output).
    method : str
        ``"lsq"`` (variable projection + least squares) or ``"simplex"`` (the
        fractional-calculus paper's Nelder-Mead).


    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models import FractionalTF, fit_fractional_frf
    >>> true = FractionalTF.seed004(a=0.05, alpha=1.5, b=0.5, beta=0.8, c=2.0)
    >>> f = np.logspace(-1, 2, 60)
    >>> fit = fit_fractional_frf(f, true.frequency_response(2 * np.pi * f))
    >>> round(fit.a, 3), round(fit.c, 3), fit.fit_percent > 99.9
    (0.05, 2.0, True)
    """

    model: FractionalTF
    error: float
    fit_percent: float
    domain: str = "frequency"
    freq: np.ndarray | None = None
    H: np.ndarray | None = None
    method: str = "lsq"

    @property
    def alpha(self) -> float:
        return float(self.model.den_orders[0])

    @property
    def beta(self) -> float:
        o = self.model.den_orders
        return float(o[1]) if len(o) > 2 else float("nan")

    @property
    def a(self) -> float:
        return float(self.model.den_coefs[0])

    @property
    def b(self) -> float:
        c = self.model.den_coefs
        return float(c[1]) if len(c) > 2 else float("nan")

    @property
    def c(self) -> float:
        return float(self.model.den_coefs[-1])

    @property
    def params(self) -> dict:
        """``a, alpha, b, beta, c`` and the numerator gain."""
        return {
            "a": self.a,
            "alpha": self.alpha,
            "b": self.b,
            "beta": self.beta,
            "c": self.c,
            "gain": float(self.model.num_coefs[0]),
        }

    def to_pandas(self) -> pd.Series:
        """Parameters and errors as a Series."""
        return pd.Series(
            {**self.params, "error": self.error, "fit_percent": self.fit_percent}
        )

    def plot(self, ax: Axes | None = None) -> Axes:
        """Data and model magnitude; returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        if self.freq is not None and self.H is not None:
            w = 2 * np.pi * self.freq
            ax.loglog(w, np.abs(self.H), ".", label="data")
            ax.loglog(w, np.abs(self.model.frequency_response(w)), label="model")
            ax.legend()
        ax.set_xlabel("omega (rad/s)")
        ax.set_ylabel("|G|")
        return ax


def _bounded_lstsq(M: np.ndarray, r: np.ndarray, lower: np.ndarray):
    """Least squares ``M x ~ r`` with ``x >= lower`` (-inf: free); returns (x, cost)."""
    x, *_ = np.linalg.lstsq(M, r, rcond=None)
    if np.any(x < lower):
        x = sopt.lsq_linear(M, r, bounds=(lower, np.inf), method="bvls").x
    return x, float(np.sum((M @ x - r) ** 2))


def _coefs_for_orders(Hinv, s_pow, wgt, lower=None):
    """Least squares of ``1/H ~ sum coef_i s^q_i`` for fixed orders (weighted)."""
    M = s_pow * wgt[:, None]
    r = Hinv * wgt
    Mr = np.vstack([M.real, M.imag])
    rr = np.concatenate([r.real, r.imag])
    if lower is None:
        lower = np.full(Mr.shape[1], -np.inf)
    return _bounded_lstsq(Mr, rr, lower)


class _Orders:
    """Denominator orders from free variables, kept apart by ``gap``.

    The free orders are stored as increments, lowest term first: a free order is the
    next lower order (or ``lo`` for the lowest term) plus ``gap`` plus a
    non-negative increment, so ``alpha >= beta + gap >= gamma + 2 gap`` by
    construction. A free order that would pass a fixed order above it (or ``hi``) is
    infeasible (:meth:`violation`).
    """

    def __init__(self, names, fixed, lo, hi, gap):
        self.names, self.fixed = list(names), dict(fixed)
        self.lo, self.hi, self.gap = float(lo), float(hi), float(gap)
        self.free = [k for k in self.names if k not in self.fixed]

    def orders(self, x) -> list[float]:
        inc = dict(zip(self.free, np.asarray(x, dtype=float), strict=True))
        out: dict[str, float] = {}
        below = None
        for k in reversed(self.names):
            if k in self.fixed:
                out[k] = float(self.fixed[k])
            else:
                base = self.lo if below is None else below + self.gap
                out[k] = base + inc[k]
            below = out[k]
        return [out[k] for k in self.names]

    def increments(self, orders) -> np.ndarray:
        val = dict(zip(self.names, orders, strict=True))
        x, below = {}, None
        for k in reversed(self.names):
            if k not in self.fixed:
                base = self.lo if below is None else below + self.gap
                x[k] = max(0.0, float(val[k]) - base)
                val[k] = base + x[k]
            below = val[k]
        return np.array([x[k] for k in self.free])

    def violation(self, orders) -> float:
        """How far ``orders`` break ``hi`` or the gap below a fixed order (0: none)."""
        v = max(0.0, max(orders, default=0.0) - self.hi)
        for upper, lower in itertools.pairwise(orders):
            v += max(0.0, lower + self.gap - upper) if self.gap > 0 else 0.0
        return v

    def bound(self) -> float:
        return max(self.hi - self.lo, 1e-6)


def fit_fractional_frf(
    freq: ArrayLike,
    H: ArrayLike,
    *,
    den_terms: int = 2,
    fixed_orders: Mapping[str, float] | None = None,
    weight: ArrayLike | None = None,
    order_bounds: tuple[float, float] = (0.05, 2.5),
    grid: int = 12,
    fit_gain: bool = False,
    dt: float | None = None,
    min_gap: float = 0.05,
    constrain: bool = True,
) -> FractionalFit:
    """Fit ``1 / (a s^alpha + b s^beta + c)`` to frequency-response data.

    For given orders the denominator is linear in its coefficients, and ``1/G`` is fitted
    to ``1/H`` with weights ``|H|`` (a relative error). The orders are searched on a grid,
    the best few refined with the coefficients projected out, and the winner polished on
    the relative complex error ``(H - G)/|H|`` with all parameters free
    (:func:`scipy.optimize.least_squares`). The model is eq. 8 of the fractional-calculus
    paper, which minimises ``|G_EETF - G|`` with Nelder-Mead; the relative error weights
    every decade alike.

    Parameters
    ----------
    freq : array_like
        Frequencies in Hz.
    H : array_like of complex
        FRF values.
    den_terms : {1, 2, 3}
        Fractional terms in the denominator besides the constant ``c``: 1 gives
        ``a s^alpha + c``, 2 the paper's structure, 3 adds ``d s^gamma``.
    fixed_orders : dict, optional
        Orders held fixed, by name (``"alpha"``, ``"beta"``, ``"gamma"``), e.g.
        ``{"alpha": 2, "beta": 1}`` for the integer-order model of the paper's table 1.
    weight : array_like, optional
        Extra weight per frequency (e.g. coherence).
    order_bounds : (float, float)
        Range of the free orders.
    grid : int
        Grid points per free order for the start.
    fit_gain : bool
        Fit a numerator gain too (otherwise 1, as in the paper; the gain is absorbed by
        ``a, b, c`` anyway).
    dt : float, optional
        Fit the Grünwald-Letnikov discretisation with this step instead of the
        continuous model (``s -> (1 - exp(-j omega dt)) / dt``); use it for data that a
        GL simulation produced. Its backward difference lags the continuous operator by
        about half a sample.
    min_gap : float, default 0.05
        ``delta``: the orders are kept apart, ``alpha >= beta + delta`` (``>= gamma
        + 2 delta``). Two equal orders make a degenerate model whose two terms cancel
        (``a = -b``, both huge).
    constrain : bool, default True
        Also keep the fractional coefficients ``a, b`` (and ``d``) of the sign of
        ``c`` (>= 0 for a positive static gain), as physical (spring, damper,
        inertia-like) terms are; ``False`` leaves the coefficients free and the gap 0.

    Returns
    -------
    FractionalFit

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.frequency import FractionalTF, fit_fractional_frf
    >>> true = FractionalTF.seed004(a=0.02, alpha=1.7, b=0.3, beta=0.6, c=1.0)
    >>> f = np.logspace(-1, 2, 60)
    >>> fit = fit_fractional_frf(f, true.frequency_response(2 * np.pi * f))
    >>> round(fit.alpha, 3), round(fit.beta, 3)
    (1.7, 0.6)
    """
    f, Hk, we, names, fixed = _checked_fractional_frf_data(
        freq, H, den_terms, fixed_orders, weight
    )
    wk = 2 * np.pi * f
    s = 1j * wk if dt is None else (1 - np.exp(-1j * wk * dt)) / dt
    lo, hi = order_bounds
    gap = float(min_gap) if constrain else 0.0
    om = _Orders(names, fixed, lo, hi, gap)
    prob = _FractionalFrfProblem(s, Hk, we, om, den_terms, fit_gain, constrain)

    def fit_sign(sign: float):
        # constrained: the fractional coefficients share the sign of the gain, which the
        # data decide (both are tried)
        if prob.n_free:
            x_best = _orders_by_grid_and_simplex(prob, sign, grid, order_bounds)
        else:
            x_best = np.array([])
        return _polish_all_parameters(prob, sign, x_best)

    fits = [fit_sign(sg) for sg in ((1.0, -1.0) if constrain else (1.0,))]
    theta, _ = min(fits, key=lambda t: t[1] if np.isfinite(t[1]) else np.inf)
    o, cf, k = prob.unpack(theta)
    # sort terms by order, descending, constant last
    idx = np.argsort(o)[::-1]
    model = FractionalTF(
        (*tuple(float(cf[i]) for i in idx), float(cf[-1])),
        (*tuple(float(o[i]) for i in idx), 0.0),
        (float(k),),
        (0.0,),
    )
    G = model.frequency_response(wk, dt=dt)
    err = float(np.sqrt(np.mean(np.abs((Hk - G) / Hk) ** 2)))
    spread = np.linalg.norm(Hk - Hk.mean())
    fitp = 100 * (1 - np.linalg.norm(Hk - G) / spread) if spread > 0 else float("nan")
    return FractionalFit(model, err, float(fitp), "frequency", f, Hk)


def _checked_fractional_frf_data(freq, H, den_terms, fixed_orders, weight):
    """The usable frequencies ``(f, H, weight)``, the order names and the fixed orders."""
    freq = _as_float_array(freq, "freq").reshape(-1)
    H = np.asarray(H, dtype=complex).reshape(-1)
    if H.shape != freq.shape:
        raise DataError(f"H has {H.size} values but freq has {freq.size}.")
    keep = (freq > 0) & np.isfinite(H) & (np.abs(H) > 0)
    if keep.sum() < 2 * den_terms + 2:
        raise DataError(
            f"{int(keep.sum())} usable frequencies (f > 0, finite, non-zero H) are too "
            f"few for {2 * den_terms + 1} parameters."
        )
    if den_terms not in (1, 2, 3):
        raise ModelError(f"den_terms must be 1, 2 or 3; got {den_terms!r}.")
    names = ["alpha", "beta", "gamma"][:den_terms]
    fixed = dict(fixed_orders or {})
    for k in fixed:
        if k not in names:
            raise ModelError(
                f"fixed_orders names {k!r}; with den_terms={den_terms} the "
                f"orders are {names}."
            )
    w_extra = np.ones(freq.size) if weight is None else np.asarray(weight, float)
    return freq[keep], H[keep], w_extra[keep], names, fixed


class _FractionalFrfProblem:
    """The data of a fractional FRF fit and its two errors (``1/H`` and relative)."""

    def __init__(self, s, Hk, we, om, den_terms, fit_gain, constrain):
        self.s, self.Hk, self.we, self.om = s, Hk, we, om
        self.Hinv = 1.0 / Hk
        self.wgt = np.abs(Hk) * np.sqrt(we)
        self.n_free, self.nc = len(om.free), den_terms + 1
        self.fit_gain = fit_gain
        # constrained: the fractional coefficients (not c) >= 0, times the sign tried
        self.lower = np.r_[np.full(den_terms, 0.0 if constrain else -np.inf), -np.inf]

    def spow(self, orders):
        """Columns ``s^q`` per order, then the constant."""
        return np.column_stack([self.s**q for q in orders] + [np.ones_like(self.s)])

    def coefs(self, orders, sign):
        """Coefficients of ``1/H`` for fixed orders (of the given sign) and their cost."""
        cf, cost = _coefs_for_orders(
            sign * self.Hinv, self.spow(orders), self.wgt, self.lower
        )
        return sign * cf, cost

    def profile(self, x, sign):
        """The cost of the order increments ``x`` with the coefficients projected out."""
        if np.any(np.asarray(x) < 0):
            return np.inf
        o = self.om.orders(x)
        pen = self.om.violation(o)
        return self.coefs(o, sign)[1] * (1.0 + 1e3 * pen) + pen

    def unpack(self, theta):
        """``(orders, coefficients, gain)`` from the full parameter vector."""
        n_free, nc = self.n_free, self.nc
        x, cf = theta[:n_free], theta[n_free : n_free + nc]
        k = theta[n_free + nc] if self.fit_gain else 1.0
        return self.om.orders(x), cf, k

    def resid(self, theta):
        """The relative complex error ``(H - G) / |H|`` (weighted), with the gap penalty."""
        o, cf, k = self.unpack(theta)
        G = k / (self.spow(o) @ cf)
        e = (self.Hk - G) / np.abs(self.Hk) * np.sqrt(self.we)
        pen = 1e3 * self.om.violation(o)
        return np.concatenate([e.real, e.imag, [pen]])


def _orders_by_grid_and_simplex(prob, sign, grid, order_bounds):
    """Free order increments: the best of a grid, refined by Nelder-Mead on the profile."""
    om = prob.om
    lo, hi = order_bounds
    g = np.linspace(lo, hi, grid)
    cands = []
    for x in itertools.product(g, repeat=prob.n_free):
        o = dict(zip(om.free, x, strict=True))
        full = [om.fixed.get(k, o.get(k)) for k in om.names]
        if any(a_ < b_ + max(om.gap, 1e-9) for a_, b_ in itertools.pairwise(full)):
            continue  # orders kept in descending order (alpha > beta > gamma)
        xi = om.increments(full)
        cands.append((prob.profile(xi, sign), xi))
    if not cands:
        raise ModelError(
            f"no orders in order_bounds={order_bounds} are {om.gap} apart around the "
            f"fixed orders {om.fixed}; widen order_bounds or lower min_gap."
        )
    cands.sort(key=lambda c: c[0])
    best = None
    for c0, x0 in cands[:3]:
        # coarse: the least-squares polish below does the fine work
        sol = sopt.minimize(
            prob.profile,
            x0,
            args=(sign,),
            method="Nelder-Mead",
            bounds=[(0.0, om.bound())] * prob.n_free,
            options={
                "xatol": 1e-4,
                "fatol": 1e-8 * max(c0, 1e-300),
                "maxiter": 300 * prob.n_free,
            },
        )
        if best is None or sol.fun < best.fun:
            best = sol
    return np.clip(best.x, 0.0, om.bound())


def _polish_all_parameters(prob, sign, x_best):
    """Least squares of the relative error over orders, coefficients (and gain)."""
    n_free, fit_gain = prob.n_free, prob.fit_gain
    coef, _ = prob.coefs(prob.om.orders(x_best), sign)
    theta0 = np.concatenate([x_best, coef, [1.0] if fit_gain else []])
    big = np.inf
    c_lo = np.where(np.isfinite(prob.lower), 0.0, -big)
    cf_lb = np.where(sign > 0, c_lo, -big)
    cf_ub = np.where(sign > 0, big, -c_lo)
    cf_lb[-1], cf_ub[-1] = -big, big
    lb = np.concatenate([[0.0] * n_free, cf_lb, [-big] if fit_gain else []])
    ub = np.concatenate([[prob.om.bound()] * n_free, cf_ub, [big] if fit_gain else []])
    theta0 = np.clip(theta0, lb + 1e-12 * (lb > -big), ub - 1e-12 * (ub < big))
    sol = sopt.least_squares(prob.resid, theta0, bounds=(lb, ub), x_scale="jac")
    theta = sol.x if np.sum(sol.fun**2) <= np.sum(prob.resid(theta0) ** 2) else theta0
    return theta, float(np.sum(prob.resid(theta) ** 2))


def fit_fractional_tf(
    u: ArrayLike,
    y: ArrayLike,
    fs: float,
    *,
    domain: str = "frequency",
    den_terms: int = 2,
    fixed_orders: Mapping[str, float] | None = None,
    nperseg: int | None = None,
    fmin: float | None = None,
    fmax: float | None = None,
    coherence_min: float = 0.5,
    operator: str = "gl",
    min_gap: float = 0.05,
    constrain: bool = True,
    n_starts: int = 4,
) -> FractionalFit:
    """Fit ``1/(a s^alpha + b s^beta + c)`` from input and output records.

    ``domain="frequency"`` estimates the FRF (H1,
    :func:`~pdmkit.models.frequency.frf_estimate`; the fractional-calculus paper's
    empirical transfer function) and fits it (:func:`fit_fractional_frf`), weighting
    each frequency by its coherence (frequencies below ``coherence_min`` dropped) by the
    inverse variance of the H1 estimate, ``g2 / (1 - g2)``.
    ``domain="time"`` starts there and then minimises the output error of the
    Grünwald-Letnikov simulation (:func:`gl_simulate`) over all parameters.

    Parameters
    ----------
    u, y : array_like, shape (n,)
        Input and output samples.
    fs : float
        Sampling rate (Hz).
    domain : {"frequency", "time"}
    den_terms, fixed_orders
        As in :func:`fit_fractional_frf`.
    nperseg : int, optional
        Welch segment length (default ``min(n, 1024)``).
    fmin, fmax : float, optional
        Band (Hz) of the frequency fit (default the first non-zero line to fs/4: the
        GL discretisation and sampling distort the response near Nyquist).
    coherence_min : float
    operator : {"gl", "s"}
        Fit the Grünwald-Letnikov discretisation at the sampling step (consistent
        with the time-domain path and with data a GL simulation produced; default), or
        the continuous model (``"s"``; for data of a continuous system sampled much
        faster than its dynamics).
    min_gap, constrain
        As in :func:`fit_fractional_frf`: ``alpha >= beta + min_gap`` and ``a, b`` of
        the sign of ``c``, in both domains.
    n_starts : int, default 4
        Time domain: output-error fits started from the frequency fit and from the
        ``n_starts - 1`` best orders of a grid (step 0.2) scored by the
        equation error ``a D^alpha y + b D^beta y + c y - u`` (linear in the
        coefficients); the best is kept.

    Returns
    -------
    FractionalFit

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.frequency import FractionalTF, fit_fractional_tf
    >>> g = FractionalTF.seed004(a=0.05, alpha=1.5, b=0.2, beta=0.5, c=1.0)
    >>> u = np.random.default_rng(0).normal(size=4000)
    >>> y = g.simulate(u, dt=0.01)
    >>> fit = fit_fractional_tf(u, y, fs=100.0)
    >>> abs(fit.alpha - 1.5) < 0.05, abs(fit.beta - 0.5) < 0.05
    (True, True)
    """
    fs = _check_fs(fs)
    u = _as_float_array(u, "u (input)").reshape(-1)
    y = _as_float_array(y, "y (output)").reshape(-1)
    if u.shape != y.shape:
        raise DataError(f"u and y must have the same length; got {u.size} and {y.size}.")
    if domain not in ("frequency", "time"):
        raise ModelError(f"domain must be 'frequency' or 'time'; got {domain!r}.")
    if operator not in ("gl", "s"):
        raise ModelError(f"operator must be 'gl' or 's'; got {operator!r}.")
    nper = min(u.size, 1024) if nperseg is None else int(nperseg)
    frf = frf_estimate(u, y, fs, nperseg=nper, fmin=fmin or fs / nper, fmax=fmax or fs / 4)
    dt_op = 1.0 / fs if operator == "gl" else None
    ok = frf.coherence >= coherence_min
    if ok.sum() < 2 * den_terms + 2:
        raise DataError(
            f"only {int(ok.sum())} frequencies reach coherence_min={coherence_min}; "
            "record longer, excite more, or lower coherence_min."
        )
    ffit = fit_fractional_frf(
        frf.freq[ok],
        frf.H[ok],
        den_terms=den_terms,
        fixed_orders=fixed_orders,
        weight=_coherence_weight(frf.coherence[ok]),
        dt=dt_op,
        min_gap=min_gap,
        constrain=constrain,
    )
    if domain == "frequency":
        return ffit
    return _fit_time_domain(u, y, fs, ffit, fixed_orders, min_gap, constrain, n_starts, frf)


def _gl_derivative(x: np.ndarray, order: float, dt: float) -> np.ndarray:
    """Grünwald-Letnikov derivative of ``x`` (from rest) of the given order."""
    if order == 0:
        return x.copy()
    return dt**-order * _causal_conv(x, gl_weights(order, x.size))


def _fit_time_domain(u, y, fs, ffit, fixed_orders, min_gap, constrain, n_starts, frf):
    """Output-error fit of the GL simulation from several starts (constrained)."""
    dt = 1.0 / fs
    m0 = ffit.model
    n_terms = len(m0.den_orders) - 1
    fixed = dict(fixed_orders or {})
    names = ["alpha", "beta", "gamma"][:n_terms]
    gap = float(min_gap) if constrain else 0.0
    om = _Orders(names, fixed, 0.01, 3.0, gap)
    nf = len(om.free)
    scale = np.std(y) or 1.0
    gain0 = float(m0.num_coefs[0])
    sign = (1.0 if m0.den_coefs[-1] >= 0 else -1.0) if constrain else 1.0

    def build(theta):
        orders = om.orders(theta[:nf])
        return FractionalTF(tuple(theta[nf:]), (*tuple(orders), 0.0))

    def resid(theta):
        with np.errstate(all="ignore"):
            e = (build(theta).simulate(u, dt) - y) / scale
        if not np.all(np.isfinite(e)):
            return np.full(y.size + 1, 1e6)
        pen = 1e3 * om.violation(om.orders(theta[:nf]))
        return np.r_[e, pen]

    # starts: the frequency fit, then the best orders of a time-domain equation-error
    # grid (a D^alpha y + b D^beta y + c y = u is linear in a, b, c for fixed orders)
    starts = [
        (
            np.concatenate(
                [om.increments(m0.den_orders[:-1]), np.asarray(m0.den_coefs) / gain0]
            ),
            sign,
        )
    ]
    lower = np.r_[np.full(n_terms, 0.0 if constrain else -np.inf), -np.inf]
    if nf and n_starts > 1:
        starts += _equation_error_starts(u, y, dt, om, lower, constrain, n_starts - 1)

    best = None
    for theta0, sg in starts:
        lb, ub = _time_fit_bounds(om, lower, sg)
        x0 = np.clip(theta0, lb + 1e-9 * np.isfinite(lb), ub - 1e-9 * np.isfinite(ub))
        sol = sopt.least_squares(resid, x0, bounds=(lb, ub), x_scale="jac", max_nfev=200)
        if best is None or sol.cost < best.cost:
            best = sol
    model = build(best.x)
    e = model.simulate(u, dt) - y
    rms = float(np.sqrt(np.mean(e**2)))
    fitp = 100 * (1 - np.linalg.norm(e) / np.linalg.norm(y - y.mean()))
    return FractionalFit(model, rms, float(fitp), "time", frf.freq, frf.H)


def _equation_error_starts(u, y, dt, om, lower, constrain, n_best):
    """The ``n_best`` orders of a grid (step 0.2) by the equation error, as starts."""
    grid = np.arange(0.2, 2.81, 0.2)
    derivs = {}

    def deriv(q):
        q = round(float(q), 6)
        if q not in derivs:
            derivs[q] = _gl_derivative(y, q, dt)
        return derivs[q]

    cands = []
    for x in itertools.product(grid, repeat=len(om.free)):
        o = dict(zip(om.free, x, strict=True))
        full = [om.fixed.get(k, o.get(k)) for k in om.names]
        if any(a_ < b_ + max(om.gap, 1e-9) for a_, b_ in itertools.pairwise(full)):
            continue
        M = np.column_stack([deriv(q) for q in full] + [y])
        if not np.all(np.isfinite(M)):
            continue
        for sg in (1.0, -1.0) if constrain else (1.0,):
            cf, cost = _bounded_lstsq(sg * M, u, lower)
            cands.append((cost, full, sg * cf, sg))
    cands.sort(key=lambda c: c[0])
    return [
        (np.concatenate([om.increments(full), cf]), sg)
        for _, full, cf, sg in cands[:n_best]
    ]


def _time_fit_bounds(om, lower, sg):
    """Bounds of ``(order increments, coefficients)`` for coefficients of sign ``sg``."""
    n_coef = lower.size
    c_lo = np.where(np.isfinite(lower), 0.0, -np.inf)
    cf_lb = c_lo if sg > 0 else np.full(n_coef, -np.inf)
    cf_ub = np.full(n_coef, np.inf) if sg > 0 else -c_lo
    cf_lb[-1], cf_ub[-1] = -np.inf, np.inf
    lb = np.concatenate([[0.0] * len(om.free), cf_lb])
    ub = np.concatenate([[om.bound()] * len(om.free), cf_ub])
    return lb, ub


def _coherence_weight(coh: np.ndarray) -> np.ndarray:
    """Inverse variance of the relative H1 error, ``g2 / (1 - g2)`` (Bendat & Piersol)."""
    g = np.clip(coh, 0.0, 0.999)
    return g / (1 - g)
