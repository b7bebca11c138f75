"""The RUL workflow: train a remaining-useful-life model, score it, write JSON and a report.

``run_rul(dataset="cmapss-fd001", model=...)`` trains on the run-to-failure training
units and predicts each test unit's RUL at its last observed cycle:

- ``"similarity"`` (alias ``"residual"``): a health indicator fused from the sensors
  (:class:`pdmkit.rul.HealthIndicator`, linear map to the fraction of life used), then
  :class:`pdmkit.rul.ResidualSimilarityModel` (cubic per-unit models, 10 nearest
  units); ``"pairwise"`` and ``"hash"`` swap in the other similarity models;
- ``"degradation"`` (alias ``"exponential-degradation"``): the indicator smoothed
  (``ewm`` span 10), :class:`pdmkit.rul.ExponentialDegradationModel` with the mean final
  indicator of the training units as threshold; ``"linear-degradation"`` likewise;
- ``"survival"`` (alias ``"reliability"``): a Weibull lifetime distribution,
  conditional on the age reached; ``"covariate"``: a Weibull proportional-hazards model
  on the smoothed indicator;
- ``"neural"``: :class:`pdmkit.rul.NeuralRULModel` (LSTM over 40-cycle windows of the
  standardised sensors and the cycle count; shorter histories padded with their first
  row; three networks, one per fold of training units).

Every model's predictions are capped at ``rul_cap`` (125 cycles) and scored against the
true RULs capped the same way, as the C-MAPSS literature does (the uncapped scores are
reported too).
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pdmkit._atomic import atomic_path
from pdmkit.errors import DataError

__all__ = ["RUL_MODELS", "make_rul_model", "run_rul"]

RUL_MODELS = {
    "similarity": "residual similarity on a fused health indicator",
    "residual": "residual similarity on a fused health indicator",
    "pairwise": "pairwise (Euclidean) similarity on a fused health indicator",
    "hash": "hash similarity on a fused health indicator",
    "degradation": "exponential degradation model with Bayesian updating",
    "exponential-degradation": "exponential degradation model with Bayesian updating",
    "linear-degradation": "linear degradation model with Bayesian updating",
    "survival": "Weibull reliability model, conditional on the age reached",
    "reliability": "Weibull reliability model, conditional on the age reached",
    "covariate": "Weibull proportional hazards on the health indicator",
    "neural": "LSTM over 40-cycle windows of the standardised sensors",
}
_CMAPSS_SENSORS = [f"sensor_{i}" for i in range(1, 22)]


def _dataset(dataset, features):
    """Return (name, train, test, true RUL per test unit, feature columns)."""
    if isinstance(dataset, str):
        key = dataset.lower().replace("_", "-")
        if key not in ("cmapss-fd001", "cmapss"):
            raise DataError(
                f"dataset {dataset!r} is not known to the RUL workflow; use "
                "'cmapss-fd001' or pass (train_table, test_table)"
            )
        from pdmkit.ensembles import load_cmapss

        train = load_cmapss("FD001", "train")
        test = load_cmapss("FD001", "test")
        name = "cmapss-fd001"
        default = _CMAPSS_SENSORS
    else:
        try:
            train, test = dataset
        except (TypeError, ValueError):
            raise DataError(
                "dataset must be a name ('cmapss-fd001') or a pair (train_table, "
                "test_table) of long tables"
            ) from None
        if not isinstance(train, pd.DataFrame) or not isinstance(test, pd.DataFrame):
            raise DataError("dataset tables must be pandas DataFrames")
        name = "tables"
        skip = {"unit", "time", "cycle", "rul", "rul_true_final", "failed"}
        default = [
            c
            for c in train.columns
            if c not in skip
            and not str(c).startswith("setting")
            and pd.api.types.is_numeric_dtype(train[c])
        ]
    for part, table in (("train", train), ("test", test)):
        if "unit" not in table.columns:
            raise DataError(f"the {part} table has no 'unit' column")
    if "rul_true_final" not in test.columns:
        raise DataError(
            "the test table needs a 'rul_true_final' column: each test unit's true RUL "
            "after its last row"
        )
    true = test.groupby("unit", sort=False)["rul_true_final"].first()
    cols = list(features) if features is not None else default
    return name, train, test, true, cols


def make_rul_model(
    model: str,
    features,
    *,
    seed: int = 0,
    rul_cap: float = 125.0,
    options: dict | None = None,
):
    """Build ``(indicator, estimator)`` for a workflow model name.

    Parameters
    ----------
    model : str
        One of :data:`RUL_MODELS`.
    features : sequence of str
        Sensor / indicator columns of the input tables.
    seed : int, default 0
        Seed of the estimators that draw random numbers.
    rul_cap : float, default 125
        Cap on the predictions.
    options : dict, optional
        Extra keyword arguments for the estimator (e.g. a small ``epochs`` for tests).

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
    from pdmkit import rul

    if model not in RUL_MODELS:
        raise DataError(f"model must be one of {sorted(RUL_MODELS)}, got {model!r}")
    opts = dict(options or {})
    features = list(features)
    if model == "neural":
        kw = {"window": 40, "pad": "edge", "max_rul": rul_cap, "random_state": seed, **opts}
        return None, rul.NeuralRULModel(features, **kw)
    if model in ("survival", "reliability"):
        return None, rul.ReliabilitySurvivalModel(max_rul=rul_cap, **opts)
    smooth = model in (
        "degradation",
        "exponential-degradation",
        "linear-degradation",
        "covariate",
    )
    indicator = rul.HealthIndicator(features, smoothing=10 if smooth else None)
    if model in ("similarity", "residual"):
        est = rul.ResidualSimilarityModel(
            **{"degree": 3, "k": 10, "max_rul": rul_cap, **opts}
        )
    elif model == "pairwise":
        est = rul.PairwiseSimilarityModel(**{"k": 10, "max_rul": rul_cap, **opts})
    elif model == "hash":
        est = rul.HashSimilarityModel(**{"k": 10, "max_rul": rul_cap, **opts})
    elif model in ("degradation", "exponential-degradation"):
        est = rul.ExponentialDegradationModel(
            **{"max_rul": rul_cap, "random_state": seed, **opts}
        )
    elif model == "linear-degradation":
        est = rul.LinearDegradationModel(
            **{"max_rul": rul_cap, "random_state": seed, **opts}
        )
    else:
        est = rul.CovariateSurvivalModel("hi", **{"max_rul": rul_cap, **opts})
    return indicator, est


