"""The result of :func:`~pdmkit.models.pneumatic.estimate_parameters`.

:class:`EstimationResult` holds the estimates with their standard errors, confidence
intervals and correlation (from the Jacobian at the optimum, ``s^2 (J^T J)^-1``), the
starts of the search and the measured and fitted windows; :func:`_estimation_result`
builds it from the refined run.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from pdmkit.errors import ModelError
from pdmkit.models._optim import covariance
from pdmkit.models.pneumatic._estimate_problem import _Problem, _Run
from pdmkit.models.pneumatic._sensors import SENSOR_UNITS
from pdmkit.models.pneumatic._twin import PneumaticParams


# ---------------------------------------------------------------------------- result
@dataclasses.dataclass(eq=False, repr=False)
class EstimationResult:
    """Estimated parameters with their uncertainty, and the fitted windows.

    Attributes
    ----------
    params : PneumaticParams
        ``known`` with the free parameters replaced by their estimates.
    estimates, stderr : dict of str to float
        Estimate and standard error of each free parameter (inf: unidentifiable).
    ci95 : dict of str to tuple of float
        95 % confidence interval of each free parameter (in log space for positive
        parameters, so it stays positive and is asymmetric).
    correlation : pandas.DataFrame
        Correlation of the estimates (of their logarithms for positive parameters).
    converged : bool
        Whether the refinement ended within half a standard error of the optimum (its
        remaining Gauss-Newton step; a ConvergenceWarning said otherwise).
    cost : float
        Half the sum of squared weighted residuals at the estimate.
    cost_history : list of float
        The cost after each accepted step, coarse stage then fine stage (the fine stage
        restarts whenever the weights are re-estimated).
    starts : pandas.DataFrame
        Each start of the coarse stage: its first point, where it ended and the cost.
    sigma : dict of str to float
        Residual scale of each signal used as its weight (its unit).
    rmse : dict of str to float
        RMS residual of each signal at the estimate (its unit).
    windows : ndarray, shape (n_windows, 2)
        Time (s) of the first and last fitted sample of each window.
    time : ndarray, shape (n_windows, n_samples)
        Times of the fitted samples.
    measured, fitted : dict of str to ndarray, shape (n_windows, n_samples)
        Measured and fitted readings of each signal at those times.
    known, bounds, units : dict
        Per free parameter: the value in ``known`` (the first start), the bounds and
        the unit.
    n_iter : int
        Iterations of the refinement.
    offset : float
        Squared length of the last Gauss-Newton step in standard errors.
    jacobian : ndarray, shape (n_residuals, n_free)
        Jacobian of the weighted residuals in the optimised (log) coordinates.
    elapsed : float
        Wall time of the fit in s.

    Examples
    --------
    >>> from pdmkit.models import EstimationResult
    >>> r = EstimationResult(estimates={"c_a_in": 5e-6}, stderr={"c_a_in": 1e-8})
    >>> r.estimates["c_a_in"], r.converged
    (5e-06, False)
    """

    params: Any = None
    estimates: dict = dataclasses.field(default_factory=dict)
    stderr: dict = dataclasses.field(default_factory=dict)
    ci95: dict = dataclasses.field(default_factory=dict)
    correlation: Any = None
    converged: bool = False
    cost: float = math.nan
    cost_history: list = dataclasses.field(default_factory=list)
    starts: Any = None
    sigma: dict = dataclasses.field(default_factory=dict)
    rmse: dict = dataclasses.field(default_factory=dict)
    windows: Any = None
    time: Any = None
    measured: dict = dataclasses.field(default_factory=dict)
    fitted: dict = dataclasses.field(default_factory=dict)
    known: dict = dataclasses.field(default_factory=dict)
    bounds: dict = dataclasses.field(default_factory=dict)
    units: dict = dataclasses.field(default_factory=dict)
    n_iter: int = 0
    offset: float = math.nan
    jacobian: Any = None
    elapsed: float = math.nan

    def __repr__(self) -> str:
        parts = ", ".join(
            f"{k}={v:.4g} (+-{self.stderr.get(k, math.nan):.2g})"
            for k, v in self.estimates.items()
        )
        flag = "converged" if self.converged else "NOT converged"
        return f"<EstimationResult {flag}: {parts}>"

    def to_pandas(self):
        """One row per free parameter: estimate, stderr, CI, bounds, identifiability.

        Columns: ``estimate``, ``stderr``, ``ci95_low``, ``ci95_high``,
        ``rel_halfwidth`` (half the CI width over the estimate), ``known`` (the value in
        ``known``, the first start), ``lower``/``upper`` (bounds), ``at_bound``,
        ``identifiable`` (finite CI narrower than +-50 %) and ``unit``.

        Returns
        -------
        pandas.DataFrame

        Examples
        --------
        >>> from pdmkit.models import EstimationResult
        >>> r = EstimationResult(estimates={"c_a_in": 5e-6}, stderr={"c_a_in": 1e-8},
        ...     ci95={"c_a_in": (4.98e-6, 5.02e-6)}, known={"c_a_in": 5e-6},
        ...     bounds={"c_a_in": (5e-8, 5e-4)}, units={"c_a_in": "m^2"})
        >>> row = r.to_pandas().loc["c_a_in"]
        >>> float(row["rel_halfwidth"]), bool(row["identifiable"])
        (0.004, True)
        """
        import pandas as pd

        rows = []
        for k, est in self.estimates.items():
            lo, hi = self.ci95[k]
            lb, ub = self.bounds[k]
            half = 0.5 * (hi - lo) / abs(est) if est != 0 else math.inf
            rows.append(
                {
                    "parameter": k,
                    "estimate": est,
                    "stderr": self.stderr[k],
                    "ci95_low": lo,
                    "ci95_high": hi,
                    "rel_halfwidth": round(half, 12),
                    "known": self.known[k],
                    "lower": lb,
                    "upper": ub,
                    "at_bound": bool(
                        np.isclose(est, lb, rtol=1e-6) or np.isclose(est, ub, rtol=1e-6)
                    ),
                    "identifiable": bool(math.isfinite(half) and half < 0.5),
                    "unit": self.units[k],
                }
            )
        return pd.DataFrame(rows).set_index("parameter")

    def plot(self, ax=None, signals: Sequence[str] | None = None):
        """Measured against fitted readings over the windows (matplotlib imported here).

        Parameters
        ----------
        ax : matplotlib Axes or sequence of Axes, optional
            One axes per signal; None: a new figure with one row per signal.
        signals : sequence of str, optional
            Which fitted signals (default: all).

        Returns
        -------
        numpy.ndarray of Axes

        Examples
        --------
        >>> import numpy as np
        >>> from pdmkit.models import EstimationResult
        >>> t = np.arange(6.0).reshape(2, 3) / 1e3
        >>> r = EstimationResult(time=t, measured={"LeverPosition": t * 0.1},
        ...     fitted={"LeverPosition": t * 0.1}, units={})
        >>> r.plot().shape
        (1,)
        """
        import matplotlib.pyplot as plt

        signals = list(signals) if signals is not None else list(self.measured)
        for s in signals:
            if s not in self.measured:
                raise ModelError(
                    f"plot: {s!r} was not fitted; choose from {', '.join(self.measured)}."
                )
        if ax is None:
            _, axes = plt.subplots(
                len(signals), 1, sharex=True, squeeze=False, figsize=(8, 2 * len(signals))
            )
            axes = axes[:, 0]
        else:
            axes = np.atleast_1d(np.asarray(ax, dtype=object)).ravel()
            if axes.size != len(signals):
                raise ModelError(
                    f"plot: got {axes.size} axes for {len(signals)} signals; pass one "
                    "axes per signal or None."
                )
        gap = np.full((self.time.shape[0], 1), np.nan)
        t = np.concatenate([self.time, gap], axis=1).ravel()
        for a, s in zip(axes, signals, strict=True):
            m = np.concatenate([self.measured[s], gap], axis=1).ravel()
            f = np.concatenate([self.fitted[s], gap], axis=1).ravel()
            a.plot(t, m, ".", ms=2, color="0.5", label="measured")
            a.plot(t, f, lw=1.0, color="C3", label="fitted")
            unit = SENSOR_UNITS.get(s, "")
            a.set_ylabel(f"{s}\n[{unit}]" if unit else s)
        axes[0].legend(loc="best", fontsize="small")
        axes[-1].set_xlabel("time [s]")
        return axes


def _estimation_result(
    prob: _Problem,
    fine: _Run,
    runs: Sequence[_Run],
    Z0: np.ndarray,
    history: list,
    offset: float,
    converged: bool,
    t_start: float,
) -> EstimationResult:
    """The result at the refined run ``fine``; ``runs`` and ``Z0``: the search's starts."""
    import pandas as pd

    signals, names, W, length = prob.signals, prob.names, prob.n_windows, prob.length
    J, cost, meas = fine.J, fine.cost, prob.meas
    fitted_Y = (
        meas[..., 1:]
        + fine.r.reshape(len(signals), W, length - 1) * (prob.sigma[:, None, None])
    )
    cov, _ = covariance(J, cost)
    est, se, ci = _intervals(prob, prob.theta(fine.theta), cov)
    sd = np.sqrt(np.diag(cov))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd, sd)
    correlation = pd.DataFrame(corr, index=names, columns=names)
    t_win = (prob.k0[:, None] + np.arange(1, length)[None, :]) / prob.fs
    fitted = {s: fitted_Y[i] for i, s in enumerate(signals)}
    measured = {s: meas[i, :, 1:] for i, s in enumerate(signals)}
    rmse = {s: float(np.sqrt(np.mean((fitted[s] - measured[s]) ** 2))) for s in signals}
    fields = {f.name: f for f in dataclasses.fields(PneumaticParams)}
    return EstimationResult(
        params=prob.params_of(fine.theta),
        estimates=est,
        stderr=se,
        ci95=ci,
        correlation=correlation,
        converged=bool(converged),
        cost=cost,
        cost_history=history,
        starts=_starts_table(prob, runs, Z0),
        sigma={s: float(v) for s, v in zip(signals, prob.sigma, strict=True)},
        rmse=rmse,
        windows=np.stack([t_win[:, 0], t_win[:, -1]], axis=1),
        time=t_win,
        measured=measured,
        fitted=fitted,
        known={k: float(getattr(prob.known, k)) for k in names},
        bounds={
            k: (float(prob.th_lo[j]), float(prob.th_hi[j])) for j, k in enumerate(names)
        },
        units={k: fields[k].metadata["unit"] for k in names},
        n_iter=fine.n_iter,
        offset=offset,
        jacobian=J,
        elapsed=time.perf_counter() - t_start,
    )


