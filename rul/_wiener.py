"""Wiener-process degradation model: Brownian motion with a unit-specific drift.

The indicator ``X(t)`` of a unit is a Brownian motion with drift (Peng & Tseng 2009;
Si et al. 2013): its increments are independent,

``X(t + dt) - X(t) ~ N(mu dt, sigma^2 dt)``,

with a drift ``mu`` of its own, drawn across units from ``N(m0, v0)``, and a diffusion
variance ``sigma^2`` shared by all units. Unlike a regression line, the path's
deviations persist: the best guess of where a unit goes next starts from where it is
now, and its uncertainty grows with the time ahead.

Fitting (empirical Bayes): each training unit's drift is estimated by its total
increment over its elapsed time, ``(X_n - X_1) / (t_n - t_1)`` (the maximum-likelihood
estimate); ``sigma^2`` is the pooled variance of the standardised increments about them;
``m0`` is the mean of the per-unit drifts and ``v0`` their variance less the part their
estimation noise explains (``sigma^2 / (t_n - t_1)`` on average), floored at 1e-3 of the
sample variance. For a unit observed over ``T = t_n - t_1`` with total increment
``D = X_n - X_1``, the posterior of ``mu`` is normal (conjugate):

``precision = 1 / v0 + T / sigma^2``, ``mean = (m0 / v0 + D / sigma^2) / precision``.

The RUL is the first-passage time of the path from its current value ``x`` to the
threshold ``w`` (distance ``d = w - x``). For a known drift it is inverse Gaussian
(mean ``d / mu``, shape ``d^2 / sigma^2``); mixed over the normal posterior
``N(m, v)`` of the drift its distribution function has the closed form (Peng & Tseng
2009, eq. 12; Si et al. 2013)

``F(t) = Phi((m t - d) / s) + exp(2 m d / sigma^2 + 2 v d^2 / sigma^4)
Phi(-(2 v d t + sigma^2 (m t + d)) / (sigma^2 s))``, ``s = sqrt(sigma^2 t + v t^2)``.

The estimate is its median and the interval its quantiles, found by bisection; a drift
that may be negative leaves probability that the threshold is never reached: when
``F(horizon)`` is below a quantile, that quantile is ``inf`` (``p_fail`` =
``F(horizon)`` in the prediction's extra columns). A unit at or past the threshold has
RUL 0. The mean RUL is not reported: with a normal drift it is infinite.
"""

from __future__ import annotations

import warnings
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from scipy.special import log_ndtr, ndtr
from sklearn.base import BaseEstimator

from pdmkit.errors import DataError
from pdmkit.rul._base import DegradationMixin, Unit, check_fitted, keep_init_args

if TYPE_CHECKING:
    from typing import Self

    from numpy.typing import ArrayLike

    from pdmkit.rul._result import RULPrediction


def wiener_first_passage_cdf(
    t: ArrayLike,
    distance: ArrayLike,
    drift_mean: ArrayLike,
    drift_var: ArrayLike,
    diffusion_var: ArrayLike,
) -> np.ndarray:
    """Distribution function of the first-passage time of a Wiener process.

    ``X(t) = mu t + sigma B(t)`` starting at 0, threshold ``distance > 0``, drift
    ``mu ~ N(drift_mean, drift_var)`` (``drift_var = 0``: a known drift, the inverse
    Gaussian distribution when the drift is positive); the module notes give the
    formula. Broadcasts over all arguments.

    Parameters
    ----------
    t : array_like
        Times (> 0).
    distance : array_like
        Distance from the current value to the threshold (> 0).
    drift_mean, drift_var : array_like
        Mean and variance (>= 0) of the normal drift.
    diffusion_var : array_like
        ``sigma^2`` (> 0).

    Returns
    -------
    numpy.ndarray
        ``P(T <= t)``; below 1 as ``t -> inf`` when the drift may be negative.

    Examples
    --------
    >>> from scipy.stats import invgauss
    >>> from pdmkit.rul._wiener import wiener_first_passage_cdf
    >>> d, mu, s2 = 2.0, 0.5, 0.1      # inverse Gaussian: mean d / mu, shape d^2 / s2
    >>> f = wiener_first_passage_cdf(3.5, d, mu, 0.0, s2)
    >>> bool(abs(f - invgauss.cdf(3.5, s2 / (d * mu), scale=d**2 / s2)) < 1e-12)
    True
    """
    args = (t, distance, drift_mean, drift_var, diffusion_var)
    t, d, m, v, s2 = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in args))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        s = np.sqrt(s2 * t + v * t**2)
        first = ndtr((m * t - d) / s)
        expo = 2 * m * d / s2 + 2 * v * d**2 / s2**2
        arg = -(2 * v * d * t + s2 * (m * t + d)) / (s2 * s)
        second = np.exp(np.minimum(expo + log_ndtr(arg), 0.0))
        out = np.clip(first + second, 0.0, 1.0)
    return np.where(t > 0, out, 0.0)


