"""Degradation models with Bayesian updating: linear and exponential.

Both are Bayesian linear regressions of a transformed indicator on time, as MATLAB's
``linearDegradationModel`` and ``exponentialDegradationModel``:

- linear: ``h(t) = a + b t + e``;
- exponential: ``h(t) = phi + exp(a + b t + e)``, i.e. ``log(h - phi) = a + b t + e``
  (``theta = exp(a)``, ``beta = b`` in MATLAB's notation, the offset ``phi`` fixed);

with Gaussian noise ``e ~ N(0, sigma^2)`` and a Gaussian prior on ``w = (a, b)``. The
prior and ``sigma^2`` are estimated from the training units (empirical Bayes: the
covariance of the per-unit least-squares fits, less the part their estimation noise
explains); each unit's history then updates the prior to a Gaussian posterior in
closed form, and :meth:`update` folds in new measurements as they arrive.

The RUL is the time until the noise-free path ``a + b t`` (transformed) reaches the
threshold, drawn from the posterior: its median is the estimate, its quantiles the
interval. A path already past the threshold has RUL 0; a path that never reaches it
(slope <= 0, or later than ``horizon``) has RUL ``inf``, so the estimate is ``inf``
when the threshold is more likely than not never crossed (``p_fail`` < 0.5 in the
prediction's extra columns).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator

from pdmkit.errors import DataError
from pdmkit.rul._base import (
    DegradationMixin,
    Unit,
    check_fitted,
    check_level,
    check_positive_int,
    keep_init_args,
)

if TYPE_CHECKING:
    from typing import Self

    from pdmkit.rul._result import RULPrediction

_BIG = 1e300


def _design(t: np.ndarray) -> np.ndarray:
    return np.column_stack([np.ones_like(t), t])


def _ols(t: np.ndarray, z: np.ndarray):
    X = _design(t)
    xtx = X.T @ X
    w = np.linalg.solve(xtx, X.T @ z)
    rss = float(np.sum((z - X @ w) ** 2))
    return w, rss, xtx


class _BayesianDegradation(DegradationMixin, BaseEstimator):
    _name = "degradation"
    _fitted_attribute = "prior_mean_"

    def __init__(
        self,
        indicator: str = "hi",
        threshold: float | None = None,
        *,
        prior: dict | None = None,
        noise_var: float | None = None,
        direction: str = "increasing",
        level: float = 0.9,
        n_samples: int = 4000,
        horizon: float | None = None,
        max_rul: float | None = None,
        random_state: int = 0,
        unit: str = "unit",
        time: str | None = None,
        failed: str | None = None,
    ) -> None:
        keep_init_args(self, locals())

    # -------------------------------------------------------------- transforms
    def _signed(self, y):
        return self._sign * np.asarray(y, dtype=float)

    def _z(self, y):
        """Indicator -> the space in which the model is linear in time."""
        return self._signed(y)

    def _from_z(self, z):
        """Inverse of :meth:`_z`."""
        return self._sign * z

    def _check_settings(self) -> None:
        check_positive_int(self.n_samples, "n_samples", 100)

    def _choose_offset(self, units):  # exponential only
        return None

    # -------------------------------------------------------------- fitting
    def fit(self, table: pd.DataFrame, y: object = None) -> Self:
        """Estimate the prior, the noise variance and the threshold from training units.

        Parameters
        ----------
        table : pandas.DataFrame
            Long table of training units (``unit``, ``time``, the indicator). They need
            not have failed when ``threshold`` is given.

        Returns
        -------
        self

        Raises
        ------
        pdmkit.errors.DataError
            A constant indicator; fewer than 2 training units with 3 or more
            samples (without ``prior``); no ``threshold`` and censored units.

        Examples
        --------
        >>> import numpy as np, pandas as pd
        >>> from pdmkit.rul import LinearDegradationModel
        >>> t = np.arange(0.0, 50.0)
        >>> train = pd.DataFrame({"unit": np.repeat([1, 2, 3], 50), "time": np.tile(t, 3),
        ...                       "hi": np.r_[0.02 * t, 0.025 * t, 0.018 * t]})
        >>> model = LinearDegradationModel(threshold=1.0).fit(train)
        >>> model.prior_mean_.round(4).tolist()
        [0.0, 0.021]
        """
        units, values = self._start_fit(table)
        # threshold (given), offset (exponential), then the per-unit least squares
        if self.threshold is None:
            self._require_failed_for_threshold(
                units,
                "the mean value of the fitted training paths at the units' failure times",
            )
            self.threshold_ = None
        else:
            self.threshold_ = self._given_threshold()
        self.offset_ = self._choose_offset(units)
        rows, fits = self._unit_lines(units)
        if self.threshold_ is None:
            if not rows:
                raise DataError(
                    "no training unit has 3 or more samples to fit; pass threshold="
                )
            self._g = float(np.mean([r["end"] for r in rows]))
            self.threshold_ = float(self._from_z(self._g))
        else:
            self._g = float(self._z(np.array([self.threshold_]))[0])
        threshold = self.threshold_
        reached = [
            u for u in units if (self._signed(u.x[:, 0]) >= self._sign * threshold).any()
        ]
        if not reached and self.threshold is not None:
            self._warn_unreached(
                values, threshold, "RULs are extrapolations of the fitted paths"
            )
        self.unit_params_ = pd.DataFrame(rows)
        noise = self._noise_variance(fits)
        self.noise_var_ = noise
        mean, cov = self._prior_moments(fits, noise)
        self.prior_mean_ = mean
        self.prior_cov_ = cov
        self._prior_precision = np.linalg.inv(cov)
        return self._finish_fit(units)

    def _unit_lines(self, units: list[Unit]) -> tuple[list[dict], list[tuple]]:
        """Least-squares line of each unit with 3 or more samples over a time span.

        Returns the rows of ``unit_params_`` and ``(w, rss, X'X, n)`` per fitted unit.
        """
        rows, fits = [], []
        for u in units:
            if len(u) < 3 or np.ptp(u.t) == 0:
                continue
            w, rss, xtx = _ols(u.t, self._z(u.x[:, 0]))
            fits.append((w, rss, xtx, len(u)))
            rows.append(
                {
                    "unit": u.name,
                    "intercept": w[0],
                    "slope": w[1],
                    "rss": rss,
                    "n": len(u),
                    "end": float(w[0] + w[1] * u.t[-1]),
                }
            )
        return rows, fits

    def _noise_variance(self, fits: list[tuple]) -> float:
        """``noise_var`` if given, else the pooled residual variance of the unit lines."""
        if self.noise_var is not None:
            noise = float(self.noise_var)
            if not noise > 0:
                raise ValueError(f"noise_var must be positive, got {self.noise_var!r}")
            return noise
        dof = sum(n - 2 for *_, n in fits)
        if dof <= 0:
            raise DataError(
                "no training unit has 3 or more samples; the noise variance cannot be "
                "estimated - pass noise_var= (and prior=)"
            )
        noise = sum(f[1] for f in fits) / dof
        if not noise > 0:
            raise DataError(
                f"indicator {self.indicator!r} follows a straight line exactly in "
                "every training unit (zero noise); pass noise_var= to set the "
                "measurement noise"
            )
        return noise

    def _prior_moments(self, fits: list[tuple], noise: float):
        """Prior ``(mean, cov)`` of ``(a, b)``: given, or from the spread of unit lines.

        The sample covariance of the lines less the part their noise explains.
        """
        if self.prior is not None:
            return self._check_prior(self.prior)
        if len(fits) < 2:
            raise DataError(
                f"{len(fits)} training unit(s) with 3 or more samples; estimating the "
                "prior needs at least 2 - pass prior={'mean': [a, b], 'cov': [[...]]}"
            )
        W = np.array([f[0] for f in fits])
        mean = W.mean(axis=0)
        sample = np.cov(W.T, ddof=1)
        explained = noise * np.mean([np.linalg.inv(f[2]) for f in fits], axis=0)
        return mean, _clip_psd(sample - explained, sample)

    @staticmethod
    def _check_prior(prior):
        if not isinstance(prior, dict) or not {"mean", "cov"} <= set(prior):
            raise ValueError(
                "prior must be a dict {'mean': [a, b], 'cov': [[var_a, cov_ab], "
                f"[cov_ab, var_b]]}}, got {prior!r}"
            )
        mean = np.asarray(prior["mean"], dtype=float)
        cov = np.asarray(prior["cov"], dtype=float)
        if mean.shape != (2,) or cov.shape != (2, 2):
            raise ValueError(
                f"prior mean must have 2 values and cov be 2 x 2; got {mean.shape}, "
                f"{cov.shape}"
            )
        if not np.allclose(cov, cov.T) or np.linalg.eigvalsh(cov).min() <= 0:
            raise ValueError("prior cov must be symmetric positive definite")
        return mean, cov

    # -------------------------------------------------------------- posterior
    def _stats(self, u: Unit):
        X = _design(u.t)
        z = self._z(u.x[:, 0])
        return X.T @ X / self.noise_var_, X.T @ z / self.noise_var_

    def _posterior_from(self, precision, vector):
        cov = np.linalg.inv(precision)
        return cov @ vector, cov

    def _unit_posterior(self, u: Unit):
        """Posterior ``(mean, cov)`` of ``(a, b)`` from the prior and ``u``'s history."""
        a, b = self._stats(u)
        return self._posterior_from(
            self._prior_precision + a, self._prior_precision @ self.prior_mean_ + b
        )

    def posterior(self, table: pd.DataFrame) -> dict:
        """Posterior mean and covariance of ``(a, b)`` for each unit of ``table``.

        Returns
        -------
        dict
            unit -> ``(mean (2,), cov (2, 2))``.

        Examples
        --------
        >>> import numpy as np, pandas as pd
        >>> from pdmkit.rul import LinearDegradationModel
        >>> model = LinearDegradationModel(threshold=0.1, noise_var=0.01,
        ...     prior={"mean": [0.0, 0.02], "cov": [[0.01, 0.0], [0.0, 1e-4]]})
        >>> t = pd.DataFrame({"unit": 1, "time": [0.0, 1.0], "hi": [0.0, 0.1]})
        >>> mean, cov = model.fit(t).posterior(t)[1]
        >>> mean.round(4).tolist()  # [[300, 100], [100, 10100]]^-1 @ [10, 210]
        [0.0265, 0.0205]
        """
        check_fitted(self, "prior_mean_")
        return {u.name: self._unit_posterior(u) for u in self._split(table)}

    def update(self, table: pd.DataFrame) -> Self:
        """Fold new measurements into each unit's posterior (sequential Bayes).

        The posterior after several updates equals the one from all the data at once.
        :meth:`predict` without a table predicts from these posteriors.

        Parameters
        ----------
        table : pandas.DataFrame
            New rows (``unit``, ``time``, indicator); units not seen before start from
            the prior.

        Returns
        -------
        self

        Examples
        --------
        >>> import numpy as np, pandas as pd
        >>> from pdmkit.rul import LinearDegradationModel
        >>> t = np.arange(0.0, 50.0)
        >>> train = pd.DataFrame({"unit": np.repeat([1, 2, 3], 50), "time": np.tile(t, 3),
        ...                       "hi": np.r_[0.02 * t, 0.025 * t, 0.018 * t]
        ...                             + np.random.default_rng(0).normal(0, 0.01, 150)})
        >>> model = LinearDegradationModel(threshold=1.0).fit(train)
        >>> new = pd.DataFrame({"unit": 9, "time": [0.0, 10.0], "hi": [0.0, 0.2]})
        >>> model.update(new.iloc[:1]).update(new.iloc[1:])
        LinearDegradationModel(threshold=1.0)
        >>> model.predict().estimate.round(0).tolist()  # crosses 1.0 near t = 50
        [40.0]
        """
        check_fitted(self, "prior_mean_")
        for u in self._split(table):
            a, b = self._stats(u)
            if u.name in self.states_:
                p, v, last = self.states_[u.name]
                self._check_update_start(u, last)
            else:
                p, v = (
                    self._prior_precision.copy(),
                    self._prior_precision @ self.prior_mean_,
                )
            self.states_[u.name] = (p + a, v + b, float(u.t[-1]))
        return self

    # -------------------------------------------------------------- prediction
    def _rul_samples(self, mean, cov, t_now, rng_normals):
        chol = np.linalg.cholesky(cov + 1e-15 * np.eye(2) * np.trace(cov))
        w = mean + rng_normals @ chol.T
        a, b = w[:, 0], w[:, 1]
        now = a + b * t_now
        with np.errstate(divide="ignore", invalid="ignore"):
            cross = (self._g - a) / b
        rul = np.where(now >= self._g, 0.0, np.where(b > 0, cross - t_now, np.inf))
        rul = np.where(rul > self.horizon_, np.inf, rul)
        return rul

    def _summarise(self, names, times, posts):
        level = check_level(self.level)
        q = [(1 - level) / 2, 0.5, (1 + level) / 2]
        normals = np.random.default_rng(self.random_state).standard_normal(
            (self.n_samples, 2)
        )
        est, lo, hi, pf = [], [], [], []
        for (mean, cov), t_now in zip(posts, times, strict=True):
            rul = self._rul_samples(mean, cov, t_now, normals)
            finite = np.isfinite(rul)
            pf.append(float(finite.mean()))
            qs = np.quantile(np.where(finite, rul, _BIG), q)
            qs = np.where(qs > self.horizon_, np.inf, qs)
            lo.append(qs[0])
            est.append(qs[1])
            hi.append(qs[2])
        return self._prediction(
            names, times, est, lo, hi, level=level, extra={"p_fail": np.asarray(pf)}
        )

    def _predict_units(self, units):
        posts = [self._unit_posterior(u) for u in units]
        return self._summarise(
            [u.name for u in units], [float(u.t[-1]) for u in units], posts
        )

    def _predict_states(self):
        names = list(self.states_)
        posts = [self._posterior_from(p, v) for p, v, _ in self.states_.values()]
        times = [last for *_, last in self.states_.values()]
        return self._summarise(names, times, posts)

    def predict(self, table: pd.DataFrame | None = None) -> RULPrediction:
        """RUL of each unit at its last time, from its posterior.

        Parameters
        ----------
        table : pandas.DataFrame, optional
            Histories of the units (each is updated from the prior). Without a table,
            the posteriors accumulated by :meth:`update` are used.

        Returns
        -------
        RULPrediction
            Median and ``level`` interval of the time until the threshold is reached;
            extra column ``p_fail``: probability that it is reached within
            ``horizon_``.

        Examples
        --------
        >>> import numpy as np, pandas as pd
        >>> from pdmkit.rul import LinearDegradationModel
        >>> t = np.arange(0.0, 50.0)
        >>> train = pd.DataFrame({"unit": np.repeat([1, 2, 3], 50), "time": np.tile(t, 3),
        ...                       "hi": np.r_[0.02 * t, 0.025 * t, 0.018 * t]
        ...                             + np.random.default_rng(0).normal(0, 0.01, 150)})
        >>> model = LinearDegradationModel(threshold=1.0).fit(train)
        >>> test = pd.DataFrame({"unit": 7, "time": t[:20], "hi": 0.025 * t[:20]})
        >>> p = model.predict(test)
        >>> float(p.estimate[0].round(0))  # 0.025 t reaches 1 at t = 40, 21 after t = 19
        21.0
        """
        return self._predict_table_or_states(table)


def _clip_psd(matrix: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Symmetric positive definite version of ``matrix`` (eigenvalues floored).

    The floor is 1e-3 in the correlation scale of ``reference`` (the sample covariance).
    """
    d = np.sqrt(np.clip(np.diag(reference), 1e-300, None))
    scaled = matrix / np.outer(d, d)
    scaled = (scaled + scaled.T) / 2
    vals, vecs = np.linalg.eigh(scaled)
    vals = np.maximum(vals, 1e-3)
    return (vecs * vals) @ vecs.T * np.outer(d, d)


class LinearDegradationModel(_BayesianDegradation):
    """Linear degradation ``h(t) = a + b t + noise`` with a Gaussian prior on ``(a, b)``.

    See the module notes: the prior and the noise variance are learned from the
    training units, each unit's history updates them in closed form, and the RUL is the
    time the posterior path takes to reach ``threshold``.

    Parameters
    ----------
    indicator : str, default "hi"
        Indicator column.
    threshold : float, optional
        Indicator value at failure; default the mean value the fitted training paths
        reach at the units' failure times (the units must then have run to failure;
        the fitted paths are less noisy than the last measurements).
    prior : dict, optional
        ``{"mean": [a, b], "cov": 2 x 2}`` instead of the one learned from the training
        units.
    noise_var : float, optional
        Measurement-noise variance instead of the pooled residual variance of the
        training fits.
    direction : {"increasing", "decreasing"}
        Whether the indicator grows or falls towards the threshold.
    level : float, default 0.9
        Confidence level of the intervals.
    n_samples : int, default 4000
        Posterior draws for the RUL distribution.
    horizon : float, optional
        Longest RUL considered; crossings later than this count as never (default 10
        times the longest training unit's life).
    max_rul : float, optional
        Cap applied to estimates and intervals (e.g. 125 cycles for C-MAPSS).
    random_state : int, default 0
        Seed of the posterior draws (the same draws for every unit).
    unit, time, failed : str
        Key columns.

    Attributes
    ----------
    prior_mean_ : numpy.ndarray of shape (2,)
    prior_cov_ : numpy.ndarray of shape (2, 2)
    noise_var_ : float
    threshold_ : float
    horizon_ : float
    unit_params_ : pandas.DataFrame
        Per training unit least-squares ``intercept, slope, rss, n`` and ``end`` (the
        fitted value at the unit's last time).
    states_ : dict
        Per-unit posterior state built by :meth:`update`.
    n_units_ : int

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from pdmkit.rul import LinearDegradationModel
    >>> rng = np.random.default_rng(1)
    >>> rows = []
    >>> for u in range(20):
    ...     slope = rng.normal(0.02, 0.003)
    ...     t = np.arange(0.0, 1.0 / slope)
    ...     rows.append(pd.DataFrame({"unit": u, "time": t,
    ...                               "hi": slope * t + rng.normal(0, 0.02, t.size)}))
    >>> train = pd.concat(rows, ignore_index=True)
    >>> model = LinearDegradationModel(threshold=1.0).fit(train)
    >>> t = np.arange(0.0, 30.0)
    >>> test = pd.DataFrame({"unit": "new", "time": t, "hi": 0.025 * t})
    >>> p = model.predict(test)          # true RUL: 1 / 0.025 - 29 = 11
    >>> bool(p.lower[0] < 11 < p.upper[0])
    True
    """

    _name = "linear degradation"


class ExponentialDegradationModel(_BayesianDegradation):
    """Exponential degradation ``h(t) = phi + exp(a + b t + noise)``.

    The linear model of the module notes on ``log(h - phi)``; ``phi`` (``offset``) is
    fixed, by default chosen from a grid by the profile likelihood of the training
    units. Indicator values at or below ``phi`` are raised to ``phi + 1e-3 * range``
    before the logarithm.

    Parameters
    ----------
    indicator, threshold, prior, noise_var, direction, level, n_samples, horizon, \
max_rul, random_state, unit, time, failed
        As for :class:`LinearDegradationModel` (``prior`` and ``noise_var`` refer to the
        log scale).
    offset : float, optional
        The offset ``phi`` (in the indicator's scale, after the sign flip of
        ``direction="decreasing"``).

    Attributes
    ----------
    offset_ : float
        The offset used.
    prior_mean_, prior_cov_, noise_var_, threshold_, horizon_, unit_params_, states_, \
n_units_
        As for :class:`LinearDegradationModel` (log scale).

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from pdmkit.rul import ExponentialDegradationModel
    >>> rng = np.random.default_rng(2)
    >>> rows = []
    >>> for u in range(20):
    ...     b = rng.normal(0.05, 0.005)
    ...     t = np.arange(0.0, np.log(10 / 0.1) / b)   # from 0.1 up to 10
    ...     rows.append(pd.DataFrame({"unit": u, "time": t,
    ...         "hi": 0.1 * np.exp(b * t + rng.normal(0, 0.05, t.size))}))
    >>> train = pd.concat(rows, ignore_index=True)
    >>> model = ExponentialDegradationModel(threshold=10.0, offset=0.0).fit(train)
    >>> model.prior_mean_.round(2).tolist()   # log(0.1), 0.05
    [-2.3, 0.05]
    """

    _name = "exponential degradation"

    def __init__(
        self,
        indicator: str = "hi",
        threshold: float | None = None,
        *,
        offset: float | None = None,
        prior: dict | None = None,
        noise_var: float | None = None,
        direction: str = "increasing",
        level: float = 0.9,
        n_samples: int = 4000,
        horizon: float | None = None,
        max_rul: float | None = None,
        random_state: int = 0,
        unit: str = "unit",
        time: str | None = None,
        failed: str | None = None,
    ) -> None:
        keep_init_args(self, locals())

    def _z(self, y):
        s = self._signed(y) - self.offset_
        return np.log(np.maximum(s, self._floor))

    def _from_z(self, z):
        return self._sign * (np.exp(z) + self.offset_)

    def _choose_offset(self, units):
        values = np.concatenate([self._signed(u.x[:, 0]) for u in units])
        span = float(np.ptp(values))
        self._floor = 1e-3 * span
        g = np.inf if self.threshold_ is None else self._sign * self.threshold_
        if self.offset is not None:
            offset = float(self.offset)
            if not np.isfinite(offset) or offset >= g:
                raise ValueError(
                    f"offset={self.offset!r} must be finite and below the threshold "
                    f"({g:g} after the direction's sign)"
                )
            return offset
        low = values.min()
        best, best_ll = None, -np.inf
        for delta in np.geomspace(1e-3 * span, 20 * span, 80):
            phi = low - delta
            z_units = [np.log(self._signed(u.x[:, 0]) - phi) for u in units]
            rss, dof, jac = 0.0, 0, 0.0
            for u, z in zip(units, z_units, strict=True):
                jac += z.sum()
                if len(u) < 3 or np.ptp(u.t) == 0:
                    continue
                _, r, _ = _ols(u.t, z)
                rss += r
                dof += len(u) - 2
            if dof <= 0 or rss <= 0:
                continue
            n = sum(len(u) for u in units)
            ll = -0.5 * n * np.log(rss / dof) - jac
            if ll > best_ll:
                best, best_ll = phi, ll
        if best is None:
            raise DataError(
                "cannot choose the exponential model's offset: no training unit has 3 or "
                "more samples; pass offset="
            )
        return float(best)
