"""The RUL models the workflows train, and the report parts every RUL workflow shares.

The models: their names, construction, calibration and saving; the report parts: trajectory
scores and plots.
"""

from __future__ import annotations

import hashlib
import inspect
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from pdmkit import rul
from pdmkit._persist import save_model
from pdmkit.errors import DataError, did_you_mean
from pdmkit.experiments._rul_checks import warn
from pdmkit.rul import (
    ConformalRUL,
    RULPipeline,
    alpha_lambda_accuracy,
    coverage_check,
    rul_metrics,
)

__all__ = ["RUL_MODELS", "leak_accuracy", "make_rul_model"]

RUL_MODELS = {
    "similarity": "residual similarity on a fused health indicator",
    "residual": "residual similarity on a fused health indicator",
    "pairwise": "pairwise (Euclidean) similarity on a fused health indicator",
    "hash": "hash similarity on a fused health indicator",
    "degradation": "exponential degradation model with Bayesian updating",
    "exponential-degradation": "exponential degradation model with Bayesian updating",
    "linear-degradation": "linear degradation model with Bayesian updating",
    "wiener": "Wiener-process degradation (drift updated per unit, first-passage RUL)",
    "wiener-noisy": "Wiener-process degradation read through measurement noise "
    "(Kalman filter on level and drift, first-passage RUL)",
    "gamma-process": "gamma-process degradation (rate updated per unit, first passage)",
    "survival": "Weibull reliability model, conditional on the age reached",
    "reliability": "Weibull reliability model, conditional on the age reached",
    "covariate": "Weibull proportional hazards on the health indicator",
    "boosting": "gradient-boosted trees on windowed sensor means and slopes, "
    "cross-conformal intervals",
    "neural": "multi-layer perceptron over 40-sample windows of the standardised sensors",
}


def make_rul_model(
    model: str,
    features: Sequence[str],
    *,
    seed: int = 0,
    rul_cap: float | None = None,
    options: dict | None = None,
    smoothing: float | None = 10,
) -> tuple[rul.HealthIndicator | None, Any]:
    """Build ``(indicator, estimator)`` for a workflow model name.

    Parameters
    ----------
    model : str
        One of :data:`RUL_MODELS`.
    features : sequence of str
        Sensor / indicator columns of the input tables.
    seed : int, default 0
        Seed of the estimators that draw random numbers.
    rul_cap : float, optional
        Cap on the predictions (and on the learned models' targets); default none.
    options : dict, optional
        Extra keyword arguments for the estimator (e.g. a small ``epochs`` for tests).
    smoothing : float or None, default 10
        ``ewm`` span of the health indicator of the degradation (but not the Wiener)
        and covariate models (None: unsmoothed, as for the clean air-leak indicator).

    Returns
    -------
    tuple
        A :class:`pdmkit.rul.HealthIndicator` (None for the models that read the
        sensors directly) and the RUL estimator.

    Examples
    --------
    >>> from pdmkit.experiments._rul import make_rul_model
    >>> hi, est = make_rul_model("similarity", ["s1", "s2"])
    >>> type(hi).__name__, type(est).__name__
    ('HealthIndicator', 'ResidualSimilarityModel')
    """
    if model not in RUL_MODELS:
        raise DataError(f"model must be one of {sorted(RUL_MODELS)}, got {model!r}")
    opts = dict(options or {})
    features = list(features)
    cap = {"max_rul": rul_cap}
    seeded = {**cap, "random_state": seed}
    # the Wiener models are deterministic (quantiles by bisection, no draws)
    table = {
        "similarity": (rul.ResidualSimilarityModel, {"degree": 3, "k": 10, **cap}),
        "residual": (rul.ResidualSimilarityModel, {"degree": 3, "k": 10, **cap}),
        "pairwise": (rul.PairwiseSimilarityModel, {"k": 10, **cap}),
        "hash": (rul.HashSimilarityModel, {"k": 10, **cap}),
        "degradation": (rul.ExponentialDegradationModel, seeded),
        "exponential-degradation": (rul.ExponentialDegradationModel, seeded),
        "linear-degradation": (rul.LinearDegradationModel, seeded),
        "wiener": (rul.WienerDegradationModel, {"transform": "auto", **cap}),
        "wiener-noisy": (rul.NoisyWienerDegradationModel, {"transform": "auto", **cap}),
        "gamma-process": (rul.GammaProcessDegradationModel, {"transform": "auto", **cap}),
        "survival": (rul.ReliabilitySurvivalModel, cap),
        "reliability": (rul.ReliabilitySurvivalModel, cap),
        "covariate": (rul.CovariateSurvivalModel, {"covariates": "hi", **cap}),
        "boosting": (rul.BoostingRULModel, {"features": features, **seeded}),
        "neural": (
            rul.NeuralRULModel,
            {
                "features": features,
                "arch": "mlp",
                "window": 40,
                "hidden": 128,
                "epochs": 30,
                "n_folds": 5,
                "pad": "edge",
                **seeded,
            },
        ),
    }
    cls, defaults = table[model]
    known = set(inspect.signature(cls.__init__).parameters) - {"self"}
    unknown = sorted(set(opts) - known)
    if unknown:
        raise DataError(
            f"option(s) {unknown} are not settings of {cls.__name__} (model "
            f"{model!r}){did_you_mean(unknown[0], known)}. Its settings: {sorted(known)}"
        )
    estimator = cls(**{**defaults, **opts})
    if model in ("neural", "boosting", "survival", "reliability"):  # sensors / ages
        return None, estimator
    # the Wiener models describe the raw increments (smoothing would correlate them;
    # the noisy one filters the noise itself); the others read a smoothed indicator
    smooth = model in (
        "degradation",
        "exponential-degradation",
        "linear-degradation",
        "gamma-process",
        "covariate",
    )
    indicator = rul.HealthIndicator(features, smoothing=smoothing if smooth else None)
    return indicator, estimator