def _quantiles(cdf, q, shape, horizon):
    """Quantile ``q`` of each row of a vectorised distribution function.

    By bisection in log t between ``horizon * exp(-60)`` and ``horizon``; ``inf`` where
    ``cdf(horizon) < q``. Returns the quantiles and ``cdf(horizon)``.
    """
    reach = cdf(np.full(shape, float(horizon)))
    lo = np.full(shape, np.log(horizon) - 60.0)
    hi = np.full(shape, np.log(horizon))
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        below = cdf(np.exp(mid)) < q
        lo = np.where(below, mid, lo)
        hi = np.where(below, hi, mid)
    return np.where(reach >= q, np.exp(0.5 * (lo + hi)), np.inf), reach


class WienerDegradationModel(DegradationMixin, BaseEstimator):
    """Wiener-process degradation: Brownian motion with a unit-specific drift.

    See the module notes: increments ``N(mu dt, sigma^2 dt)``, a normal prior on the
    drift ``mu`` learned across the training units, a conjugate update from the unit's
    own increments, and the RUL as the first-passage time to ``threshold`` (inverse
    Gaussian for a known drift, mixed over the drift's posterior).

    Parameters
    ----------
    indicator : str, default "hi"
        Indicator column.
    threshold : float, optional
        Indicator value at failure; default the mean of the training units' last
        (failing) values, so the units must then have run to failure.
    prior : dict, optional
        ``{"mean": m0, "var": v0}`` of the drift instead of the one learned from the
        training units.
    diffusion_var : float, optional
        ``sigma^2`` (per unit of time) instead of the pooled estimate.
    transform : None, "auto" or float, default None
        Model ``g(X)`` instead of ``X``, with the exponential (Manly) transform
        ``g(x) = span (exp(lam u) - 1) / lam``, ``u = (x - min) / span`` over the
        training range (``lam = 0``: no transform). For an indicator that bends with
        the degradation level (same for every unit) rather than with time. ``"auto"``
        picks ``lam`` on a grid (-3 to 3 by 0.1) by the Gaussian profile likelihood of
        the training units' increments (pooled variance about each unit's drift, with
        the transform's Jacobian), as :class:`ExponentialDegradationModel` picks its
        offset.
    direction : {"increasing", "decreasing"}
        Whether the indicator grows or falls towards the threshold.
    level : float, default 0.9
        Confidence level of the intervals.
    horizon : float, optional
        Longest RUL considered (default 10 times the longest training life).
    max_rul : float, optional
        Cap applied to estimates and intervals.
    unit, time, failed : str
        Key columns.

    Attributes
    ----------
    drift_mean_, drift_var_ : float
        Prior mean and variance of the drift (in the indicator's units per unit of
        time, after the sign of ``direction`` and the transform).
    transform_ : float
        ``lam`` of the transform (0: none).
    diffusion_var_ : float
        ``sigma^2``.
    threshold_ : float
    horizon_ : float
    unit_params_ : pandas.DataFrame
        Per training unit: ``drift`` (its own estimate), ``elapsed``, ``n`` and ``end``
        (the last value).
    states_ : dict
        Per-unit state built by :meth:`update`.
    n_units_ : int

    Notes
    -----
    A unit with a single sample has no increment yet: its drift posterior is the prior
    and its RUL is the prior first-passage time from its one value. Units with one
    sample are left out of the estimates of the prior; units with two samples give a
    drift but no degree of freedom for ``sigma^2``.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from pdmkit.rul import WienerDegradationModel
    >>> rng = np.random.default_rng(0)
    >>> rows = []
    >>> for u in range(30):                       # drifts around 0.02, sigma 0.02
    ...     mu, t = rng.normal(0.02, 0.003), np.arange(0.0, 80.0)
    ...     x = np.r_[0, np.cumsum(rng.normal(mu, 0.02, 79))]
    ...     life = np.flatnonzero(x >= 1.0)
    ...     end = life[0] + 1 if life.size else 80
    ...     rows.append(pd.DataFrame({"unit": u, "time": t[:end], "hi": x[:end]}))
    >>> model = WienerDegradationModel(threshold=1.0).fit(pd.concat(rows))
    >>> abs(model.drift_mean_ - 0.02) < 0.002, abs(model.diffusion_var_ - 4e-4) < 4e-5
    (True, True)
    >>> new = pd.DataFrame({"unit": "new", "time": [0.0, 20.0], "hi": [0.0, 0.5]})
    >>> p = model.predict(new)             # half way after 20: about 20 more to go
    >>> bool(15 < p.estimate[0] < 25 and p.lower[0] < 20 < p.upper[0])
    True
    """

    def __init__(
        self,
        indicator: str = "hi",
        threshold: float | None = None,
        *,
        prior: dict | None = None,
        diffusion_var: float | None = None,
        transform: float | str | None = None,
        direction: str = "increasing",
        level: float = 0.9,
        horizon: float | None = None,
        max_rul: float | None = None,
        unit: str = "unit",
        time: str | None = None,
        failed: str | None = None,
    ) -> None:
        keep_init_args(self, locals())

    def _z(self, u: Unit) -> np.ndarray:
        return self._g(self._sign * u.x[:, 0])

    def _g(self, y, lam=None):
        """The exponential (Manly) transform of the signed indicator."""
        lam = self.transform_ if lam is None else lam
        if lam == 0:
            return np.asarray(y, dtype=float)
        u = (np.asarray(y, dtype=float) - self._lo) / self._span
        return self._span * np.expm1(lam * u) / lam

    def _g_inverse(self, z):
        lam = self.transform_
        if lam == 0:
            return float(z)
        return float(self._lo + self._span * np.log1p(lam * z / self._span) / lam)

    def _choose_transform(self, units) -> float:
        """``transform_``: given, 0 (None), or the profile-likelihood choice."""
        if self.transform is None:
            return 0.0
        if isinstance(self.transform, str):
            if self.transform != "auto":
                raise ValueError(
                    f"transform must be None, 'auto' or a number, got {self.transform!r}"
                )
        else:
            lam = float(self.transform)
            if not np.isfinite(lam):
                raise ValueError(f"transform must be finite, got {self.transform!r}")
            return lam
        best, best_crit = 0.0, np.inf
        signed = [self._sign * u.x[:, 0] for u in units if len(u) >= 3]
        times = [u.t for u in units if len(u) >= 3]
        if not signed:
            return 0.0
        mean_u = float(
            np.mean(np.concatenate([(y - self._lo) / self._span for y in signed]))
        )
        for lam in np.linspace(-3.0, 3.0, 61):
            ss, dof = 0.0, 0
            for y, t in zip(signed, times, strict=True):
                z = self._g(y, lam)
                dt, dz = np.diff(t), np.diff(z)
                drift = (z[-1] - z[0]) / (t[-1] - t[0])
                ss += float(np.sum((dz - drift * dt) ** 2 / dt))
                dof += len(t) - 2
            if not (dof > 0 and ss > 0):
                continue
            crit = np.log(ss / dof) - 2.0 * lam * mean_u
            if crit < best_crit - 1e-12:
                best, best_crit = float(lam), crit
        return best

    # -------------------------------------------------------------- fitting
    def fit(self, table: pd.DataFrame, y: object = None) -> Self:
        """Estimate the drift prior, the diffusion and the threshold from training units.

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
            A constant indicator; fewer than 2 training units with 2 or more samples
            (without ``prior``); no unit with 3 or more samples (without
            ``diffusion_var``); a path without diffusion; no ``threshold`` and
            censored units.

        Examples
        --------
        >>> import numpy as np, pandas as pd
        >>> from pdmkit.rul import WienerDegradationModel
        >>> train = pd.DataFrame({"unit": np.repeat([1, 2], 4),
        ...                       "time": np.tile(np.arange(4.0), 2),
        ...                       "hi": [0, 1, 3, 4, 0, 2, 2, 5]})
        >>> model = WienerDegradationModel().fit(train)
        >>> model.unit_params_["drift"].tolist(), model.threshold_
        ([1.3333333333333333, 1.6666666666666667], 4.5)
        """
        units, values = self._start_fit(table)
        signed = self._sign * values
        self._lo, self._span = float(signed.min()), float(max(np.ptp(signed), 1e-300))
        self.transform_ = self._choose_transform(units)
        # threshold
        if self.threshold is None:
            self._require_failed_for_threshold(
                units, "the mean of the training units' last (failing) values"
            )
            self._w = float(np.mean([self._z(u)[-1] for u in units]))
            self.threshold_ = float(self._sign * self._g_inverse(self._w))
        else:
            threshold = self._given_threshold()
            self.threshold_ = threshold
            self._w = float(self._g(self._sign * threshold))
            if not any((self._z(u) >= self._w).any() for u in units):
                self._warn_unreached(values, threshold, "RULs extrapolate the fitted drift")
        self._fit_process(units)
        return self._finish_fit(units, positive_horizon=True)

    def _fit_process(self, units) -> None:
        """Per-unit drifts (:attr:`unit_params_`) and the process parameters."""
        rows, ss, dof = [], 0.0, 0
        for u in units:
            if len(u) < 2:
                continue
            z = self._z(u)
            elapsed = float(u.t[-1] - u.t[0])
            drift = float((z[-1] - z[0]) / elapsed)
            dt, dz = np.diff(u.t), np.diff(z)
            ss += float(np.sum((dz - drift * dt) ** 2 / dt))
            dof += len(u) - 2
            rows.append(
                {
                    "unit": u.name,
                    "drift": drift,
                    "elapsed": elapsed,
                    "n": len(u),
                    "end": float(u.x[-1, 0]),
                    "rss": float(np.sum((dz - drift * dt) ** 2 / dt)),
                }
            )
        self.unit_params_ = pd.DataFrame(
            rows, columns=["unit", "drift", "elapsed", "n", "end", "rss"]
        )
        self._estimate_process(ss, dof)

    def _estimate_process(self, ss: float, dof: int) -> None:
        """Pooled diffusion and the drift prior from :attr:`unit_params_`."""
        s2 = self._given_diffusion()
        if s2 is None:
            if dof <= 0:
                raise DataError(
                    "no training unit has 3 or more samples; the diffusion variance "
                    "cannot be estimated - pass diffusion_var= (and prior=)"
                )
            s2 = ss / dof
            if not s2 > 0:
                raise DataError(
                    f"indicator {self.indicator!r} grows at a constant rate in every "
                    "training unit (no diffusion); pass diffusion_var= to set it"
                )
        self.diffusion_var_ = s2
        self._set_drift_prior(s2 / self.unit_params_["elapsed"].to_numpy())

    def _given_diffusion(self) -> float | None:
        """``diffusion_var`` checked (None when it is to be estimated)."""
        if self.diffusion_var is None:
            return None
        s2 = float(self.diffusion_var)
        if not (np.isfinite(s2) and s2 > 0):
            raise ValueError(
                f"diffusion_var must be a positive number, got {self.diffusion_var!r}"
            )
        return s2

    def _set_drift_prior(self, estimation_var) -> None:
        """``drift_mean_``, ``drift_var_``: given, or from the training units' drifts.

        Otherwise the mean and the variance of the training units' drifts
        (:attr:`unit_params_`) less ``estimation_var``, the variance of each unit's drift
        estimate (floored at 1e-3 of the sample variance).
        """
        if self.prior is not None:
            m0, v0 = self._check_prior(self.prior)
        else:
            drifts = self.unit_params_["drift"].to_numpy()
            if len(drifts) < 2:
                raise DataError(
                    f"{len(drifts)} training unit(s) with 2 or more samples; estimating "
                    "the drift prior needs at least 2 - pass prior={'mean': m0, 'var': v0}"
                )
            m0 = float(drifts.mean())
            sample = float(drifts.var(ddof=1))
            explained = float(np.mean(estimation_var))
            v0 = max(
                sample - explained, 1e-3 * sample, 1e-12 * (m0**2 + self.diffusion_var_)
            )
        self.drift_mean_, self.drift_var_ = m0, v0
        self._warn_non_positive_drift(m0)

    def _warn_non_positive_drift(self, m0: float) -> None:
        if m0 <= 0:
            warnings.warn(
                f"the mean drift of {self.indicator!r} towards the threshold is {m0:g} "
                "(not positive): the training units do not move towards the threshold "
                "on average, so units short of it get RULs beyond the horizon (inf) "
                "and units past it RUL 0 - check direction= and threshold=",
                UserWarning,
                stacklevel=6,
            )

    @staticmethod
    def _check_prior(prior):
        if not isinstance(prior, dict) or not {"mean", "var"} <= set(prior):
            raise ValueError(
                "prior must be a dict {'mean': m0, 'var': v0} of the drift, got "
                f"{prior!r}"
            )
        m0, v0 = float(prior["mean"]), float(prior["var"])
        if not (np.isfinite(m0) and np.isfinite(v0) and v0 > 0):
            raise ValueError(
                f"prior mean must be finite and var positive, got {m0!r}, {v0!r}"
            )
        return m0, v0

    # -------------------------------------------------------------- posterior
    def _posterior(self, increment, elapsed):
        elapsed = np.asarray(elapsed, dtype=float)
        prec = 1.0 / self.drift_var_ + elapsed / self.diffusion_var_
        mean = (
            self.drift_mean_ / self.drift_var_
            + np.asarray(increment, dtype=float) / self.diffusion_var_
        ) / prec
        return mean, 1.0 / prec

    def posterior(self, table: pd.DataFrame) -> dict:
        """Posterior mean and variance of the drift for each unit of ``table``.

        Returns
        -------
        dict
            unit -> ``(mean, var)`` (after the sign of ``direction``).

        Examples
        --------
        >>> import pandas as pd
        >>> from pdmkit.rul import WienerDegradationModel
        >>> model = WienerDegradationModel(threshold=3.0, diffusion_var=0.5,
        ...                                prior={"mean": 1.0, "var": 0.25})
        >>> t = pd.DataFrame({"unit": 1, "time": [0.0, 2.0], "hi": [0.0, 3.0]})
        >>> model.fit(t).posterior(t)[1]    # precision 4 + 2/0.5 = 8, (4 + 3/0.5) / 8
        (1.25, 0.125)
        """
        check_fitted(self, "n_units_")
        units = self._split(table)
        return {
            u.name: post for u, post in zip(units, self._posteriors(units), strict=True)
        }

    def _posteriors(self, units) -> list[tuple[float, float]]:
        """The posterior of each unit's drift (rate for the gamma process)."""
        out = []
        for u in units:
            z = self._z(u)
            post = self._posterior(z[-1] - z[0], u.t[-1] - u.t[0])
            out.append(tuple(float(v) for v in post))
        return out

    def update(self, table: pd.DataFrame) -> Self:
        """Fold new measurements into each unit's state (sequential Bayes).

        The drift's sufficient statistics are the first and the latest value, so the
        state after several updates equals the one from all the data at once.
        :meth:`predict` without a table predicts from these states.

        Parameters
        ----------
        table : pandas.DataFrame
            New rows (``unit``, ``time``, indicator); units not seen before start from
            their first row.

        Returns
        -------
        self

        Examples
        --------
        >>> import pandas as pd
        >>> from pdmkit.rul import WienerDegradationModel
        >>> model = WienerDegradationModel(threshold=3.0, diffusion_var=0.5,
        ...                                prior={"mean": 1.0, "var": 0.25})
        >>> new = pd.DataFrame({"unit": 1, "time": [0.0, 1.0, 2.0], "hi": [0.0, 2.0, 3.0]})
        >>> model.fit(new).update(new.iloc[:2]).update(new.iloc[2:]).predict().time.tolist()
        [2.0]
        """
        check_fitted(self, "n_units_")
        for u in self._split(table):
            z = self._z(u)
            if u.name in self.states_:
                t0, z0, last, _ = self.states_[u.name]
                self._check_update_start(u, last)
            else:
                t0, z0 = float(u.t[0]), float(z[0])
            self.states_[u.name] = (t0, z0, float(u.t[-1]), float(z[-1]))
        return self

    # -------------------------------------------------------------- prediction
    def _summarise(self, names, t0, z0, t_now, z_now):
        t0, z0, t_now, z_now = (np.asarray(a, dtype=float) for a in (t0, z0, t_now, z_now))
        post = self._posterior(z_now - z0, t_now - t0)
        dist = self._w - z_now
        past = dist <= 0
        d = np.where(past, 1.0, dist)
        # a unit beyond the threshold from its first row never crossed it: the model
        # cannot time a crossing it did not see (not "RUL 0 (0 to 0)")
        unknown = past & (self._w - z0 <= 0)
        return self._first_passage_summary(
            names,
            t_now,
            past,
            lambda t: self._rul_cdf(t, d, post),
            self._extra(post),
            unknown=unknown,
        )

    def _first_passage_summary(self, names, t_now, past, cdf, extra, unknown=None):
        """Median and interval of each unit's RUL from its distribution function ``cdf``.

        ``cdf`` is vectorised over the units. RUL 0 where ``past``; where ``unknown``
        (beyond the threshold since the first row) no estimate (NaN) and the interval 0 to
        inf.
        """
        level = self._level
        out = []
        for q in ((1 - level) / 2, 0.5, (1 + level) / 2):
            value, reach = _quantiles(cdf, q, past.shape, self.horizon_)
            out.append(np.where(past, 0.0, value))
        lo, est, hi = out
        p_fail = np.where(past, 1.0, reach)
        note = np.full(past.shape, "", dtype=object)
        note[past] = "past the threshold"
        if unknown is not None and unknown.any():
            est = np.where(unknown, np.nan, est)
            hi = np.where(unknown, np.inf, hi)
            p_fail = np.where(unknown, np.nan, p_fail)
            note[unknown] = "indicator beyond the threshold since its first row"
        note[~past & ~np.isfinite(hi)] = "upper bound beyond the horizon"
        return self._prediction(
            names,
            t_now,
            est,
            lo,
            hi,
            level=level,
            extra={"p_fail": p_fail, **extra, "note": note},
        )

    def _rul_cdf(self, t, d, post):
        """P(RUL <= t) at distance ``d`` from the threshold, drift posterior ``post``."""
        mean, var = post
        return wiener_first_passage_cdf(t, d, mean, var, self.diffusion_var_)

    def _extra(self, post):
        mean, var = post
        return {"drift": self._sign * mean, "drift_sd": np.sqrt(var)}

    def _predict_units(self, units):
        z = [self._z(u) for u in units]
        return self._summarise(
            [u.name for u in units],
            [u.t[0] for u in units],
            [v[0] for v in z],
            [u.t[-1] for u in units],
            [v[-1] for v in z],
        )

    def predict(self, table: pd.DataFrame | None = None) -> RULPrediction:
        """RUL of each unit at its last time: the first-passage time to the threshold.

        Parameters
        ----------
        table : pandas.DataFrame, optional
            Histories of the units. Without a table, the states accumulated by
            :meth:`update` are used.

        Returns
        -------
        RULPrediction
            Median and ``level`` interval of the first-passage time; extra columns
            ``p_fail`` (probability of reaching the threshold within ``horizon_``),
            ``drift`` and ``drift_sd`` (the drift's posterior, in the indicator's sign).

        Examples
        --------
        >>> import pandas as pd
        >>> from scipy.stats import invgauss
        >>> from pdmkit.rul import WienerDegradationModel
        >>> model = WienerDegradationModel(threshold=10.0, diffusion_var=0.5,
        ...                                prior={"mean": 1.0, "var": 1e-12})
        >>> train = pd.DataFrame({"unit": 0, "time": [0.0, 10.0], "hi": [0.0, 10.0]})
        >>> t = pd.DataFrame({"unit": 1, "time": [0.0, 3.0], "hi": [0.0, 4.0]})
        >>> p = model.fit(train).predict(t)   # drift known: inverse Gaussian, d = 6
        >>> ig = invgauss(0.5 / (6 * 1.0), scale=6**2 / 0.5)  # mu = s2 / (d m), d^2 / s2
        >>> round(float(p.estimate[0]), 4), round(float(ig.median()), 4)
        (5.7615, 5.7615)
        """
        return self._predict_table_or_states(table)

    def _predict_states(self):
        names = list(self.states_)
        cols = list(zip(*self.states_.values(), strict=True))
        return self._summarise(names, *cols)
