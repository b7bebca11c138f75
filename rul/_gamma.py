"""The gamma-process degradation model: monotone wear with independent gamma increments."""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.optimize import minimize
from scipy.special import betainc, gammaln

from pdmkit.errors import DataError
from pdmkit.rul._base import check_fitted, keep_init_args
from pdmkit.rul._wiener import WienerDegradationModel

__all__ = ["GammaProcessDegradationModel"]


def _gamma_marginal_nll(params, alpha_t, total):
    """Negative log marginal likelihood of each unit's total increment ``D`` over ``T``.

    With ``alpha_t = alpha T``, when ``D | beta ~ Gamma(alpha T, rate beta)`` and
    ``beta ~ Gamma(a, rate b)``; ``params = (log a, log b)``.
    """
    a, b = np.exp(params)
    ll = (
        gammaln(alpha_t + a)
        - gammaln(alpha_t)
        - gammaln(a)
        + a * np.log(b)
        + (alpha_t - 1) * np.log(total)
        - (alpha_t + a) * np.log(total + b)
    )
    return -float(np.sum(ll))


class GammaProcessDegradationModel(WienerDegradationModel):
    """Gamma-process degradation: monotone increments with a unit-specific rate.

    The indicator's increments are independent gamma variables,
    ``X(t + dt) - X(t) ~ Gamma(shape = alpha dt, rate = beta)``, with ``alpha`` (per
    unit of time) shared by all units and a rate ``beta`` of the unit's own, drawn
    from ``Gamma(a, rate b)`` across units (Lawless & Crowder 2004). The mean growth is
    ``alpha / beta`` per unit of time and every increment's coefficient of variation
    over ``dt`` is ``1 / sqrt(alpha dt)``: fast units are also the rough ones, which a
    Wiener model with one diffusion for all units does not know.

    Fitting: ``alpha`` by moments, pooled over the training units
    (``sum (n_i - 2) drift_i^2 / sum rss_i`` with each unit's drift and standardised
    residual sum of squares as in :class:`WienerDegradationModel`); ``(a, b)`` by
    maximising the marginal likelihood of the units' total increments (``D / (D + b)``
    is ``Beta(alpha T, a)``). The posterior of a unit's rate after a total increment
    ``D`` over ``T`` is ``Gamma(a + alpha T, b + D)`` (conjugate; a net decrease counts
    as ``D = 0``). The path is monotone, so the RUL is at most ``s`` exactly when the
    increment over ``s`` reaches the distance ``d`` to the threshold:

    ``P(RUL <= s) = I_{b' / (b' + d)}(a', alpha s)``

    (the regularised incomplete beta function; for a known rate, the gamma survival
    function ``P(Gamma(alpha s, beta) >= d)``). Median and interval by bisection.

    Parameters
    ----------
    indicator, threshold, transform, direction, level, horizon, max_rul, unit, time, \
failed
        As for :class:`WienerDegradationModel` (the transformed indicator must grow).
    prior : dict, optional
        ``{"shape": a, "rate": b}`` of the gamma prior of ``beta``.
    shape : float, optional
        ``alpha`` (per unit of time) instead of the moment estimate.

    Attributes
    ----------
    shape_ : float
        ``alpha``.
    rate_shape_, rate_rate_ : float
        ``a`` and ``b`` of the prior of ``beta``.
    threshold_, transform_, horizon_, unit_params_, states_, n_units_
        As for :class:`WienerDegradationModel`.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from pdmkit.rul import GammaProcessDegradationModel
    >>> rng = np.random.default_rng(0)
    >>> rows = []
    >>> for u in range(30):                     # alpha 4 per step, mean growth ~0.02
    ...     beta = rng.gamma(50.0, 1 / 0.25)
    ...     x = np.r_[0, np.cumsum(rng.gamma(4.0, 1 / beta, 150))]
    ...     end = np.flatnonzero(x >= 1.0)[0] + 1
    ...     rows.append(pd.DataFrame({"unit": u, "time": np.arange(end), "hi": x[:end]}))
    >>> model = GammaProcessDegradationModel(threshold=1.0).fit(pd.concat(rows))
    >>> bool(3.0 < model.shape_ < 5.0)
    True
    >>> new = pd.DataFrame({"unit": "new", "time": [0.0, 25.0], "hi": [0.0, 0.5]})
    >>> p = model.predict(new)               # half way after 25: about 25 more to go
    >>> bool(20 < p.estimate[0] < 30 and p.lower[0] < 25 < p.upper[0])
    True
    """

    def __init__(
        self,
        indicator: str = "hi",
        threshold: float | None = None,
        *,
        prior: dict | None = None,
        shape: float | None = None,
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

    def _estimate_process(self, ss: float, dof: int) -> None:
        rows = self.unit_params_
        if self.shape is not None:
            alpha = float(self.shape)
            if not (np.isfinite(alpha) and alpha > 0):
                raise ValueError(f"shape must be a positive number, got {self.shape!r}")
        else:
            use = rows[(rows["n"] >= 3) & (rows["drift"] > 0)]
            if use.empty:
                raise DataError(
                    "no training unit has 3 or more samples and a net increase; the "
                    "gamma shape cannot be estimated - pass shape= (and prior=)"
                )
            rss = float(use["rss"].sum())
            if not rss > 0:
                raise DataError(
                    f"indicator {self.indicator!r} grows at a constant rate in every "
                    "training unit (no randomness); pass shape= to set it"
                )
            alpha = float(np.sum((use["n"] - 2) * use["drift"] ** 2) / rss)
        self.shape_ = alpha
        if self.prior is not None:
            a, b = self._check_prior(self.prior)
        else:
            use = rows[rows["drift"] > 0]
            if len(use) < 2:
                raise DataError(
                    f"{len(use)} training unit(s) with 2 or more samples and a net "
                    "increase; estimating the rate prior needs at least 2 - pass "
                    "prior={'shape': a, 'rate': b}"
                )
            alpha_t = alpha * use["elapsed"].to_numpy()
            total = use["drift"].to_numpy() * use["elapsed"].to_numpy()
            beta = alpha_t / total
            mean = float(beta.mean())
            var = max(
                float(beta.var(ddof=1)) - float(np.mean(beta**2 / alpha_t)),
                1e-2 * mean**2,
            )
            start = np.log([mean**2 / var, mean / var])
            res = minimize(
                _gamma_marginal_nll,
                start,
                args=(alpha_t, total),
                method="L-BFGS-B",
                bounds=[(-10.0, 20.0), (start[1] - 30.0, start[1] + 30.0)],
            )
            a, b = (float(v) for v in np.exp(res.x if np.isfinite(res.fun) else start))
        self.rate_shape_, self.rate_rate_ = a, b

    @staticmethod
    def _check_prior(prior):
        if not isinstance(prior, dict) or not {"shape", "rate"} <= set(prior):
            raise ValueError(
                "prior must be a dict {'shape': a, 'rate': b} of the gamma prior of the "
                f"rate, got {prior!r}"
            )
        a, b = float(prior["shape"]), float(prior["rate"])
        if not (np.isfinite(a) and np.isfinite(b) and a > 0 and b > 0):
            raise ValueError(f"prior shape and rate must be positive, got {a!r}, {b!r}")
        return a, b

    def _posterior(self, increment, elapsed):
        a = self.rate_shape_ + self.shape_ * np.asarray(elapsed, dtype=float)
        b = self.rate_rate_ + np.maximum(np.asarray(increment, dtype=float), 0.0)
        return a, b

    def posterior(self, table: pd.DataFrame) -> dict:
        """Posterior shape and rate of each unit's gamma rate ``beta``.

        Returns
        -------
        dict
            unit -> ``(a', b')``: ``beta ~ Gamma(a', rate b')``.

        Examples
        --------
        >>> import pandas as pd
        >>> from pdmkit.rul import GammaProcessDegradationModel
        >>> model = GammaProcessDegradationModel(threshold=3.0, shape=2.0,
        ...                                      prior={"shape": 5.0, "rate": 4.0})
        >>> t = pd.DataFrame({"unit": 1, "time": [0.0, 2.0], "hi": [0.0, 3.0]})
        >>> model.fit(t).posterior(t)[1]     # (5 + 2 * 2, 4 + 3)
        (9.0, 7.0)
        """
        check_fitted(self, "shape_")
        return super().posterior(table)

    def _rul_cdf(self, t, d, post):
        a, b = post
        with np.errstate(invalid="ignore"):
            return np.where(t > 0, betainc(a, self.shape_ * t, b / (b + d)), 0.0)

    def _extra(self, post):
        a, b = post
        with np.errstate(divide="ignore", invalid="ignore"):
            mean = np.where(a > 1, self.shape_ * b / (a - 1), np.inf)
        return {"drift": self._sign * mean}
