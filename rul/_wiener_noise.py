"""Wiener-process degradation seen through measurement noise.

The degradation level ``X(t)`` of a unit is a Brownian motion with a unit-specific
drift, as in :class:`~pdmkit.rul.WienerDegradationModel`, but the indicator is a noisy
reading of it (Ye, Wang, Tsui & Pecht 2013, "Degradation data analysis using Wiener
processes with measurement errors", Technometrics 55(4)):

``Y(t_i) = X(t_i) + e_i``, ``e_i ~ N(0, tau^2)`` independent,
``X(t + dt) - X(t) ~ N(mu dt, sigma^2 dt)``, ``mu ~ N(m0, v0)`` across units.

Without the noise term, every wiggle of a noisy indicator counts as diffusion: the
estimated ``sigma^2`` swells, the drift is read from the first and last (noisy) value
only, and the intervals are wide and centred on the last reading. With it:

- **Fitting** (per-unit drifts profiled out, restricted maximum likelihood): the
  increments of a unit, ``dY = mu dt + sigma dB + e_i - e_{i-1}``, are Gaussian with a
  tridiagonal covariance ``C = sigma^2 diag(dt) + tau^2 D D'`` (``D`` the differencing
  matrix); ``(sigma^2, tau^2)`` maximise the sum over training units of
  ``-1/2 [log|C| + log(dt' C^-1 dt) + r' C^-1 r]`` (``r`` the residual about the unit's
  generalised-least-squares drift ``dt' C^-1 dY / dt' C^-1 dt``), by L-BFGS-B on their
  logarithms with banded Cholesky factors. The drift prior: ``m0`` the mean of the
  units' GLS drifts, ``v0`` their variance less the mean of their GLS variances
  ``1 / dt' C^-1 dt`` (floored as in the Wiener model).
- **Updating**: a Kalman filter on the state ``(X, mu)`` with ``X`` diffuse before the
  first reading and ``mu ~ N(m0, v0)``; the filtered mean and covariance of the current
  level and the drift after the unit's last reading are its posterior (the filter is
  run for all units, or all cuts of :meth:`predict_trajectory`, at once).
- **RUL**: the first-passage time of ``X`` from its current level to the threshold.
  Given the level, the drift is normal (its conditional posterior) and the closed form
  of :func:`~pdmkit.rul._wiener.wiener_first_passage_cdf` applies; the uncertain level
  is integrated by Gauss-Hermite quadrature (20 nodes). Nodes already past the
  threshold count as failed (RUL 0).

``measurement_var=0`` gives the Wiener model's drift posterior with the first reading
as the known start (tested), so the plain model is the special case of no noise.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from scipy.linalg import cho_solve_banded, cholesky_banded
from scipy.optimize import minimize

from pdmkit.errors import DataError
from pdmkit.rul._base import check_fitted, keep_init_args
from pdmkit.rul._wiener import WienerDegradationModel, wiener_first_passage_cdf

if TYPE_CHECKING:
    from typing import Self

_HERMITE_NODES, _HERMITE_WEIGHTS = np.polynomial.hermite.hermgauss(20)


def _increment_covariance_bands(dt, sigma2, tau2):
    """Upper banded form of ``C = sigma2 diag(dt) + tau2 D D'`` (tridiagonal)."""
    bands = np.empty((2, dt.size))
    bands[1] = sigma2 * dt + 2.0 * tau2
    bands[0, 0] = 0.0
    bands[0, 1:] = -tau2
    return bands


def _gls_drift(dt, dy, sigma2, tau2):
    """``(drift, drift variance, restricted log likelihood)`` of one unit's increments."""
    chol = cholesky_banded(_increment_covariance_bands(dt, sigma2, tau2))
    c_dt = cho_solve_banded((chol, False), dt)
    c_dy = cho_solve_banded((chol, False), dy)
    info = float(dt @ c_dt)
    drift = float(dt @ c_dy) / info
    resid = dy - drift * dt
    quad = float(resid @ cho_solve_banded((chol, False), resid))
    logdet = 2.0 * float(np.sum(np.log(chol[1])))
    return drift, 1.0 / info, -0.5 * (logdet + np.log(info) + quad)


