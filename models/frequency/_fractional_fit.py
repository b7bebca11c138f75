"""Fitting fractional-order transfer functions ``1/(a s^alpha + b s^beta + c)`` to data.

In the frequency domain (:func:`fit_fractional_frf`: a grid over the orders and least
squares for the coefficients), in the time domain (:func:`fit_fractional_tf`), and by
seed 004's simplex on the error between the empirical transfer function estimate and
the model (:func:`fit_fractional_simplex`).
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd
import scipy.optimize as sopt

from pdmkit.errors import DataError, ModelError
from pdmkit.models.frequency._fractional import (
    _SEED_NAMES,
    FractionalTF,
    _causal_conv,
    gl_weights,
)
from pdmkit.models.frequency._frf import _as_float_array, _check_fs, frf_estimate

__all__ = [
    "FractionalFit",
    "fit_fractional_frf",
    "fit_fractional_simplex",
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
        Their coefficients and the constant term (seed 004 notation).
    error : float
        RMS relative error ``sqrt(mean |H - G|^2 / |H|^2)`` on the fitted data (frequency
        fits), RMS output error (time fits), or seed 004's objective
        ``mean |G_EETF - G|`` (:func:`fit_fractional_simplex`).
    fit_percent : float
        ``100 (1 - ||H - G|| / ||H - mean H||)`` (or the same on the output).
    method : str
        ``"lsq"`` (variable projection + least squares) or ``"simplex"`` (seed 004).


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

    def plot(self, ax=None):
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


def fit_fractional_frf(  # noqa: C901, PLR0915
    freq,
    H,
    *,
    den_terms: int = 2,
    fixed_orders: Mapping[str, float] | None = None,
    weight=None,
    order_bounds: tuple[float, float] = (0.05, 2.5),
    grid: int = 12,
    fit_gain: bool = False,
    dt: float | None = None,
    min_gap: float = 0.05,
    constrain: bool = True,
) -> FractionalFit:
    """Fit ``1 / (a s^alpha + b s^beta + c)`` (seed 004, eq. 8) to frequency-response data.

    For given orders the denominator is linear in its coefficients, and ``1/G`` is fitted
    to ``1/H`` with weights ``|H|`` (a relative error). The orders are searched on a grid,
    the best few refined with the coefficients projected out, and the winner polished on
    the relative complex error ``(H - G)/|H|`` with all parameters free
    (:func:`scipy.optimize.least_squares`). Seed 004 minimises ``|G_EETF - G|`` with
    Nelder-Mead; the relative error weights every decade alike.

    Parameters
    ----------
    freq : array_like
        Frequencies in Hz.
    H : array_like of complex
        FRF values.
    den_terms : {1, 2, 3}
        Fractional terms in the denominator besides the constant ``c``: 1 gives
        ``a s^alpha + c``, 2 the seed's structure, 3 adds ``d s^gamma``.
    fixed_orders : dict, optional
        Orders held fixed, by name (``"alpha"``, ``"beta"``, ``"gamma"``), e.g.
        ``{"alpha": 2, "beta": 1}`` for the integer-order model of seed 004 table 1.
    weight : array_like, optional
        Extra weight per frequency (e.g. coherence).
    order_bounds : (float, float)
        Range of the free orders.
    grid : int
        Grid points per free order for the start.
    fit_gain : bool
        Fit a numerator gain too (otherwise 1, as in the seed; the gain is absorbed by
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
    f, Hk, we = freq[keep], H[keep], w_extra[keep]
    wk = 2 * np.pi * f
    s = 1j * wk if dt is None else (1 - np.exp(-1j * wk * dt)) / dt
    Hinv = 1.0 / Hk
    wgt = np.abs(Hk) * np.sqrt(we)
    lo, hi = order_bounds
    gap = float(min_gap) if constrain else 0.0
    om = _Orders(names, fixed, lo, hi, gap)
    n_free = len(om.free)
    nc = den_terms + 1

    def fit_sign(sign: float):
        # constrained: the fractional coefficients share the sign of the gain, which the
        # data decide (both are tried)
        lower = np.r_[np.full(den_terms, 0.0 if constrain else -np.inf), -np.inf]

        def spow(orders):
            return np.column_stack([s**q for q in orders] + [np.ones_like(s)])

        def coefs(orders):
            cf, cost = _coefs_for_orders(sign * Hinv, spow(orders), wgt, lower)
            return sign * cf, cost

        def profile(x):
            if np.any(np.asarray(x) < 0):
                return np.inf
            o = om.orders(x)
            pen = om.violation(o)
            return coefs(o)[1] * (1.0 + 1e3 * pen) + pen

        if n_free:
            g = np.linspace(lo, hi, grid)
            cands = []
            for x in itertools.product(g, repeat=n_free):
                o = dict(zip(om.free, x, strict=True))
                full = [fixed.get(k, o.get(k)) for k in names]
                if any(a_ < b_ + max(gap, 1e-9) for a_, b_ in itertools.pairwise(full)):
                    continue  # orders kept in descending order (alpha > beta > gamma)
                xi = om.increments(full)
                cands.append((profile(xi), xi))
            if not cands:
                raise ModelError(
                    f"no orders in order_bounds={order_bounds} are {gap} apart around the "
                    f"fixed orders {fixed}; widen order_bounds or lower min_gap."
                )
            cands.sort(key=lambda c: c[0])
            best = None
            for c0, x0 in cands[:3]:
                # coarse: the least-squares polish below does the fine work
                sol = sopt.minimize(
                    profile,
                    x0,
                    method="Nelder-Mead",
                    bounds=[(0.0, om.bound())] * n_free,
                    options={
                        "xatol": 1e-4,
                        "fatol": 1e-8 * max(c0, 1e-300),
                        "maxiter": 300 * n_free,
                    },
                )
                if best is None or sol.fun < best.fun:
                    best = sol
            x_best = np.clip(best.x, 0.0, om.bound())
        else:
            x_best = np.array([])
        orders = om.orders(x_best)
        coef, _ = coefs(orders)
        theta0 = np.concatenate([x_best, coef, [1.0] if fit_gain else []])

        def unpack(theta):
            x, cf = theta[:n_free], theta[n_free : n_free + nc]
            k = theta[n_free + nc] if fit_gain else 1.0
            return om.orders(x), cf, k

        def resid(theta):
            o, cf, k = unpack(theta)
            G = k / (spow(o) @ cf)
            e = (Hk - G) / np.abs(Hk) * np.sqrt(we)
            pen = 1e3 * om.violation(o)
            return np.concatenate([e.real, e.imag, [pen]])

        big = np.inf
        c_lo = np.where(np.isfinite(lower), 0.0, -big)
        cf_lb = np.where(sign > 0, c_lo, -big)
        cf_ub = np.where(sign > 0, big, -c_lo)
        cf_lb[-1], cf_ub[-1] = -big, big
        lb = np.concatenate([[0.0] * n_free, cf_lb, [-big] if fit_gain else []])
        ub = np.concatenate([[om.bound()] * n_free, cf_ub, [big] if fit_gain else []])
        theta0 = np.clip(theta0, lb + 1e-12 * (lb > -big), ub - 1e-12 * (ub < big))
        sol = sopt.least_squares(resid, theta0, bounds=(lb, ub), x_scale="jac")
        theta = sol.x if np.sum(sol.fun**2) <= np.sum(resid(theta0) ** 2) else theta0
        return theta, float(np.sum(resid(theta) ** 2))

    fits = [fit_sign(sg) for sg in ((1.0, -1.0) if constrain else (1.0,))]
    theta, _ = min(fits, key=lambda t: t[1] if np.isfinite(t[1]) else np.inf)

    def unpack(theta):
        x, cf = theta[:n_free], theta[n_free : n_free + nc]
        k = theta[n_free + nc] if fit_gain else 1.0
        return om.orders(x), cf, k

    o, cf, k = unpack(theta)
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


def fit_fractional_tf(
    u,
    y,
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
    :func:`~pdmkit.models.frequency.frf_estimate`; seed 004's empirical transfer
    function) and fits it (:func:`fit_fractional_frf`), weighting each frequency by
    its coherence (frequencies below ``coherence_min`` dropped) by the inverse variance
    of the H1 estimate, ``g2 / (1 - g2)``.
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
        grid = np.arange(0.2, 2.81, 0.2)
        derivs = {}

        def deriv(q):
            q = round(float(q), 6)
            if q not in derivs:
                derivs[q] = _gl_derivative(y, q, dt)
            return derivs[q]

        cands = []
        for x in itertools.product(grid, repeat=nf):
            o = dict(zip(om.free, x, strict=True))
            full = [fixed.get(k, o.get(k)) for k in names]
            if any(a_ < b_ + max(gap, 1e-9) for a_, b_ in itertools.pairwise(full)):
                continue
            M = np.column_stack([deriv(q) for q in full] + [y])
            if not np.all(np.isfinite(M)):
                continue
            for sg in (1.0, -1.0) if constrain else (1.0,):
                cf, cost = _bounded_lstsq(sg * M, u, lower)
                cands.append((cost, full, sg * cf, sg))
        cands.sort(key=lambda c: c[0])
        for _cost, full, cf, sg in cands[: n_starts - 1]:
            starts.append((np.concatenate([om.increments(full), cf]), sg))

    def bounds(sg):
        c_lo = np.where(np.isfinite(lower), 0.0, -np.inf)
        cf_lb = c_lo if sg > 0 else np.full(n_terms + 1, -np.inf)
        cf_ub = np.full(n_terms + 1, np.inf) if sg > 0 else -c_lo
        cf_lb[-1], cf_ub[-1] = -np.inf, np.inf
        lb = np.concatenate([[0.0] * nf, cf_lb])
        ub = np.concatenate([[om.bound()] * nf, cf_ub])
        return lb, ub

    best = None
    for theta0, sg in starts:
        lb, ub = bounds(sg)
        x0 = np.clip(theta0, lb + 1e-9 * np.isfinite(lb), ub - 1e-9 * np.isfinite(ub))
        sol = sopt.least_squares(resid, x0, bounds=(lb, ub), x_scale="jac", max_nfev=200)
        if best is None or sol.cost < best.cost:
            best = sol
    model = build(best.x)
    e = model.simulate(u, dt) - y
    rms = float(np.sqrt(np.mean(e**2)))
    fitp = 100 * (1 - np.linalg.norm(e) / np.linalg.norm(y - y.mean()))
    return FractionalFit(model, rms, float(fitp), "time", frf.freq, frf.H)


def _coherence_weight(coh: np.ndarray) -> np.ndarray:
    """Inverse variance of the relative H1 error, ``g2 / (1 - g2)`` (Bendat & Piersol)."""
    g = np.clip(coh, 0.0, 0.999)
    return g / (1 - g)


def _seed_response(theta: np.ndarray, s: np.ndarray) -> np.ndarray:
    """``1 / (a s^alpha + b s^beta + c)`` for ``theta = (a, alpha, b, beta, c)``."""
    a, al, b, be, c = theta
    with np.errstate(all="ignore"):
        return 1.0 / (a * s**al + b * s**be + c)


def _simplex_starts(s, Hr, fixed, bounds, n_starts, power):
    """Start vectors ``(a, alpha, b, beta, c)`` for the simplex.

    For the orders of a coarse grid (``fixed`` orders held) the coefficients of a
    linear least-squares fit of ``1/H`` weighted by ``|H|`` (relative error) and by
    ``|H|^2`` (absolute error, since ``|H - G| ~ |H|^2 |1/H - 1/G|``); the best
    ``n_starts`` by the objective.
    """
    lo, hi = bounds
    grid = np.round(np.arange(0.25, hi + 1e-9, 0.25), 6)  # holds the integers
    grid = grid[grid >= lo]
    al_grid = [fixed["alpha"]] if "alpha" in fixed else grid
    be_grid = [fixed["beta"]] if "beta" in fixed else grid
    Hmean = Hr.mean(axis=0)
    Hinv = 1.0 / Hmean
    cands = []
    for al, be in itertools.product(al_grid, be_grid):
        if al <= be and not ("alpha" in fixed and "beta" in fixed):
            continue  # alpha > beta: the swapped pair is the same model
        spow = np.column_stack([s**al, s**be, np.ones_like(s)])
        for wgt in (np.abs(Hmean), np.abs(Hmean) ** 2):
            (a, b, c), _ = _coefs_for_orders(Hinv, spow, wgt / wgt.max())
            theta = np.array([a, al, b, be, c])
            cost = float(np.mean(np.abs(Hr - _seed_response(theta, s)) ** power))
            if np.isfinite(cost):
                cands.append((cost, theta))
    cands.sort(key=lambda t: t[0])
    return [t for _, t in cands[: max(1, int(n_starts))]]


def fit_fractional_simplex(  # noqa: C901
    freq,
    H,
    *,
    fixed_orders: Mapping[str, float] | None = None,
    start: Mapping[str, float] | None = None,
    loss: str = "abs",
    order_bounds: tuple[float, float] = (0.0, 4.0),
    n_starts: int = 6,
    maxiter: int = 4000,
) -> FractionalFit:
    """Seed 004's fit: Nelder-Mead of ``1/(a s^alpha + b s^beta + c)`` on ``|G_EETF - G|``.

    Seed 004 (section 4.1, eqs. 6-9) minimises the error between the empirical
    transfer functions of its tuning records and the model,
    ``f_e = |G_EETF(omega) - G(omega, [a, b, c, alpha, beta])|``, with the simplex
    method of Lagarias et al. (1998), i.e. MATLAB's ``fminsearch``; here
    :func:`scipy.optimize.minimize` with ``method="Nelder-Mead"`` (the same algorithm:
    initial simplex 5 % along each coordinate, standard reflection / expansion /
    contraction coefficients), restarted from its own result until it stops improving.
    The objective is the mean over the records and frequencies of ``|H - G|``
    (``loss="abs"``, the seed's ``f_e``) or of ``|H - G|^2`` (``"squared"``, the mean
    square error the seed uses as failure index). Nelder-Mead is local: it starts
    from the best ``n_starts`` orders of a grid (step 0.25) with their coefficients
    from a weighted linear least-squares fit of ``1/H``, or from ``start``.

    Parameters
    ----------
    freq : array_like, shape (n_freq,)
        Frequencies in Hz (seed 004 uses 100-1000 rad/s).
    H : array_like of complex, shape (n_freq,) or (n_records, n_freq)
        Empirical transfer functions; the objective averages over all records (the
        seed's 20 tuning data sets per condition).
    fixed_orders : dict, optional
        ``{"alpha": 2, "beta": 1}`` gives the integer-order model (IOM) of seed 004,
        table 1; other orders are free in ``order_bounds``.
    start : dict, optional
        Start values of ``a, alpha, b, beta, c`` (instead of the grid).
    loss : {"abs", "squared"}
    order_bounds : (float, float), default (0, 4)
        Range of the free orders (the seed leaves them free; a measured ETFE can fall
        off faster than ``1/s^3``).
    n_starts : int, default 6
    maxiter : int, default 4000
        Iterations of each Nelder-Mead run.

    Returns
    -------
    FractionalFit
        ``method="simplex"``; ``error`` is the objective at the optimum (the seed's
        ``f_e`` for ``loss="abs"``), ``H`` the mean of the records.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models.frequency import FractionalTF, fit_fractional_simplex
    >>> true = FractionalTF.seed004(a=0.02, alpha=1.6, b=0.3, beta=0.7, c=1.0)
    >>> f = np.linspace(100, 1000, 60) / (2 * np.pi)       # 100-1000 rad/s
    >>> fit = fit_fractional_simplex(f, true.frequency_response(2 * np.pi * f))
    >>> round(fit.alpha, 2), round(fit.beta, 2), fit.error < 1e-4
    (1.6, 0.7, True)
    """
    freq = _as_float_array(freq, "freq").reshape(-1)
    Hr = np.asarray(H, dtype=complex)
    Hr = Hr[None, :] if Hr.ndim == 1 else Hr
    if Hr.ndim != 2 or Hr.shape[1] != freq.size:
        raise DataError(
            f"H must be (n_freq,) or (n_records, n_freq) with n_freq = {freq.size} "
            f"(the length of freq); got shape {np.shape(H)}."
        )
    if not (np.all(np.isfinite(Hr)) and np.all(freq > 0)) or freq.size < 5:
        raise DataError(
            "fit_fractional_simplex needs >= 5 frequencies > 0 and finite H; got "
            f"{freq.size} frequencies (min {freq.min() if freq.size else None})."
        )
    if loss not in ("abs", "squared"):
        raise ModelError(f"loss must be 'abs' or 'squared'; got {loss!r}.")
    fixed = {k: float(v) for k, v in dict(fixed_orders or {}).items()}
    for k in fixed:
        if k not in ("alpha", "beta"):
            raise ModelError(f"fixed_orders names {k!r}; the orders are alpha and beta.")
    lo, hi = (float(v) for v in order_bounds)
    s = 1j * 2 * np.pi * freq
    Hmean = Hr.mean(axis=0)
    free = [i for i, k in enumerate(_SEED_NAMES) if k not in fixed]
    power = 1 if loss == "abs" else 2

    def full(x):
        theta = np.array([fixed.get(k, np.nan) for k in _SEED_NAMES])
        theta[free] = x
        return theta

    def objective(x):
        theta = full(x)
        if theta[1] < lo or theta[1] > hi or theta[3] < lo or theta[3] > hi:
            return np.inf
        d = np.abs(Hr - _seed_response(theta, s)) ** power
        val = float(np.mean(d))
        return val if np.isfinite(val) else np.inf

    if start is not None:
        starts = [np.array([float(start[k]) for k in _SEED_NAMES])]
        for k, v in fixed.items():
            starts[0][_SEED_NAMES.index(k)] = v
    else:
        starts = _simplex_starts(s, Hr, fixed, (lo, hi), n_starts, power)
    best = None
    for theta0 in starts:
        x, fx = theta0[free], objective(theta0[free])
        f_start = fx
        for _ in range(4):  # restart from the result until it stops improving
            sol = sopt.minimize(
                objective,
                x,
                method="Nelder-Mead",
                options={"maxiter": maxiter, "xatol": 1e-9, "fatol": 1e-9 * f_start},
            )
            improved = sol.fun < fx * (1 - 1e-6)
            if sol.fun <= fx:
                x, fx = sol.x, float(sol.fun)
            if not improved:
                break
        if best is None or fx < best[1]:
            best = (x, fx)
    theta = full(best[0])
    a, al, b, be, c = (float(v) for v in theta)
    if be > al:  # the same model with the terms named so that alpha >= beta
        a, al, b, be = b, be, a, al
    model = FractionalTF.seed004(a, al, b, be, c)
    G = model.frequency_response(2 * np.pi * freq)
    spread = np.linalg.norm(Hmean - Hmean.mean())
    fitp = 100 * (1 - np.linalg.norm(Hmean - G) / spread) if spread > 0 else float("nan")
    return FractionalFit(
        model, float(best[1]), float(fitp), "frequency", freq, Hmean, "simplex"
    )
