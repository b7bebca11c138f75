"""Survival models: RUL from lifetimes (and covariates), with right censoring.

Time is counted from the start of each unit's life (time 0): a unit's lifetime is the
time of its last row, and units whose ``failed`` flag is False are right-censored (they
were still working then). The RUL of a unit that has survived to ``t`` is the
conditional distribution of ``T - t`` given ``T > t`` (lifelines' ``conditional_after``):
its median is the estimate, its quantiles the interval.

- :class:`ReliabilitySurvivalModel`: a parametric lifetime distribution (Weibull by
  default) fitted by maximum likelihood with censoring; it knows nothing of a unit's
  condition, only its age.
- :class:`CovariateSurvivalModel`: a Weibull proportional-hazards model with
  time-varying covariates (condition indicators), ``h(t) = h0(t) exp(gamma . z(t))``,
  the model behind condition-based maintenance tools such as EXAKT (Banjevic & Jardine
  2006). The RUL holds the covariates at their latest values.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
import scipy.optimize
import scipy.stats
from sklearn.base import BaseEstimator

from pdmkit.errors import ConvergenceWarning, DataError
from pdmkit.rul._base import (
    TrajectoryMixin,
    as_columns,
    check_fitted,
    check_level,
    check_max_rul,
    check_table,
    failed_column,
    keep_init_args,
    resolve_keys,
)

if TYPE_CHECKING:
    from typing import Self

    from numpy.typing import ArrayLike

_DISTRIBUTIONS = {
    # name: (scipy distribution, parameter names; every parameter positive)
    "weibull": (scipy.stats.weibull_min, ("shape", "scale")),
    "lognormal": (scipy.stats.lognorm, ("sigma", "scale")),
    "loglogistic": (scipy.stats.fisk, ("shape", "scale")),
    "exponential": (scipy.stats.expon, ("scale",)),
}


def _check_lifetimes(lifetimes, failed):
    t = np.asarray(lifetimes, dtype=float)
    if t.ndim != 1 or t.size == 0:
        raise DataError(f"lifetimes must be a non-empty 1-D array, got shape {t.shape}")
    if not np.isfinite(t).all() or (t <= 0).any():
        raise DataError(
            "lifetimes must be finite and positive (time counted from the start of each "
            f"unit's life); got min {np.nanmin(t):g}"
        )
    if failed is None:
        e = np.ones(t.size, dtype=bool)
    else:
        e = np.asarray(failed).astype(bool)
        if e.shape != t.shape:
            raise DataError(f"failed has {e.size} values for {t.size} lifetimes")
    if not e.any():
        raise DataError(
            f"all {t.size} lifetimes are censored (no failure observed); a lifetime "
            "distribution cannot be estimated without at least one failure"
        )
    return t, e


class _SurvivalBase(TrajectoryMixin, BaseEstimator):
    _min_history = 1

    def _result(self, names, times, q_values):
        est, lo, hi = q_values
        return self._prediction(names, times, est, lo, hi, level=float(self.level))


class ReliabilitySurvivalModel(_SurvivalBase):
    """A lifetime distribution fitted to (censored) lifetimes; RUL given survival so far.

    Parameters
    ----------
    distribution : {"weibull", "lognormal", "loglogistic", "exponential"}
        Lifetime distribution (scipy.stats ``weibull_min``, ``lognorm``, ``fisk``,
        ``expon``, location fixed at 0).
    level : float, default 0.9
        Confidence level of the intervals.
    max_rul : float, optional
        Cap on estimates and intervals.
    unit, time, failed : str
        Key columns; ``failed`` (default ``"failed"`` when present) is False for
        censored units.

    Attributes
    ----------
    params_ : dict
        Maximum-likelihood parameters (``shape``, ``scale`` for the Weibull).
    dist_ : scipy.stats frozen distribution
    loglik_ : float
        Log-likelihood at the optimum.
    n_units_, n_failed_, n_censored_ : int

    Notes
    -----
    The conditional RUL quantile ``q`` of a unit aged ``t`` is
    ``isf((1 - q) S(t)) - t``; for the Weibull the median is
    ``scale * ((t / scale) ** shape + ln 2) ** (1 / shape) - t``.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from pdmkit.rul import ReliabilitySurvivalModel
    >>> life = 100 * np.random.default_rng(0).weibull(3.0, 400)
    >>> model = ReliabilitySurvivalModel().fit_lifetimes(life)
    >>> round(model.params_["shape"], 1), round(model.params_["scale"])
    (3.0, 104)
    >>> now = pd.DataFrame({"unit": [1, 2], "time": [10.0, 120.0]})
    >>> model.predict(now).estimate.round(1)   # an old unit has little life left
    array([82.4, 15.7])
    """

    def __init__(
        self,
        distribution: str = "weibull",
        *,
        level: float = 0.9,
        max_rul: float | None = None,
        unit: str = "unit",
        time: str | None = None,
        failed: str | None = None,
    ) -> None:
        keep_init_args(self, locals())

    def fit(self, table: pd.DataFrame, y: object = None) -> Self:
        """Fit the distribution to the lifetimes of the units in a long table.

        Each unit's lifetime is the time of its last row; ``failed`` False marks it
        censored there.

        Returns
        -------
        self

        Examples
        --------
        >>> import pandas as pd
        >>> from pdmkit.rul import ReliabilitySurvivalModel
        >>> t = pd.DataFrame({"unit": [1, 2, 3, 4], "time": [90.0, 110.0, 100.0, 60.0],
        ...                   "failed": [True, True, True, False]})
        >>> m = ReliabilitySurvivalModel("exponential").fit(t)
        >>> m.params_["scale"], m.n_censored_     # total time / failures = 360 / 3
        (120.0, 1)
        """
        table = check_table(table)
        self._keys = resolve_keys(table, self.unit, self.time)
        self._failed = failed_column(table, self.failed)
        units = self._split(table, "training table")
        return self._fit(
            np.array([u.t[-1] for u in units]), np.array([u.failed for u in units])
        )

    def fit_lifetimes(self, lifetimes: ArrayLike, failed: ArrayLike | None = None) -> Self:
        """Fit the distribution to lifetimes directly.

        Parameters
        ----------
        lifetimes : array_like
            Positive lifetimes (failure or censoring times).
        failed : array_like of bool, optional
            False for censored lifetimes (default all failures).

        Returns
        -------
        self

        Examples
        --------
        >>> from pdmkit.rul import ReliabilitySurvivalModel
        >>> ReliabilitySurvivalModel("exponential").fit_lifetimes([1.0, 2.0, 3.0]).params_
        {'scale': 2.0}
        """
        self._keys = (self.unit, self.time or "time")
        self._failed = None
        return self._fit(*_check_lifetimes(lifetimes, failed)[:2])

    def _fit(self, t, e):
        if self.distribution not in _DISTRIBUTIONS:
            raise ValueError(
                f"distribution must be one of {list(_DISTRIBUTIONS)}, got "
                f"{self.distribution!r}"
            )
        check_level(self.level)
        check_max_rul(self.max_rul)
        t, e = _check_lifetimes(t, e)
        dist, names = _DISTRIBUTIONS[self.distribution]
        if self.distribution == "exponential":
            params = np.array([t.sum() / e.sum()])  # closed form
            ok = True
        else:

            def nll(theta):
                p = np.exp(theta)
                frozen = dist(*p[:-1], scale=p[-1])
                return -(frozen.logpdf(t[e]).sum() + frozen.logsf(t[~e]).sum())

            start = np.log([1.0, np.median(t)])
            if e.sum() >= 2:
                with np.errstate(all="ignore"), warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    guess = dist.fit(t[e], floc=0)
                if np.isfinite(np.log([guess[0], guess[-1]])).all():
                    start = np.log([guess[0], guess[-1]])
            res = scipy.optimize.minimize(
                nll,
                start,
                method="Nelder-Mead",
                options={"xatol": 1e-10, "fatol": 1e-12, "maxiter": 4000},
            )
            res = scipy.optimize.minimize(nll, res.x, method="BFGS")
            ok = bool(res.success) or res.status == 2  # 2: precision loss at the optimum
            params = np.exp(res.x)
        if not ok:
            warnings.warn(
                f"the {self.distribution} likelihood optimisation did not converge; the "
                "parameters may be inaccurate",
                ConvergenceWarning,
                stacklevel=3,
            )
        self.params_ = {n: float(v) for n, v in zip(names, params, strict=True)}
        self.dist_ = dist(*params[:-1], scale=params[-1])
        self.loglik_ = float(self.dist_.logpdf(t[e]).sum() + self.dist_.logsf(t[~e]).sum())
        self.n_units_ = int(t.size)
        self.n_failed_ = int(e.sum())
        self.n_censored_ = int((~e).sum())
        return self

    def survival_function(self, t: ArrayLike) -> np.ndarray:
        """Probability of surviving beyond ``t``.

        Examples
        --------
        >>> from pdmkit.rul import ReliabilitySurvivalModel
        >>> m = ReliabilitySurvivalModel("exponential").fit_lifetimes([2.0, 2.0])
        >>> round(float(m.survival_function(2.0)), 4)   # exp(-1)
        0.3679
        """
        check_fitted(self, "dist_")
        return self.dist_.sf(np.asarray(t, dtype=float))

    def rul_quantiles(self, age: ArrayLike, q: ArrayLike) -> np.ndarray:
        """Quantiles ``q`` of the remaining life of units that have survived to ``age``.

        Examples
        --------
        >>> from pdmkit.rul import ReliabilitySurvivalModel
        >>> m = ReliabilitySurvivalModel("exponential").fit_lifetimes([5.0, 15.0])
        >>> round(float(m.rul_quantiles(30.0, 0.5)), 4)   # memoryless: 10 ln 2
        6.9315
        """
        check_fitted(self, "dist_")
        age = np.asarray(age, dtype=float)
        q = np.asarray(q, dtype=float)
        log_target = self.dist_.logsf(age) + np.log1p(-q)
        t_q = self.dist_.isf(np.exp(log_target))
        return np.maximum(np.where(np.isfinite(t_q), t_q, age) - age, 0.0)

    def _predict_units(self, units):
        level = check_level(self.level)
        ages = np.array([u.t[-1] for u in units], dtype=float)
        qs = [self.rul_quantiles(ages, q) for q in (0.5, (1 - level) / 2, (1 + level) / 2)]
        return self._result([u.name for u in units], ages, qs)


class CovariateSurvivalModel(_SurvivalBase):
    """Weibull proportional hazards with time-varying covariates.

    ``h(t | z) = (k / lam) (t / lam)^(k - 1) exp(gamma . z(t))`` with the covariates
    ``z`` (standardised over the training rows) piecewise constant: the row at time
    ``t_i`` holds for ``(t_{i-1}, t_i]`` (the first row from time 0). The parameters
    maximise the full likelihood of the (censored) lifetimes. The RUL of a unit aged
    ``t`` with latest covariates ``z`` solves
    ``exp(-exp(gamma . z) (H0(t + r) - H0(t))) = 1 - q`` with ``H0(t) = (t / lam)^k``:
    the covariates are held at their latest values.

    Parameters
    ----------
    covariates : str or sequence of str
        Covariate columns (condition indicators, or constant per-unit properties).
    penalizer : float, default 0
        L2 penalty ``penalizer / 2 * |gamma|^2`` on the (standardised) coefficients,
        for covariates that separate failures almost perfectly. The fit is bounded
        (shape in [0.05, 50], coefficients in [-30, 30]); a fit that stops at a bound
        warns with a ConvergenceWarning.
    level, max_rul, unit, time, failed
        As for :class:`ReliabilitySurvivalModel`.

    Attributes
    ----------
    shape_, scale_ : float
        Weibull baseline ``k`` and ``lam``, for covariates at their training mean
        (``mean_``); at raw covariates ``z = 0`` the scale is
        ``scale_ * exp(coef_ . mean_ / std_ / shape_)``.
    coef_ : pandas.Series
        ``gamma`` per covariate, in standardised units (hazard ratio per standard
        deviation: ``exp(coef_)``).
    mean_, std_ : pandas.Series
        Standardisation of the covariates.
    loglik_ : float
    n_units_, n_failed_, n_censored_ : int

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from pdmkit.rul import CovariateSurvivalModel
    >>> rng = np.random.default_rng(0)
    >>> rows = []
    >>> for u in range(300):   # the hazard doubles per unit of "wear"
    ...     z = rng.normal()
    ...     life = 50 * rng.weibull(2.0) * np.exp(-np.log(2) * z / 2.0)
    ...     rows.append({"unit": u, "time": life, "wear": z})
    >>> model = CovariateSurvivalModel("wear").fit(pd.DataFrame(rows))
    >>> bool(abs(model.coef_["wear"] / model.std_["wear"] - np.log(2)) < 0.15)
    True
    """

    def __init__(
        self,
        covariates: str | Sequence[str],
        *,
        penalizer: float = 0.0,
        level: float = 0.9,
        max_rul: float | None = None,
        unit: str = "unit",
        time: str | None = None,
        failed: str | None = None,
    ) -> None:
        keep_init_args(self, locals())

    def _split_columns(self) -> list[str]:
        return list(self._cols)

    @staticmethod
    def _rows(units, mean, std):
        t_prev, t_end, z, last, event = [], [], [], [], []
        for u in units:
            if u.t[0] < 0:
                raise DataError(
                    f"unit {u.name!r} has negative time {u.t[0]:g}; time is counted from "
                    "the start of the unit's life"
                )
            prev = np.concatenate([[0.0], u.t[:-1]])
            t_prev.append(prev)
            t_end.append(u.t)
            z.append((u.x - mean) / std)
            flag = np.zeros(len(u), dtype=bool)
            flag[-1] = True
            last.append(flag)
            event.append(flag & u.failed)
        return (
            np.concatenate(t_prev),
            np.concatenate(t_end),
            np.concatenate(z),
            np.concatenate(last),
            np.concatenate(event),
        )

    @staticmethod
    def _nll(theta, t_prev, t_end, z, event):
        """Negative log-likelihood and its gradient in ``(log k, log lam, gamma)``."""
        u, v, gamma = theta[0], theta[1], theta[2:]
        k = np.exp(u)
        lt_end = np.log(t_end) - v
        with np.errstate(divide="ignore"):
            lt_prev = np.log(t_prev) - v
        h_end = np.exp(k * lt_end)
        h_prev = np.where(t_prev > 0, np.exp(k * np.where(t_prev > 0, lt_prev, 0.0)), 0.0)
        eta = z @ gamma
        w = np.exp(eta)
        dh = h_end - h_prev
        cum = np.sum(w * dh)
        ev_log_h = np.sum(u - v + (k - 1) * lt_end[event] + eta[event])
        nll = cum - ev_log_h
        # gradient
        dprev_u = np.where(t_prev > 0, h_prev * k * np.where(t_prev > 0, lt_prev, 0.0), 0.0)
        g_u = np.sum(w * (h_end * k * lt_end - dprev_u)) - np.sum(1 + k * lt_end[event])
        g_v = np.sum(w * (-k * dh)) - np.sum(np.full(event.sum(), -k))
        g_gamma = (w * dh) @ z - z[event].sum(axis=0)
        return nll, np.concatenate([[g_u, g_v], g_gamma])

    def fit(self, table: pd.DataFrame, y: object = None) -> Self:
        """Fit the baseline and the covariate effects by maximum likelihood.

        Returns
        -------
        self

        Raises
        ------
        pdmkit.errors.DataError
            No failed unit; a constant covariate; negative times; NaN values.

        Examples
        --------
        >>> import pandas as pd
        >>> from pdmkit.rul import CovariateSurvivalModel
        >>> import numpy as np
        >>> rng = np.random.default_rng(1)
        >>> wear = rng.normal(size=60)
        >>> life = 50 * rng.weibull(2.0, 60) * np.exp(-wear / 2)
        >>> t = pd.DataFrame({"unit": range(60), "time": life, "wear": wear,
        ...                   "failed": life < 80})
        >>> m = CovariateSurvivalModel("wear").fit(t)
        >>> m.n_failed_ + m.n_censored_
        60
        """
        table = check_table(table)
        self._keys = resolve_keys(table, self.unit, self.time)
        self._failed = failed_column(table, self.failed)
        self._cols = as_columns(self.covariates)
        if not self._cols:
            raise ValueError("covariates must name at least one column")
        check_level(self.level)
        check_max_rul(self.max_rul)
        units = self._split(table, "training table")
        x = np.concatenate([u.x for u in units])
        mean = x.mean(axis=0)
        std = x.std(axis=0)
        flat = [c for c, s in zip(self._cols, std, strict=True) if not s > 0]
        if flat:
            raise DataError(
                f"covariate {flat} is constant over the training table; its effect cannot "
                "be estimated - drop it (use ReliabilitySurvivalModel without covariates)"
            )
        lifetimes = np.array([u.t[-1] for u in units])
        failed = np.array([u.failed for u in units])
        _check_lifetimes(lifetimes, failed)
        t_prev, t_end, z, _, event = self._rows(units, mean, std)
        base = ReliabilitySurvivalModel().fit_lifetimes(lifetimes, failed)
        theta0 = np.r_[
            np.log(base.params_["shape"]),
            np.log(base.params_["scale"]),
            np.zeros(len(self._cols)),
        ]
        pen = float(self.penalizer)
        if not pen >= 0:
            raise ValueError(f"penalizer must be >= 0, got {self.penalizer!r}")

        def objective(theta):
            f, g = self._nll(theta, t_prev, t_end, z, event)
            gamma = theta[2:]
            g = g.copy()
            g[2:] += pen * gamma
            return f + 0.5 * pen * float(gamma @ gamma), g

        span = np.log([lifetimes.min(), lifetimes.max()])
        bounds = [(np.log(0.05), np.log(50.0)), (span[0] - 5.0, span[1] + 5.0)]
        bounds += [(-30.0, 30.0)] * len(self._cols)
        theta0 = np.clip(theta0, [b[0] for b in bounds], [b[1] for b in bounds])
        with np.errstate(over="ignore", invalid="ignore"):
            res = scipy.optimize.minimize(
                objective,
                theta0,
                jac=True,
                method="L-BFGS-B",
                bounds=bounds,
                options={"maxiter": 5000, "gtol": 1e-9},
            )
        at_bound = np.isclose(res.x, [b[0] for b in bounds]) | np.isclose(
            res.x, [b[1] for b in bounds]
        )
        if at_bound.any():
            warnings.warn(
                "the proportional-hazards fit stopped at a parameter bound (shape, scale "
                "or a coefficient): the covariates separate the failures almost "
                "perfectly or the data hold too few failures; consider penalizer > 0",
                ConvergenceWarning,
                stacklevel=2,
            )
        elif not res.success or not np.isfinite(res.fun):
            warnings.warn(
                f"the proportional-hazards likelihood optimisation did not converge "
                f"({res.message}); the parameters may be inaccurate",
                ConvergenceWarning,
                stacklevel=2,
            )
        self.shape_ = float(np.exp(res.x[0]))
        self.scale_ = float(np.exp(res.x[1]))
        self.coef_ = pd.Series(res.x[2:], index=self._cols)
        self.mean_ = pd.Series(mean, index=self._cols)
        self.std_ = pd.Series(std, index=self._cols)
        self.loglik_ = float(-self._nll(res.x, t_prev, t_end, z, event)[0])
        self.n_units_ = len(units)
        self.n_failed_ = int(failed.sum())
        self.n_censored_ = int((~failed).sum())
        return self

    def rul_quantiles(self, age: ArrayLike, z: ArrayLike, q: ArrayLike) -> np.ndarray:
        """Quantiles ``q`` of the RUL at ``age`` with covariates ``z`` (raw units) held.

        ``z`` is one covariate vector or one row per unit (broadcast against ``age``).

        Examples
        --------
        >>> import pandas as pd
        >>> from pdmkit.rul import CovariateSurvivalModel
        >>> import numpy as np
        >>> rng = np.random.default_rng(1)
        >>> wear = rng.normal(size=60)
        >>> life = 50 * rng.weibull(2.0, 60) * np.exp(-wear / 2)
        >>> t = pd.DataFrame({"unit": range(60), "time": life, "wear": wear})
        >>> m = CovariateSurvivalModel("wear").fit(t)
        >>> worn, fresh = m.rul_quantiles(20.0, [[1.0], [-1.0]], 0.5)
        >>> bool(worn < fresh)
        True
        """
        check_fitted(self, "coef_")
        age = np.asarray(age, dtype=float)
        z = np.asarray(z, dtype=float)
        single = z.ndim <= 1  # one covariate vector
        z = np.atleast_2d(z)
        eta = ((z - self.mean_.to_numpy()) / self.std_.to_numpy()) @ self.coef_.to_numpy()
        if single:
            eta = eta[0]
        k, lam = self.shape_, self.scale_
        h_now = (age / lam) ** k
        total = h_now - np.log1p(-np.asarray(q, dtype=float)) * np.exp(-eta)
        return np.maximum(lam * total ** (1.0 / k) - age, 0.0)

    def _predict_units(self, units):
        level = check_level(self.level)
        ages = np.array([u.t[-1] for u in units], dtype=float)
        z = np.array([u.x[-1] for u in units])
        qs = [
            self.rul_quantiles(ages, z, q) for q in (0.5, (1 - level) / 2, (1 + level) / 2)
        ]
        return self._result([u.name for u in units], ages, qs)