def _fit_pipeline(
    model, features, train, *, seed, rul_cap, options, smoothing=10, calibrate=False
):
    """A fitted :class:`pdmkit.rul.RULPipeline` for a workflow model, and its fit time.

    ``calibrate`` wraps the estimator in :class:`pdmkit.rul.ConformalRUL`.
    """
    indicator, estimator = make_rul_model(
        model, features, seed=seed, rul_cap=rul_cap, options=options, smoothing=smoothing
    )
    if calibrate:
        estimator = ConformalRUL(estimator, random_state=seed)
    start = time.perf_counter()
    pipeline = RULPipeline(indicator, estimator).fit(train)
    return pipeline, time.perf_counter() - start


def _calibration(pipeline) -> dict:
    """The summary's ``calibrated`` entry (and the interval factors when calibrated)."""
    factors = getattr(pipeline.model, "upper_factor_", None)
    if factors is None:
        return {"calibrated": False}
    return {
        "calibrated": True,
        "interval_factors": {
            "lower": pipeline.model.lower_factor_,
            "upper": pipeline.model.upper_factor_,
        },
    }


def _save_pipeline(pipeline, sink, summary: dict) -> None:
    """Register the trained pipeline as ``model.pdmkit`` (see :func:`predict_rul`)."""
    import tempfile

    with tempfile.TemporaryDirectory() as folder:  # hashed now, written at the commit
        blob = save_model(pipeline, Path(folder) / "model.pdmkit").read_bytes()
    sink.add_file("model.pdmkit", lambda path: path.write_bytes(blob))
    summary["model_file"] = str(sink.path("model.pdmkit"))
    # kept apart from the file, this hash is what proves the file is this one
    # (pdmkit rul --trained MODEL --expect-sha256 HASH; docs/model_files.md)
    summary["model_sha256"] = hashlib.sha256(blob).hexdigest()


def _finish(report, summary: dict, sink) -> dict:
    """Register the report and the JSON summary (with its ``paths``); return the summary."""
    report.add_json(summary, caption="Summary")
    summary["paths"] = {
        "json": str(sink.path("summary.json")),
        "report": str(sink.path("report.html")),
        "predictions": str(sink.path("predictions.parquet")),
    }
    sink.add_report("report.html", report)
    sink.add_json("summary.json", summary)
    return summary