def _write_json(data: dict, path: Path) -> Path:
    from pdmkit.experiments._report import _to_jsonable

    text = json.dumps(_to_jsonable(data), indent=2)
    with atomic_path(path) as tmp:
        Path(tmp).write_text(text + "\n")
    return path


def run_rul(
    dataset="cmapss-fd001",
    model: str = "similarity",
    out_dir: str | Path = "results/rul",
    json_path: str | Path | None = None,
    seed: int = 0,
    *,
    features=None,
    rul_cap: float = 125.0,
    options: dict | None = None,
    n_trajectories: int = 4,
) -> dict[str, Any]:
    """Train a RUL model, predict the test units, and write JSON and an HTML report.

    Parameters
    ----------
    dataset : str or (pandas.DataFrame, pandas.DataFrame)
        ``"cmapss-fd001"`` (NASA C-MAPSS FD001: 100 training engines run to failure,
        100 test engines stopped earlier, true RULs from ``RUL_FD001.txt``), or a pair
        of long tables ``(train, test)`` with ``unit``, ``time``/``cycle`` and the
        features, the test table holding ``rul_true_final``.
    model : str, default "similarity"
        One of :data:`RUL_MODELS` (``similarity``, ``degradation``, ``survival``,
        ``neural`` and the variants named in the module notes).
    out_dir : str or Path, default "results/rul"
        Folder for ``rul.json``, ``predictions.parquet`` and ``report.html``.
    json_path : str or Path, optional
        Also write the JSON summary here.
    seed : int, default 0
        Seed of the estimators that draw random numbers.
    features : sequence of str, optional
        Input columns (default: the 21 C-MAPSS sensors, or every numeric column of the
        tables but the keys, labels and ``setting*``).
    rul_cap : float, default 125
        Cap on predictions and on the true RULs in the headline scores.
    options : dict, optional
        Extra keyword arguments for the estimator.
    n_trajectories : int, default 4
        Test units shown as RUL-against-time plots.

    Returns
    -------
    dict
        ``model, dataset, rmse, mae, phm08_score, coverage, n_units`` (scored against
        the capped true RUL), the same uncapped (``*_uncapped``), ``bias``,
        ``mean_interval_width``, ``level``, ``rul_cap``, ``seed``, ``fit_seconds``,
        ``predict_seconds``, ``estimator``, ``features`` and ``paths``.

    Examples
    --------
    >>> import tempfile
    >>> import numpy as np, pandas as pd
    >>> from pdmkit.experiments._rul import run_rul
    >>> rng = np.random.default_rng(0)
    >>> def units(n, cut):
    ...     rows = []
    ...     for u in range(n):
    ...         life = int(rng.integers(80, 140)); t = np.arange(1, life + 1)
    ...         keep = t <= (life - rng.integers(5, 40) if cut else life)
    ...         rows.append(pd.DataFrame({"unit": u, "cycle": t[keep],
    ...             "s1": ((t / life) ** 2 + rng.normal(0, 0.03, life))[keep],
    ...             "rul_true_final": life - t[keep][-1]}))
    ...     return pd.concat(rows, ignore_index=True)
    >>> out = run_rul((units(20, False), units(6, True)), "similarity",
    ...               tempfile.mkdtemp(), n_trajectories=1)
    >>> out["n_units"], out["rmse"] < 15
    (6, True)
    """
    from pdmkit.experiments._report import Report
    from pdmkit.rul import rul_metrics

    out = Path(out_dir)
    name, train, test, true, cols = _dataset(dataset, features)
    indicator, estimator = make_rul_model(
        model, cols, seed=seed, rul_cap=rul_cap, options=options
    )
    start = time.perf_counter()
    if indicator is not None:
        train_in = indicator.fit_transform(train)
        test_in = indicator.transform(test)
    else:
        train_in, test_in = train, test
    estimator.fit(train_in)
    fit_seconds = time.perf_counter() - start
    start = time.perf_counter()
    pred = estimator.predict(test_in)
    predict_seconds = time.perf_counter() - start

    truth = true.reindex(pred.unit).to_numpy(dtype=float)
    capped = np.minimum(truth, rul_cap)
    headline = rul_metrics(capped, pred.estimate, pred.lower, pred.upper)
    raw = rul_metrics(truth, pred.estimate, pred.lower, pred.upper)
    summary: dict[str, Any] = {
        "model": model,
        "dataset": name,
        "rmse": headline["rmse"],
        "mae": headline["mae"],
        "phm08_score": headline["phm08_score"],
        "coverage": headline["coverage"],
        "n_units": headline["n"],
        "bias": headline["bias"],
        "mean_interval_width": headline["mean_width"],
        "rmse_uncapped": raw["rmse"],
        "mae_uncapped": raw["mae"],
        "phm08_score_uncapped": raw["phm08_score"],
        "coverage_uncapped": raw["coverage"],
        "level": pred.level,
        "rul_cap": rul_cap,
        "seed": seed,
        "n_train_units": int(train["unit"].nunique()),
        "fit_seconds": round(fit_seconds, 2),
        "predict_seconds": round(predict_seconds, 2),
        "estimator": repr(estimator),
        "features": list(indicator.selected_)
        if indicator is not None
        else list(getattr(estimator, "features_", cols)),
    }

    # ---------------------------------------------------------------- files
    out.mkdir(parents=True, exist_ok=True)
    table = pred.to_pandas()
    table["rul_true"] = truth
    table["rul_true_capped"] = capped
    if "nearest" in table.columns:
        table["nearest"] = table["nearest"].map(lambda v: ",".join(map(str, v)))
    with atomic_path(out / "predictions.parquet") as tmp:
        table.to_parquet(tmp)

    report = Report(f"pdmkit rul: {model} on {name}")
    report.add_text(
        f"Model: {RUL_MODELS[model]} ({summary['estimator']}). Trained on "
        f"{summary['n_train_units']} run-to-failure units; each of the "
        f"{summary['n_units']} test units is predicted at its last observed time. "
        f"Predictions and true RULs are capped at {rul_cap:g} for the headline scores; "
        f"intervals are {100 * pred.level:g} %. Seed {seed}; fit {fit_seconds:.1f} s."
    )
    scores = pd.DataFrame(
        {
            f"capped at {rul_cap:g}": [
                headline[k] for k in ("rmse", "mae", "phm08_score", "coverage", "bias")
            ],
            "uncapped": [
                raw[k] for k in ("rmse", "mae", "phm08_score", "coverage", "bias")
            ],
        },
        index=["RMSE", "MAE", "PHM08 score", "interval coverage", "bias (pred - true)"],
    )
    report.add_table(scores, caption="Scores on the test units")
    report.add_figure(
        pred.plot(true=capped),
        caption=f"Predicted against true RUL (capped at {rul_cap:g})",
    )
    # units with histories of different lengths: from the median to the longest
    lengths = test.groupby("unit").size().reindex(pred.unit).to_numpy()
    order = np.argsort(lengths, kind="stable")
    picks = np.unique(np.linspace(len(order) // 2, len(order) - 1, n_trajectories).round())
    shown = [pred.unit[order[int(i)]] for i in picks] if n_trajectories > 0 else []
    if shown:
        subset = test_in[test_in["unit"].isin(shown)]
        path = estimator.predict_trajectory(subset, every=5)
        end = {u: test.loc[test.unit == u, _time_col(test)].max() + true[u] for u in shown}
        path_true = np.minimum(
            [end[u] - t for u, t in zip(path.unit, path.time, strict=True)], rul_cap
        )
        report.add_figure(
            path.plot(true=path_true, units=shown),
            caption="RUL against time for test units with histories from the median "
            "length to the longest (true RUL dashed, capped)",
        )
    if indicator is not None:
        report.add_figure(
            _indicator_plot(train_in, estimator),
            caption="Health indicator of ten training units",
        )
    report.add_table(
        table.drop(columns=[c for c in ("nearest",) if c in table]),
        caption="Predictions per test unit",
    )
    report.add_json(summary, caption="Summary")
    summary["paths"] = {
        "json": str(out / "rul.json"),
        "report": str(out / "report.html"),
        "predictions": str(out / "predictions.parquet"),
    }
    report.write(out / "report.html")
    _write_json(summary, out / "rul.json")
    if json_path is not None:
        _write_json(summary, Path(json_path))
    return summary


def _time_col(table: pd.DataFrame) -> str:
    return "time" if "time" in table.columns else "cycle"


def _indicator_plot(table: pd.DataFrame, estimator):
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
    ax.set_xlabel(tcol)
    ax.set_ylabel("health indicator")
    return ax