def _intervals(prob: _Problem, theta: np.ndarray, cov: np.ndarray):
    """Estimates, standard errors and 95 % intervals (t quantile) per free parameter.

    Positive parameters, fitted as logarithms, get ``exp(z +- t se)``: positive and
    asymmetric; the others ``theta +- t se``.
    """
    from scipy import stats

    tq = float(stats.t.ppf(0.975, max(prob.n_res - prob.p, 1)))
    est, se, ci = {}, {}, {}
    for j, k in enumerate(prob.names):
        sz = math.sqrt(cov[j, j]) if np.isfinite(cov[j, j]) else math.inf
        v = float(theta[j])
        est[k] = v
        if prob.log[j]:
            se[k] = v * sz if math.isfinite(sz) else math.inf
            spread = math.exp(min(tq * sz, 700.0))  # inf-safe: an unidentifiable
            ci[k] = (v / spread, v * spread) if spread < 1e300 else (0.0, math.inf)
        else:
            se[k] = sz
            ci[k] = (v - tq * sz, v + tq * sz)
    return est, se, ci


def _starts_table(prob: _Problem, runs: Sequence[_Run], Z0: np.ndarray):
    """Each start of the search: where it began and ended, its cost and iterations."""
    import pandas as pd

    start_rows = []
    for i, run in enumerate(runs):
        row = {"start": i, "cost": run.cost, "iterations": run.n_iter}
        th0 = prob.theta(Z0[i])
        th1 = prob.theta(run.theta)
        for j, k in enumerate(prob.names):
            row[f"{k} (start)"] = float(th0[j])
            row[k] = float(th1[j])
        start_rows.append(row)
    return pd.DataFrame(start_rows).set_index("start")