def _trajectory_scores(path, life: pd.Series, rul_cap: float | None):
    """The scores of a trajectory prediction, over each unit's last half.

    The prediction is a RULPrediction or its table; returns (table of every prediction,
    headline metrics, per-unit accuracy, fractions).
    """
    table = path.to_pandas() if hasattr(path, "to_pandas") else path.copy()
    table["life"] = life.reindex(table["unit"]).to_numpy(dtype=float)
    table["rul_true"] = table["life"] - table["time"]
    table["last_half"] = (table["time"] >= table["life"] / 2) & (
        table["time"] < table["life"]
    )
    last = table[table["last_half"] & ~table["rul"].isna()]  # units with an estimate
    truth = np.minimum(last["rul_true"].to_numpy(), np.inf if rul_cap is None else rul_cap)
    metrics = rul_metrics(truth, last["rul"], last["lower"], last["upper"])
    acc = leak_accuracy(table["unit"], table["time"], table["rul"], life)
    fractions = {k: float(acc[k].mean()) for k in _READINGS}
    fractions["points_of_rul"] = float(
        np.mean(np.abs(last["rul"] - last["rul_true"]) <= 0.1 * last["rul_true"])
    )
    fractions["points_of_life"] = float(
        np.mean(np.abs(last["rul"] - last["rul_true"]) <= 0.1 * last["life"])
    )
    return table, metrics, acc, fractions


def coverage_warning(truth, lower, upper, level, found, *, n_units=None) -> dict:
    """Empirical coverage of the held-out intervals; warned when far below ``level``.

    The rule is :func:`pdmkit.rul.coverage_check`'s (more than 5 points short and a
    one-sided binomial test at 1 %); ``n_units`` counts the units behind trajectory
    predictions. Returns the check for the summary (without the message).
    """
    check = coverage_check(truth, lower, upper, level, n_units=n_units, warn=False)
    if check["far_below"]:
        warn(check["message"], found)
    return {k: v for k, v in check.items() if k != "message"}


def _trajectory_coverage(table: pd.DataFrame, rul_cap, level, found, n_units) -> dict:
    """:func:`coverage_warning` on the scored rows of :func:`_trajectory_scores`.

    The rows in the last half of each held-out unit's life with an estimate, against
    the (capped) true RUL; the binomial test counts ``n_units`` units.
    """
    last = table[table["last_half"] & ~table["rul"].isna()]
    if last.empty:
        return {}
    truth = np.minimum(last["rul_true"].to_numpy(), np.inf if rul_cap is None else rul_cap)
    return coverage_warning(
        truth, last["lower"], last["upper"], level, found, n_units=n_units
    )


def _trajectory_plot(table: pd.DataFrame, units, ax=None, *, time_unit: str = "cycles"):
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(7, 4))
    for i, u in enumerate(units):
        part = table[table["unit"] == u]
        color = f"C{i}"
        t, life = part["time"].to_numpy(), float(part["life"].iloc[0])
        ax.plot(t, part["rul"], color=color, label=f"unit {u} (life {life:g})")
        ax.plot(t, part["rul_true"], color=color, linestyle="--", linewidth=0.8)
        if {"lower", "upper"} <= set(part.columns):  # the model's own interval
            upper = np.minimum(part["upper"], 1.5 * life)  # an open end stays on the plot
            for edge in (part["lower"], upper):
                ax.plot(t, edge, color=color, linestyle=":", linewidth=0.8)
        half = part[part["last_half"]]
        ax.fill_between(
            half["time"],
            half["rul_true"] - 0.1 * life,
            half["rul_true"] + 0.1 * life,
            color=color,
            alpha=0.15,
        )
    ax.set_xlabel(f"time ({time_unit})")
    ax.set_ylabel(f"RUL ({time_unit})")
    ax.legend(fontsize="small")
    return ax


_READINGS = {
    "of_rul": "every prediction within 10 % of the true RUL",
    "of_life": "every prediction within 10 % of the unit's life",
    "mean_of_life": "mean absolute error within 10 % of the unit's life",
    "alpha_lambda": "prediction at half life within 10 % of the true RUL",
}