def _kalman_step(state, dt, y, sigma2, tau2):
    """One step of the filter on ``(level, drift)``: move by ``dt``, then read ``y``.

    ``state = (x, pxx, m, pmm, pxm)``: level mean and variance, drift mean and
    variance, their covariance (arrays over units).
    """
    x, pxx, m, pmm, pxm = state
    # predict: the level moves by drift * dt plus diffusion; the drift stays
    x_p = x + m * dt
    pxx_p = pxx + 2 * dt * pxm + dt**2 * pmm + sigma2 * dt
    pxm_p = pxm + dt * pmm
    # update with the reading y = level + noise
    s = pxx_p + tau2
    s = np.where(s > 0, s, 1.0)  # a padded step of a finished unit (dt 0, no noise)
    gx, gm = pxx_p / s, pxm_p / s
    innov = y - x_p
    return (
        x_p + gx * innov,
        pxx_p - gx * pxx_p,
        m + gm * innov,
        pmm - gm * pxm_p,
        pxm_p - gx * pxm_p,
    )


def _run_filter(state, dts, ys, lengths, sigma2, tau2):
    """Filter from ``state`` (after column 0) over the later columns of ``ys`` / ``dts``.

    Columns ``1 .. lengths - 1``; the arrays are ``(n_units, width)``, padded past each
    unit's length.
    """
    state = tuple(np.asarray(v, dtype=float) for v in state)
    for k in range(1, ys.shape[1]):
        live = k < lengths
        if not live.any():
            break
        dt = np.where(live, dts[:, k], 0.0)
        step = _kalman_step(state, dt, np.where(live, ys[:, k], 0.0), sigma2, tau2)
        state = tuple(
            np.where(live, new, old) for new, old in zip(step, state, strict=True)
        )
    x, pxx, m, pmm, pxm = state
    return x, np.maximum(pxx, 0.0), m, np.maximum(pmm, 0.0), pxm


