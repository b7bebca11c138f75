"""The fractional-calculus paper's fit of ``1/(a s^alpha + b s^beta + c)`` by Nelder-Mead.

The simplex of :func:`fit_fractional_simplex` on the error between the empirical transfer
function estimates and the model, started from a grid of orders with least-squares
coefficients (the fits of :mod:`._fractional_fit` minimise a relative error instead).
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np
import scipy.optimize as sopt

from pdmkit.errors import DataError, ModelError
from pdmkit.models.frequency._fractional import _SEED_NAMES, FractionalTF
from pdmkit.models.frequency._fractional_fit import FractionalFit, _coefs_for_orders
from pdmkit.models.frequency._frf import _as_float_array

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["fit_fractional_simplex"]


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


def fit_fractional_simplex(
    freq: ArrayLike,
    H: ArrayLike,
    *,
    fixed_orders: Mapping[str, float] | None = None,
    start: Mapping[str, float] | None = None,
    loss: str = "abs",
    order_bounds: tuple[float, float] = (0.0, 4.0),
    n_starts: int = 6,
    maxiter: int = 4000,
) -> FractionalFit:
    """Fit ``1/(a s^alpha + b s^beta + c)`` by Nelder-Mead on ``|G_EETF - G|``.

    The fractional-calculus paper (section 4.1, eqs. 6-9) minimises the error between the
    empirical transfer functions of its tuning records and the model,
    ``f_e = |G_EETF(omega) - G(omega, [a, b, c, alpha, beta])|``, with the simplex
    method of Lagarias et al. (1998), i.e. MATLAB's ``fminsearch``; here
    :func:`scipy.optimize.minimize` with ``method="Nelder-Mead"`` (the same algorithm:
    initial simplex 5 % along each coordinate, standard reflection / expansion /
    contraction coefficients), restarted from its own result until it stops improving.
    The objective is the mean over the records and frequencies of ``|H - G|``
    (``loss="abs"``, the paper's ``f_e``) or of ``|H - G|^2`` (``"squared"``, the mean
    square error the paper uses as failure index). Nelder-Mead is local: it starts
    from the best ``n_starts`` orders of a grid (step 0.25) with their coefficients
    from a weighted linear least-squares fit of ``1/H``, or from ``start``.

    Parameters
    ----------
    freq : array_like, shape (n_freq,)
        Frequencies in Hz (the paper uses 100-1000 rad/s).
    H : array_like of complex, shape (n_freq,) or (n_records, n_freq)
        Empirical transfer functions; the objective averages over all records (the
        paper's 20 tuning data sets per condition).
    fixed_orders : dict, optional
        ``{"alpha": 2, "beta": 1}`` gives the integer-order model (IOM) of the paper's
        table 1; other orders are free in ``order_bounds``.
    start : dict, optional
        Start values of ``a, alpha, b, beta, c`` (instead of the grid).
    loss : {"abs", "squared"}
    order_bounds : (float, float), default (0, 4)
        Range of the free orders (the paper leaves them free; a measured ETFE can fall
        off faster than ``1/s^3``).
    n_starts : int, default 6
    maxiter : int, default 4000
        Iterations of each Nelder-Mead run.

    Returns
    -------
    FractionalFit
        ``method="simplex"``; ``error`` is the objective at the optimum (the paper's
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
    freq, Hr, fixed = _checked_simplex_data(freq, H, loss, fixed_orders)
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
        x, fx = _restarted_nelder_mead(objective, theta0[free], maxiter)
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


def _checked_simplex_data(freq, H, loss, fixed_orders):
    """``(freq, H as (n_records, n_freq), fixed orders)`` checked for the simplex fit."""
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
    return freq, Hr, fixed


def _restarted_nelder_mead(objective, x, maxiter):
    """Nelder-Mead from ``x``, restarted from its result until it stops improving."""
    fx = objective(x)
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
    return x, fx