def leak_accuracy(
    unit: ArrayLike,
    time: ArrayLike,
    rul_pred: ArrayLike,
    life: Mapping | pd.Series,
    *,
    alpha: float = 0.1,
) -> pd.DataFrame:
    """Per-unit accuracy of RUL predictions over the last half of life.

    For each unit, the predictions made at times ``t`` with ``life / 2 <= t < life``
    (``life`` = the unit's failing cycle, time counted from the start of its life,
    true RUL ``life - t``, from about ``life / 2`` down to 1; the failing cycle itself,
    true RUL 0, is left out) are checked against four readings of "within
    ``alpha`` of the true RUL":

    - ``of_rul``: every prediction within ``alpha * true RUL`` (the strictest; near
      failure it asks for a fraction of a cycle);
    - ``of_life``: every prediction within ``alpha * life`` (the prognostic-horizon
      band of Saxena et al.: the horizon at ``alpha`` covers the last half of life);
    - ``mean_of_life``: the mean absolute error within ``alpha * life``;
    - ``alpha_lambda``: the prediction at half life within ``alpha * true RUL``
      (:func:`pdmkit.rul.alpha_lambda_accuracy` at ``lam=0.5``).

    A unit whose first prediction comes after half its life (a model with a window
    longer than the history), or with no prediction in its last half, fails all four.

    Parameters
    ----------
    unit, time, rul_pred : array_like
        One row per prediction.
    life : mapping or pandas.Series
        Unit -> failing cycle.
    alpha : float, default 0.1

    Returns
    -------
    pandas.DataFrame
        Indexed by unit: ``life``, ``n`` (predictions scored), ``mae``, the four
        readings (bool), and ``frac_of_rul`` / ``frac_of_life`` (fraction of the
        unit's predictions inside each band).

    Examples
    --------
    >>> from pdmkit.experiments._rul import leak_accuracy
    >>> t = [5, 6, 7, 8, 9]                        # life 10: true RUL 5, 4, 3, 2, 1
    >>> acc = leak_accuracy([1] * 5, t, [5.2, 4.1, 3.9, 2.0, 1.0], {1: 10})
    >>> acc.loc[1, ["of_rul", "of_life", "mean_of_life", "alpha_lambda"]].tolist()
    [False, True, True, True]
    """
    if not 0 < alpha:
        raise ValueError(f"alpha must be positive, got {alpha!r}")
    frame = pd.DataFrame(
        {
            "unit": np.asarray(unit),
            "time": np.asarray(time, dtype=float),
            "pred": np.asarray(rul_pred, dtype=float),
        }
    )
    lives = pd.Series(life)
    unknown = set(frame["unit"]) - set(lives.index)
    if unknown:
        raise DataError(f"no life given for unit(s) {sorted(unknown, key=str)[:5]}")
    frame["life"] = lives.reindex(frame["unit"]).to_numpy(dtype=float)
    frame["true"] = frame["life"] - frame["time"]
    rows = {}
    for name, part in frame.groupby("unit", sort=False):
        life_u = float(part["life"].iloc[0])
        part = part.sort_values("time")
        last = part[(part["time"] >= life_u / 2) & (part["time"] < life_u)]
        if last.empty:  # nothing predicted over the last half: not accurate there
            rows[name] = {"life": life_u, "n": 0, "mae": np.nan}
            rows[name].update({k: False for k in _READINGS})
            rows[name].update({"frac_of_rul": 0.0, "frac_of_life": 0.0})
            continue
        err = (last["pred"] - last["true"]).abs()
        in_rul = err <= alpha * last["true"]
        in_life = err <= alpha * life_u
        # a model that has not predicted yet at half life (a history shorter than its
        # window) is not accurate there
        complete = bool(part["time"].iloc[0] <= life_u / 2)
        ok_lam = complete and alpha_lambda_accuracy(
            part["time"], part["pred"], life_u, alpha=alpha, lam=0.5, t_start=0.0
        )
        rows[name] = {
            "life": life_u,
            "n": len(last),
            "mae": float(err.mean()),
            "of_rul": complete and bool(in_rul.all()),
            "of_life": complete and bool(in_life.all()),
            "mean_of_life": complete and bool(err.mean() <= alpha * life_u),
            "alpha_lambda": bool(ok_lam),
            "frac_of_rul": float(in_rul.mean()),
            "frac_of_life": float(in_life.mean()),
        }
    return pd.DataFrame.from_dict(rows, orient="index").rename_axis("unit")


def _time_col(table: pd.DataFrame) -> str:
    return "time" if "time" in table.columns else "cycle"


def _indicator_plot(table: pd.DataFrame, estimator, time_unit: str = ""):
    import matplotlib.pyplot as plt

    _, ax = plt.subplots(figsize=(7, 4))
    tcol = _time_col(table)
    for u in list(pd.unique(table["unit"]))[:10]:
        part = table[table["unit"] == u]
        ax.plot(part[tcol], part["hi"], linewidth=0.8)
    threshold = getattr(estimator, "threshold_", None)
    if threshold is not None:
        ax.axhline(threshold, color="k", linestyle="--", label="threshold")
        ax.legend()
    ax.set_xlabel(f"{tcol} ({time_unit})" if time_unit else tcol)
    ax.set_ylabel("health indicator")
    return ax


# --------------------------------------------------------------------------- air leak