class NoisyWienerDegradationModel(WienerDegradationModel):
    """Wiener-process degradation read through measurement noise (Kalman filter).

    See the module notes: a Brownian level with a unit-specific drift, observed with
    independent Gaussian noise of variance ``tau^2``; ``sigma^2`` and ``tau^2`` by
    restricted maximum likelihood on the training units' increments, the drift prior
    from their GLS drifts, each unit's level and drift by a Kalman filter, and the RUL
    as the first passage of the level, integrated over its uncertainty.

    Parameters
    ----------
    indicator, threshold, prior, diffusion_var, transform, direction, level, horizon, \
max_rul, unit, time, failed
        As for :class:`WienerDegradationModel`.
    measurement_var : "auto" or float, default "auto"
        ``tau^2`` (in the transformed indicator's units squared), or estimated with
        ``sigma^2`` from the training units. ``0`` is the plain Wiener model (with the
        first reading taken as exact).

    Attributes
    ----------
    measurement_var_ : float
        ``tau^2``.
    drift_mean_, drift_var_, diffusion_var_, threshold_, transform_, horizon_, \
n_units_
        As for :class:`WienerDegradationModel`.
    unit_params_ : pandas.DataFrame
        Per training unit: ``drift`` (GLS), ``drift_var``, ``elapsed``, ``n``, ``end``.
    states_ : dict
        Per-unit Kalman state built by :meth:`update`.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from pdmkit.rul import NoisyWienerDegradationModel, WienerDegradationModel
    >>> rng = np.random.default_rng(0)
    >>> rows = []
    >>> for u in range(40):              # drift ~0.02, sigma^2 1e-4, noise sd 0.05
    ...     x = np.r_[0, np.cumsum(rng.normal(rng.normal(0.02, 0.002), 0.01, 99))]
    ...     end = np.flatnonzero(x >= 1.0)[0] + 1 if (x >= 1.0).any() else 100
    ...     y = x[:end] + rng.normal(0, 0.05, end)
    ...     rows.append(pd.DataFrame({"unit": u, "time": np.arange(end), "hi": y}))
    >>> train = pd.concat(rows)
    >>> noisy = NoisyWienerDegradationModel(threshold=1.0).fit(train)
    >>> plain = WienerDegradationModel(threshold=1.0).fit(train)
    >>> round(noisy.measurement_var_ ** 0.5, 3), round(noisy.diffusion_var_ * 1e4, 2)
    (0.05, 0.88)
    >>> round(plain.diffusion_var_ * 1e4, 1)  # noise read as diffusion: ~1 + 2 * 25
    53.1
    """

    def __init__(
        self,
        indicator: str = "hi",
        threshold: float | None = None,
        *,
        prior: dict | None = None,
        diffusion_var: float | None = None,
        measurement_var: float | str = "auto",
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

    # -------------------------------------------------------------- fitting
    def _fit_process(self, units) -> None:
        units = [u for u in units if len(u) >= 2]
        paths = [(np.diff(u.t), np.diff(self._z(u))) for u in units]
        sigma2, tau2 = self._estimate_variances(paths)
        self.diffusion_var_, self.measurement_var_ = sigma2, tau2
        rows = []
        for u, (dt, dy) in zip(units, paths, strict=True):
            drift, var, _ = _gls_drift(dt, dy, sigma2, tau2)
            rows.append(
                {
                    "unit": u.name,
                    "drift": drift,
                    "drift_var": var,
                    "elapsed": float(u.t[-1] - u.t[0]),
                    "n": len(u),
                    "end": float(u.x[-1, 0]),
                }
            )
        self.unit_params_ = pd.DataFrame(
            rows, columns=["unit", "drift", "drift_var", "elapsed", "n", "end"]
        )
        self._set_drift_prior(self.unit_params_["drift_var"].to_numpy())

    def _estimate_variances(self, paths) -> tuple[float, float]:
        """``(sigma^2, tau^2)``: given, or restricted maximum likelihood."""
        given_s2, given_t2 = self._given_diffusion(), self.measurement_var
        if isinstance(given_t2, str):
            if given_t2 != "auto":
                raise ValueError(
                    f"measurement_var must be 'auto' or a number >= 0, got {given_t2!r}"
                )
            given_t2 = None
        elif given_t2 is not None:
            given_t2 = float(given_t2)
            if not (np.isfinite(given_t2) and given_t2 >= 0):
                raise ValueError(
                    f"measurement_var must be 'auto' or a number >= 0, got "
                    f"{self.measurement_var!r}"
                )
        if given_s2 is not None and given_t2 is not None:
            return given_s2, given_t2
        usable = [(dt, dy) for dt, dy in paths if dt.size >= 2]
        if not usable:
            raise DataError(
                "no training unit has 3 or more samples; the diffusion and the "
                "measurement noise cannot be estimated - pass diffusion_var= and "
                "measurement_var="
            )
        # starting point: the increments' variance split between the two sources
        dt_all = np.concatenate([dt for dt, _ in usable])
        resid = np.concatenate([dy - dt * dy.sum() / dt.sum() for dt, dy in usable])
        total = float(np.mean(resid**2))
        size = float(np.mean(np.concatenate([dy for _, dy in usable]) ** 2))
        if not total > 1e-20 * size:  # rounding error of an exact straight line
            raise DataError(
                f"indicator {self.indicator!r} grows at a constant rate in every "
                "training unit (no diffusion, no noise); pass diffusion_var= and "
                "measurement_var="
            )
        start_s2 = given_s2 if given_s2 is not None else 0.5 * total / dt_all.mean()
        start_t2 = given_t2 if given_t2 is not None else 0.25 * total
        free = [given_s2 is None, given_t2 is None]
        log_start = np.log([start_s2, start_t2])

        def unpack(theta):
            values = log_start.copy()
            values[free] = theta
            return np.exp(values)

        def negative_log_likelihood(theta):
            s2, t2 = unpack(theta)
            try:
                return -sum(_gls_drift(dt, dy, s2, t2)[2] for dt, dy in usable)
            except np.linalg.LinAlgError:
                return np.inf

        x0 = log_start[free]
        bounds = [(v - 30.0, v + 30.0) for v in x0]
        res = minimize(negative_log_likelihood, x0, method="L-BFGS-B", bounds=bounds)
        s2, t2 = unpack(res.x)
        if given_t2 is None and t2 < 1e-9 * total:  # no detectable noise
            t2 = 0.0
        return float(s2), float(t2)

    # -------------------------------------------------------------- posterior
    def _filter(self, units):
        """Kalman posterior of ``(level, drift)`` after each unit's last reading."""
        lengths = np.array([len(u) for u in units])
        width = int(lengths.max())
        ys = np.zeros((len(units), width))
        dts = np.zeros((len(units), width))
        for i, u in enumerate(units):
            ys[i, : len(u)] = self._z(u)
            dts[i, 1 : len(u)] = np.diff(u.t)
        n = len(units)
        # after the first reading: level ~ N(y0, tau^2) (flat prior), drift ~ prior
        first = (
            ys[:, 0],
            np.full(n, self.measurement_var_),
            np.full(n, self.drift_mean_),
            np.full(n, self.drift_var_),
            np.zeros(n),
        )
        return _run_filter(
            first, dts, ys, lengths, self.diffusion_var_, self.measurement_var_
        )

    def _posteriors(self, units) -> list[tuple[float, float]]:
        """Drift posteriors from the Kalman filter (:meth:`posterior` returns them)."""
        _, _, m, pmm, _ = self._filter(units)
        return [(float(a), float(b)) for a, b in zip(m, pmm, strict=True)]

    def update(self, table: pd.DataFrame) -> Self:
        """Fold new measurements into each unit's state (the Kalman filter, continued).

        Returns
        -------
        self

        Examples
        --------
        >>> import pandas as pd
        >>> from pdmkit.rul import NoisyWienerDegradationModel
        >>> model = NoisyWienerDegradationModel(threshold=3.0, diffusion_var=0.5,
        ...     measurement_var=0.1, prior={"mean": 1.0, "var": 0.25})
        >>> new = pd.DataFrame({"unit": 1, "time": [0.0, 1.0, 2.0], "hi": [0.0, 2.0, 3.0]})
        >>> model.fit(new)
        NoisyWienerDegradationModel(diffusion_var=0.5, measurement_var=0.1,
                                    prior={'mean': 1.0, 'var': 0.25}, threshold=3.0)
        >>> a = model.update(new.iloc[:2]).update(new.iloc[2:]).predict()
        >>> b = model.predict(new)
        >>> bool(abs(a.estimate[0] - b.estimate[0]) < 1e-9)
        True
        """
        check_fitted(self, "measurement_var_")
        for u in self._split(table):
            z = self._z(u)
            if u.name in self.states_:
                state = self.states_[u.name]
                self._check_update_start(u, state[0])
                # continue the filter from the stored state (column 0)
                times, values = np.r_[state[0], u.t], np.r_[0.0, z]
                x, pxx, m, pmm, pxm = _run_filter(
                    tuple(np.array([v]) for v in state[1:]),
                    np.diff(times, prepend=times[0])[None, :],
                    values[None, :],
                    np.array([values.size]),
                    self.diffusion_var_,
                    self.measurement_var_,
                )
            else:
                x, pxx, m, pmm, pxm = self._filter([u])
            self.states_[u.name] = (
                float(u.t[-1]),
                *(float(v[0]) for v in (x, pxx, m, pmm, pxm)),
            )
        return self

    # -------------------------------------------------------------- prediction
    def _summarise_states(self, names, t_now, x, pxx, m, pmm, pxm):
        x, pxx, m, pmm, pxm, t_now = (
            np.asarray(a, dtype=float) for a in (x, pxx, m, pmm, pxm, t_now)
        )
        # level nodes (Gauss-Hermite) and the drift given the level
        sd = np.sqrt(pxx)[:, None]
        nodes = x[:, None] + np.sqrt(2.0) * sd * _HERMITE_NODES[None, :]
        weights = _HERMITE_WEIGHTS / np.sqrt(np.pi)
        with np.errstate(divide="ignore", invalid="ignore"):
            slope = np.where(pxx > 0, pxm / pxx, 0.0)[:, None]
            cond_var = np.maximum(pmm - np.where(pxx > 0, pxm**2 / pxx, 0.0), 0.0)
        cond_mean = m[:, None] + slope * (nodes - x[:, None])
        dist = self._w - nodes
        failed = dist <= 0
        d = np.where(failed, 1.0, dist)
        s2 = self.diffusion_var_
        p_failed = (failed * weights).sum(axis=1)
        past = p_failed >= 0.5  # the level is more likely than not past the threshold

        def cdf(t):
            part = wiener_first_passage_cdf(t[:, None], d, cond_mean, cond_var[:, None], s2)
            return (np.where(failed, 1.0, part) * weights).sum(axis=1)

        extra = {
            "drift": self._sign * m,
            "drift_sd": np.sqrt(pmm),
            "level_sd": np.sqrt(pxx),
        }
        return self._first_passage_summary(names, t_now, past, cdf, extra)

    def _predict_units(self, units):
        post = self._filter(units)
        return self._summarise_states(
            [u.name for u in units], [u.t[-1] for u in units], *post
        )

    def _predict_states(self):
        names = list(self.states_)
        cols = list(zip(*self.states_.values(), strict=True))
        return self._summarise_states(names, *cols)
