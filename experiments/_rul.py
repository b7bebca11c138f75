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
  ``"wiener"``: :class:`pdmkit.rul.WienerDegradationModel` (Brownian motion with a
  unit-specific drift, first-passage RUL) on the same indicator; ``"wiener-noisy"``:
  :class:`pdmkit.rul.NoisyWienerDegradationModel` (the same read through measurement
  noise, Kalman filter); ``"gamma-process"``:
  :class:`pdmkit.rul.GammaProcessDegradationModel` (monotone gamma increments with a
  unit-specific rate); both with ``transform="auto"`` (an exponential transform of the
  indicator chosen by profile likelihood on the training units);
- ``"survival"`` (alias ``"reliability"``): a Weibull lifetime distribution,
  conditional on the age reached; ``"covariate"``: a Weibull proportional-hazards model
  on the smoothed indicator;
- ``"neural"``: :class:`pdmkit.rul.NeuralRULModel` (LSTM over 40-cycle windows of the
  standardised sensors and the cycle count; shorter histories padded with their first
  row; three networks, one per fold of training units).

Every model's predictions are capped at ``rul_cap`` (125 cycles) and scored against the
true RULs capped the same way, as the C-MAPSS literature does (the uncapped scores are
reported too).

``run_rul(dataset="nasa-battery", ...)`` runs the degradation models on the NASA Li-ion
cells, leave-one-cell-out (:mod:`pdmkit.experiments._rul_battery`).

``run_rul(dataset="pneumatic-leak", ...)`` runs the same models on air-leak
run-to-failure units of the pneumatic twin (:func:`simulate_leak_dataset`): the
candidate indicators of each 10 s cycle are ranked by monotonicity, trendability and
prognosability on the training units, the best one feeds the model (unsmoothed), and
every test unit is followed through its whole life with
:meth:`~pdmkit.rul.LinearDegradationModel.predict_trajectory`; the scores are over the
predictions in the last half of each test unit's life, with the fraction of test units
predicted within 10 % (see :func:`leak_accuracy`).
"""

from __future__ import annotations

import hashlib
import inspect
import json
import time
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pdmkit._atomic import atomic_path
from pdmkit._checks import check_magnitude
from pdmkit._outputs import (
    OutputRun,
    check_output_folder,
    collect_warnings,
    write_json_file,
)
from pdmkit.errors import DataError, did_you_mean

__all__ = [
    "LEAK_DEFAULTS",
    "LEAK_SIGNALS",
    "RUL_MODELS",
    "leak_accuracy",
    "leak_indicators",
    "make_rul_model",
    "predict_rul",
    "run_rul",
    "simulate_leak_dataset",
    "split_run_to_failure",
]

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
    "neural": "LSTM over 40-cycle windows of the standardised sensors",
}
_CMAPSS_SENSORS = [f"sensor_{i}" for i in range(1, 22)]
_LEAK_NAMES = ("pneumatic-leak", "leak", "pneumatic")
#: Twin signals whose indicators are candidates for the air-leak RUL workflow.
LEAK_SIGNALS = ("LeverPosition", "FlowExtrusion")
#: Settings of :func:`simulate_leak_dataset` used by ``run_rul("pneumatic-leak")``.
LEAK_DEFAULTS = {
    "n_train": 20,
    "n_test": 40,
    "max_cycles": 60,
    "t_end": 10.0,
    "walk_shape": 16.0,  # simulate_leak_runs' default; its notes say why
}
_LEAK_VERSION = 1  # bump when the simulation or the indicators change (cache key)
_LEAK_LABELS = ("unit", "cycle", "c_leak", "rul", "failed", "load_kg", "supply_bar")
_SEED_INDICATOR = "FlowExtrusion/stats/ShapeFactor"  # the seed's (section 8.4.2)
_READINGS = {
    "of_rul": "every prediction within 10 % of the true RUL",
    "of_life": "every prediction within 10 % of the unit's life",
    "mean_of_life": "mean absolute error within 10 % of the unit's life",
    "alpha_lambda": "prediction at half life within 10 % of the true RUL",
}


# --------------------------------------------------------------------------- air leak
def leak_indicators(ensemble, *, signals=None) -> pd.DataFrame:
    """Candidate prognostic indicators of air-leak runs, one row per cycle.

    For each signal: the time-domain statistics of each recording (group ``"stats"``
    of :func:`pdmkit.features.extract`, the seed's shape factor among them), and
    ``<signal>/deviation/LogRMS``, the base-10 logarithm of the RMS difference between
    the recording and the unit's first one (its as-new reference, same operating
    point). The first cycle of each unit is the reference and is left out of the
    table; a deviation of exactly 0 (a recording identical to the reference) takes the
    unit's smallest non-zero deviation.

    Parameters
    ----------
    ensemble : Ensemble
        Output of :func:`pdmkit.ensembles.simulate_leak_runs` (conditions ``unit``,
        ``cycle``, ``rul``, ``failed``), each unit's cycles in order.
    signals : sequence of str, optional
        Signals to use (default every signal of the ensemble).

    Returns
    -------
    pandas.DataFrame
        The conditions (``unit, cycle, c_leak, rul, failed, load_kg, supply_bar``) and
        the indicator columns ``<signal>/stats/<Name>`` and ``<signal>/deviation/LogRMS``.

    Examples
    --------
    >>> from pdmkit.ensembles import simulate_leak_runs
    >>> from pdmkit.experiments._rul import leak_indicators
    >>> runs = simulate_leak_runs(2, max_cycles=5, t_end=0.5, signals=["LeverPosition"])
    >>> table = leak_indicators(runs)
    >>> bool((table["cycle"] >= 1).all()), "LeverPosition/deviation/LogRMS" in table
    (True, True)
    """
    from pdmkit.features import extract

    cond = ensemble.conditions.reset_index(drop=True)
    missing = [c for c in ("unit", "cycle") if c not in cond]
    if missing:
        raise DataError(
            f"the ensemble has no condition column(s) {missing}; leak_indicators needs "
            "the output of simulate_leak_runs (unit and cycle per member)"
        )
    names = list(ensemble.signal_names if signals is None else signals)
    units = cond["unit"].to_numpy()
    order = np.lexsort((cond["cycle"].to_numpy(), units))
    if not np.array_equal(order, np.arange(len(cond))):
        raise DataError("the ensemble's members must be sorted by unit, then cycle")
    first = cond.groupby("unit", sort=False)["cycle"].transform("min").to_numpy()
    is_ref = cond["cycle"].to_numpy() == first
    ref_row = pd.Series(np.flatnonzero(is_ref), index=units[is_ref])
    ref_of = ref_row.reindex(units).to_numpy()
    parts = [cond[[c for c in _LEAK_LABELS if c in cond]]]
    for name in names:
        x, has = ensemble.stack(name)
        if not has.all():
            raise DataError(f"members {list(ensemble.member_ids[~has][:5])} lack {name!r}")
        fs = ensemble.fs[name]
        table = extract(x, fs=fs, groups=("stats",)).reset_index(drop=True)
        table.columns = [f"{name}/{c}" for c in table.columns]
        dev = np.sqrt(np.mean((x - x[ref_of]) ** 2, axis=1))
        dev = pd.Series(dev).where(~is_ref)
        floor = dev.where(dev > 0).groupby(units).transform("min")
        dev = dev.where((dev > 0) | is_ref, floor)
        table[f"{name}/deviation/LogRMS"] = np.log10(dev)
        parts.append(table)
    out = pd.concat(parts, axis=1)
    return out.loc[~is_ref].reset_index(drop=True)


def _leak_seed(seed: int, part: int) -> int:
    return int(np.random.SeedSequence([int(seed), part]).generate_state(1)[0])


def simulate_leak_dataset(
    n_train: int = 20,
    n_test: int = 40,
    *,
    max_cycles: int = 60,
    t_end: float = 10.0,
    walk_shape: float = 16.0,
    seed: int = 0,
    signals=LEAK_SIGNALS,
    cache_dir: str | Path | None = None,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Simulate training and test air-leak units of the twin and their indicators.

    Training and test units are drawn independently by
    :func:`pdmkit.ensembles.simulate_leak_runs` (seeds derived from ``seed``) and turned
    into per-cycle indicator tables by :func:`leak_indicators`; every unit runs to
    failure (``rul`` 0 and ``failed`` True at its last row).

    Parameters
    ----------
    n_train, n_test : int, default 20 and 40
        Units in each part.
    max_cycles, t_end, walk_shape
        As :func:`pdmkit.ensembles.simulate_leak_runs` (10 s recordings, lives of
        24-60 cycles plus the walk's spread, its default walk).
    seed : int, default 0
    signals : sequence of str, default :data:`LEAK_SIGNALS`
    cache_dir : str or Path, optional
        Keep the indicator tables in ``cache_dir/leak_<key>.parquet`` (the key hashes
        every argument) and read them from there next time; the raw recordings (tens of
        MB per unit) are not kept.

    Returns
    -------
    (pandas.DataFrame, pandas.DataFrame)
        Training and test tables (see :func:`leak_indicators`).

    Examples
    --------
    >>> from pdmkit.experiments._rul import simulate_leak_dataset
    >>> train, test = simulate_leak_dataset(2, 1, max_cycles=5, t_end=0.5,
    ...                                     signals=["LeverPosition"])
    >>> train["unit"].nunique(), test["unit"].nunique(), int(test["rul"].min())
    (2, 1, 0)
    """
    from pdmkit.ensembles import simulate_leak_runs

    for name, value in (("n_train", n_train), ("n_test", n_test)):
        if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
            raise DataError(f"{name} must be a positive integer, got {value!r}")
    settings = {
        "n_train": int(n_train),
        "n_test": int(n_test),
        "max_cycles": int(max_cycles),
        "t_end": float(t_end),
        "walk_shape": float(walk_shape),
        "seed": int(seed),
        "signals": list(signals),
        "version": _LEAK_VERSION,
    }
    path = None
    if cache_dir is not None:
        key = hashlib.sha1(json.dumps(settings, sort_keys=True).encode()).hexdigest()[:12]
        path = Path(cache_dir) / f"leak_{key}.parquet"
        if path.exists():
            table = pd.read_parquet(path)
            return tuple(
                table[table["part"] == p].drop(columns="part").reset_index(drop=True)
                for p in ("train", "test")
            )
    tables = []
    for part, n in ((0, n_train), (1, n_test)):
        runs = simulate_leak_runs(
            int(n),
            max_cycles=int(max_cycles),
            t_end=float(t_end),
            signals=list(signals),
            seed=_leak_seed(seed, part),
            walk_shape=float(walk_shape),
        )
        tables.append(leak_indicators(runs))
        del runs
    train, test = tables
    test["unit"] = test["unit"] + int(n_train)  # unit ids unique over both parts
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        both = pd.concat(
            [train.assign(part="train"), test.assign(part="test")], ignore_index=True
        )
        with atomic_path(path) as tmp:
            both.to_parquet(tmp)
    return train, test


def leak_accuracy(unit, time, rul_pred, life, *, alpha: float = 0.1) -> pd.DataFrame:
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
    from pdmkit.rul import alpha_lambda_accuracy

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


def _leak_data(features, seed, options, cache_dir):
    """(train, test, feature columns, ranking) of the air-leak workflow."""
    from pdmkit.rul import prognostic_ranking

    opts = {**LEAK_DEFAULTS, **dict(options or {})}
    unknown = set(opts) - {*LEAK_DEFAULTS, "cache_dir", "signals"}
    if unknown:
        raise DataError(
            f"unknown dataset option(s) {sorted(unknown)} for 'pneumatic-leak'; known: "
            f"{sorted([*LEAK_DEFAULTS, 'cache_dir', 'signals'])}"
        )
    opts.setdefault("cache_dir", cache_dir)
    train, test = simulate_leak_dataset(seed=seed, **opts)
    candidates = [c for c in train.columns if "/" in str(c)]
    ranking = prognostic_ranking(train, candidates)
    if features is None:
        scored = ranking["score"].dropna()
        if scored.empty:
            raise DataError("no candidate indicator of the leak runs can be scored")
        cols = [str(scored.index[0])]
    else:
        cols = list(features)
    return train, test, cols, ranking


def split_run_to_failure(
    table: pd.DataFrame,
    *,
    test_fraction: float = 0.25,
    cut: tuple[float, float] = (0.1, 0.9),
    seed: int = 0,
    unit: str = "unit",
    time: str | None = None,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Split run-to-failure units into training units and cut test histories.

    The usual case: one set of units run to failure and no separate test set. A
    ``test_fraction`` of the units (at least one, at least two left for training) is
    held out; each held-out unit's history is cut after a uniformly drawn fraction of
    its life in ``cut`` (at least its first row, at most all but its last), and its
    true RUL after the cut, ``rul_true_final``, is what remained, as C-MAPSS's test
    files give it.

    Parameters
    ----------
    table : pandas.DataFrame
        Long table of run-to-failure units (a unit's last row is its failure).
    test_fraction : float, default 0.25
    cut : (float, float), default (0.1, 0.9)
        Range of the fraction of life after which a test history stops.
    seed : int, default 0
    unit, time : str
        Key columns (``time`` default ``"time"``, else ``"cycle"``).

    Returns
    -------
    (train, test) : tuple of pandas.DataFrame

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from pdmkit.experiments import split_run_to_failure
    >>> table = pd.DataFrame({"unit": np.repeat([1, 2, 3, 4], 10),
    ...                       "cycle": np.tile(np.arange(1, 11), 4), "s1": 0.0})
    >>> train, test = split_run_to_failure(table, seed=1)
    >>> train["unit"].nunique(), test["unit"].nunique()
    (3, 1)
    >>> bool((test["cycle"].max() + test["rul_true_final"].iloc[0]) == 10)
    True
    """
    from pdmkit.rul._base import resolve_keys

    unit, time = resolve_keys(table, unit, time)
    if not 0 < test_fraction < 1:
        raise ValueError(f"test_fraction must be in (0, 1), got {test_fraction!r}")
    lo, hi = (float(v) for v in cut)
    if not 0 <= lo <= hi <= 1:
        raise ValueError(f"cut must be (lo, hi) with 0 <= lo <= hi <= 1, got {cut!r}")
    units = pd.unique(table[unit])
    if len(units) < 3:
        raise DataError(
            f"splitting needs at least 3 run-to-failure units (2 to train, 1 to test); "
            f"the table has {len(units)}"
        )
    rng = np.random.default_rng(seed)
    n_test = min(max(1, round(test_fraction * len(units))), len(units) - 2)
    held = set(rng.choice(units, size=n_test, replace=False).tolist())
    parts = []
    for _, part in table[table[unit].isin(held)].groupby(unit, sort=False):
        part = part.sort_values(time)
        t = part[time].to_numpy(dtype=float)
        end = t[0] + rng.uniform(lo, hi) * (t[-1] - t[0])
        keep = part[(t <= end)] if (t <= end).any() else part.iloc[:1]
        keep = keep.iloc[: max(1, min(len(keep), len(part) - 1))]
        parts.append(keep.assign(rul_true_final=t[-1] - float(keep[time].iloc[-1])))
    train = table[~table[unit].isin(held)].reset_index(drop=True)
    return train, pd.concat(parts, ignore_index=True)


def _dataset(dataset, features):
    """Return (name, train, test, true RUL per test unit, feature columns)."""
    if isinstance(dataset, str):
        key = dataset.lower().replace("_", "-")
        if key not in ("cmapss-fd001", "cmapss"):
            raise DataError(
                f"dataset {dataset!r} is not known to the RUL workflow; use "
                "'cmapss-fd001', 'pneumatic-leak', 'nasa-battery' or pass "
                "(train_table, test_table)"
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
    smoothing: float | None = 10,
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
    from pdmkit import rul

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
        "neural": (
            rul.NeuralRULModel,
            {"features": features, "window": 40, "pad": "edge", **seeded},
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
    if model in ("neural", "survival", "reliability"):  # they read the sensors / ages
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
    """A fitted :class:`pdmkit.rul.RULPipeline` for a workflow model, and its fit time;
    ``calibrate`` wraps the estimator in :class:`pdmkit.rul.ConformalRUL`."""
    from pdmkit.rul import ConformalRUL, RULPipeline

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
    import hashlib
    import tempfile

    from pdmkit._persist import save_model

    with tempfile.TemporaryDirectory() as folder:  # hashed now, written at the commit
        blob = save_model(pipeline, Path(folder) / "model.pdmkit").read_bytes()
    sink.add_file("model.pdmkit", lambda path: path.write_bytes(blob))
    summary["model_file"] = str(sink.path("model.pdmkit"))
    # kept apart from the file, this hash is what proves the file is this one
    # (pdmkit rul --trained MODEL --expect-sha256 HASH; docs/model_files.md)
    summary["model_sha256"] = hashlib.sha256(blob).hexdigest()


def predict_rul(
    model_file, history, *, json_path=None, expect_sha256: str | None = None
) -> dict[str, Any]:
    """RUL of each unit in ``history`` from a model trained by :func:`run_rul`.

    Parameters
    ----------
    model_file : str or Path
        ``model.pdmkit`` from a ``run_rul`` / ``pdmkit rul`` output folder (any
        :class:`pdmkit.rul.RULPipeline` or RUL model saved with
        :func:`pdmkit.save_model`).
    history : str, Path or pandas.DataFrame
        The units' histories so far: a long table (CSV or Parquet file, or a frame)
        with ``unit``, ``time`` or ``cycle`` and the columns the model was trained on.
        Without a ``unit`` column the table is one unit's history, named after the
        file (``"unit"`` for a frame).
    json_path : str or Path, optional
        Also write the answer here as JSON.
    expect_sha256 : str, optional
        The model file's SHA-256 as its training run reported it (``model_sha256`` in
        ``rul.json``); a file with another hash is refused before it is read.

    Returns
    -------
    dict
        ``model_file``, ``model`` (the estimator), ``level`` and ``units``: one entry
        per unit with ``unit``, ``time`` (its last time), ``rul``, ``lower``,
        ``upper``.

    Raises
    ------
    pdmkit.errors.ModelError
        The model file is damaged, not a pdmkit model, or not a RUL model.
    pdmkit.errors.DataError
        The history lacks a column the model needs (the message names it).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> import numpy as np, pandas as pd
    >>> from pdmkit import save_model
    >>> from pdmkit.experiments._rul import predict_rul
    >>> from pdmkit.rul import LinearDegradationModel
    >>> t = np.arange(0.0, 40.0)
    >>> train = pd.DataFrame({"unit": np.repeat([1, 2, 3], 40), "time": np.tile(t, 3),
    ...     "hi": np.r_[0.02 * t, 0.025 * t, 0.03 * t] + 0.001 * np.sin(np.tile(t, 3))})
    >>> model = LinearDegradationModel(threshold=1.0).fit(train)
    >>> path = save_model(model, pathlib.Path(tempfile.mkdtemp()) / "model.pdmkit")
    >>> history = pd.DataFrame({"unit": "pump-7", "time": [0.0, 10.0], "hi": [0.0, 0.25]})
    >>> answer = predict_rul(path, history)
    >>> answer["units"][0]["unit"], round(answer["units"][0]["rul"])   # 1.0 at t = 40
    ('pump-7', 30)
    """
    inputs = [model_file] if isinstance(history, pd.DataFrame) else [model_file, history]
    if json_path is not None:  # before any work: --json must not overwrite an input
        check_output_folder(None, "rul", inputs=inputs, json_path=json_path)
    with collect_warnings() as found:
        answer = _predict_rul(model_file, history, expect_sha256)
    answer["warnings"] = list(found)
    if json_path is not None:
        write_json_file(answer, json_path, inputs=inputs)
    return answer


def units_in_seconds(table: pd.DataFrame, where) -> tuple[pd.DataFrame, str | None]:
    """:func:`pdmkit.rul.timestamps_to_seconds` with errors naming ``where`` (a file).

    Examples
    --------
    >>> import pandas as pd
    >>> from pdmkit.experiments._rul import units_in_seconds
    >>> units_in_seconds(pd.DataFrame({"cycle": [1, 2]}), "units.csv")[1] is None
    True
    """
    from pdmkit.rul import timestamps_to_seconds

    try:
        return timestamps_to_seconds(table)
    except DataError as exc:
        raise DataError(f"{where}: {exc}") from None


def _predict_rul(model_file, history, expect_sha256=None) -> dict[str, Any]:
    from pdmkit._persist import load_model
    from pdmkit.ensembles._readers import read_table
    from pdmkit.errors import ModelError

    pipeline = load_model(model_file, expect_sha256=expect_sha256)
    if not hasattr(pipeline, "predict_trajectory"):
        raise ModelError(
            f"{model_file}: holds a {type(pipeline).__name__}, not a RUL model; train "
            "one with `pdmkit rul ... --out DIR` (it writes DIR/model.pdmkit)"
        )
    table = history if isinstance(history, pd.DataFrame) else read_table(history)
    where = "history" if isinstance(history, pd.DataFrame) else str(history)
    table, _ = units_in_seconds(table, where)
    for column in table.select_dtypes("number"):  # overflows: silent wrong answers
        check_magnitude(table[column], f"{where}: column {column!r}")
    unit = getattr(getattr(pipeline, "model", pipeline), "unit", "unit")
    if unit not in table.columns:  # one unit's history: named after its file
        name = "unit" if isinstance(history, pd.DataFrame) else Path(history).stem
        table = table.assign(**{unit: name})
    try:
        prediction = pipeline.predict(table)
    except DataError as exc:  # name the file: the model's message names the column
        raise DataError(f"{where}: {exc}") from None
    except (AttributeError, TypeError, ValueError, IndexError, MemoryError) as exc:
        # a loaded model whose parts do not fit together (hand-made or damaged)
        text = str(exc).splitlines()[0][:200] if str(exc) else ""
        raise ModelError(
            f"{model_file}: the model cannot predict ({type(exc).__name__}: {text}); "
            "train it again with `pdmkit rul ... --out DIR`"
        ) from None
    rows = prediction.to_pandas()[["unit", "time", "rul", "lower", "upper"]]
    answer = {
        "model_file": str(model_file),
        "model": repr(getattr(pipeline, "model", pipeline)),
        "level": float(prediction.level),
        "units": rows.to_dict(orient="records"),
    }
    return answer


def _finish(report, summary: dict, sink) -> dict:
    """Register the report and the JSON summary (with its ``paths``); return the summary."""
    report.add_json(summary, caption="Summary")
    summary["paths"] = {
        "json": str(sink.path("rul.json")),
        "report": str(sink.path("report.html")),
        "predictions": str(sink.path("predictions.parquet")),
    }
    sink.add_report("report.html", report)
    sink.add_json("rul.json", summary)
    return summary


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
    dataset_options: dict | None = None,
    calibrate: bool = False,
) -> dict[str, Any]:
    """Train a RUL model, predict the test units, and write JSON and an HTML report.

    Parameters
    ----------
    dataset : str or (pandas.DataFrame, pandas.DataFrame)
        ``"cmapss-fd001"`` (NASA C-MAPSS FD001: 100 training engines run to failure,
        100 test engines stopped earlier, true RULs from ``RUL_FD001.txt``),
        ``"pneumatic-leak"`` (air-leak units of the pneumatic twin,
        :func:`simulate_leak_dataset`, scored over the last half of each test unit's
        life), ``"nasa-battery"`` (four Li-ion cells, leave-one-cell-out, the
        degradation models only), or a pair of long tables ``(train, test)`` with ``unit``,
        ``time``/``cycle`` and the features, the test table holding ``rul_true_final``.
    model : str, default "similarity"
        One of :data:`RUL_MODELS` (``similarity``, ``degradation``, ``survival``,
        ``neural`` and the variants named in the module notes).
    out_dir : str or Path, default "results/rul"
        Folder for ``rul.json``, ``predictions.parquet``, ``report.html`` and
        ``model.pdmkit``, written all at once when everything succeeded; anything else
        in the folder is left as it is (see :mod:`pdmkit._outputs`).
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
    dataset_options : dict, optional
        For ``"pneumatic-leak"``: arguments of :func:`simulate_leak_dataset`
        (defaults :data:`LEAK_DEFAULTS`; ``cache_dir`` defaults to
        ``out_dir/.pdmkit/cache``).
    calibrate : bool, default False
        Wrap the model in :class:`pdmkit.rul.ConformalRUL`: its intervals rescaled on
        held-out training units to hold their level (estimates unchanged).

    Returns
    -------
    dict
        ``model, dataset, rmse, mae, phm08_score, coverage, n_units`` (scored against
        the capped true RUL), the same uncapped (``*_uncapped``), ``bias``,
        ``mean_interval_width``, ``level``, ``rul_cap``, ``seed``, ``fit_seconds``,
        ``predict_seconds``, ``estimator``, ``features`` and ``paths``. For
        ``"pneumatic-leak"`` the scores are over every prediction in the last half of
        the test units' lives (``n_predictions`` of them), and ``within_10pct`` holds
        the fraction of test units within 10 % under each reading of
        :func:`leak_accuracy`, ``indicator_ranking`` the best candidates, and
        ``true_leak`` the same scores with the true ``log10 C_al`` as the indicator
        (what the random walk alone allows).

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
    with OutputRun(out_dir, "rul", json_path=json_path) as run:
        summary = _rul(
            run,
            dataset,
            model,
            seed,
            features=features,
            rul_cap=rul_cap,
            options=options,
            n_trajectories=n_trajectories,
            dataset_options=dataset_options,
            calibrate=calibrate,
        )
        run.commit()
    return summary


def _rul(
    sink,
    dataset,
    model,
    seed,
    *,
    features,
    rul_cap,
    options,
    n_trajectories,
    dataset_options,
    calibrate,
) -> dict[str, Any]:
    """:func:`run_rul` with its files registered with ``sink`` (not yet written)."""
    from pdmkit.experiments._report import Report
    from pdmkit.rul import rul_metrics

    key = dataset.lower().replace("_", "-") if isinstance(dataset, str) else None
    if key in ("nasa-battery", "battery"):
        from pdmkit.experiments._rul_battery import run_battery

        if dataset_options:
            raise DataError("'nasa-battery' takes no dataset options")
        return run_battery(
            model,
            sink,
            seed,
            rul_cap=rul_cap,
            options=options,
            calibrate=calibrate,
        )
    if key in _LEAK_NAMES:
        return _run_leak(
            model,
            sink,
            seed,
            features=features,
            rul_cap=rul_cap,
            options=options,
            n_trajectories=n_trajectories,
            dataset_options=dataset_options,
            calibrate=calibrate,
        )
    if dataset_options:
        raise DataError(
            f"dataset options {sorted(dataset_options)} are simulation settings of "
            "'pneumatic-leak'; the other datasets take none"
        )
    name, train, test, true, cols = _dataset(dataset, features)
    pipeline, fit_seconds = _fit_pipeline(
        model, cols, train, seed=seed, rul_cap=rul_cap, options=options, calibrate=calibrate
    )
    indicator, estimator = pipeline.indicator, pipeline.model
    test_in = pipeline.transform(test)
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
        **_calibration(pipeline),
        "features": list(indicator.selected_)
        if indicator is not None
        else list(getattr(estimator, "features_", cols)),
    }

    # ---------------------------------------------------------------- files
    _save_pipeline(pipeline, sink, summary)
    table = pred.to_pandas()
    table["rul_true"] = truth
    table["rul_true_capped"] = capped
    if "nearest" in table.columns:
        table["nearest"] = table["nearest"].map(lambda v: ",".join(map(str, v)))
    sink.add_parquet("predictions.parquet", table.copy())

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
            _indicator_plot(pipeline.transform(train), estimator),
            caption="Health indicator of ten training units",
        )
    report.add_table(
        table.drop(columns=[c for c in ("nearest",) if c in table]),
        caption="Predictions per test unit",
    )
    return _finish(report, summary, sink)


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


# --------------------------------------------------------------------------- air leak


def _leak_fit_predict(model, cols, train, test, seed, rul_cap, options, calibrate):
    """Fit on ``train`` and follow every test unit through its life."""
    pipeline, fit_seconds = _fit_pipeline(
        model,
        cols,
        train,
        seed=seed,
        rul_cap=rul_cap,
        options=options,
        smoothing=None,
        calibrate=calibrate,
    )
    start = time.perf_counter()
    path = pipeline.predict_trajectory(test, every=1)
    predict_seconds = time.perf_counter() - start
    return pipeline, path, fit_seconds, predict_seconds


def _trajectory_scores(path, life: pd.Series, rul_cap: float):
    """(table of every prediction, headline metrics, per-unit accuracy, fractions) of a
    trajectory prediction (a RULPrediction or its table), over each unit's last half."""
    from pdmkit.rul import rul_metrics

    table = path.to_pandas() if hasattr(path, "to_pandas") else path.copy()
    table["life"] = life.reindex(table["unit"]).to_numpy(dtype=float)
    table["rul_true"] = table["life"] - table["time"]
    table["last_half"] = (table["time"] >= table["life"] / 2) & (
        table["time"] < table["life"]
    )
    last = table[table["last_half"]]
    truth = np.minimum(last["rul_true"].to_numpy(), rul_cap)
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


def _run_leak(
    model,
    sink,
    seed,
    *,
    features,
    rul_cap,
    options,
    n_trajectories,
    dataset_options,
    calibrate,
):
    from pdmkit.experiments._report import Report

    start = time.perf_counter()
    train, test, cols, ranking = _leak_data(features, seed, dataset_options, sink.cache)
    data_seconds = time.perf_counter() - start
    life = test.groupby("unit", sort=False)["cycle"].max()
    pipeline, path, fit_s, pred_s = _leak_fit_predict(
        model, cols, train, test, seed, rul_cap, options, calibrate
    )
    indicator, estimator = pipeline.indicator, pipeline.model
    table, metrics, acc, fractions = _trajectory_scores(path, life, rul_cap)
    # the same model on the true leak coefficient: what the random walk alone allows
    true_col = "true/log10_c_leak"
    ceiling_in = [t.assign(**{true_col: np.log10(t["c_leak"])}) for t in (train, test)]
    _, true_path, _, _ = _leak_fit_predict(
        model, [true_col], *ceiling_in, seed, rul_cap, options, calibrate
    )
    _, true_metrics, _, true_fractions = _trajectory_scores(true_path, life, rul_cap)

    top = ranking.head(5)
    summary: dict[str, Any] = {
        "model": model,
        "dataset": "pneumatic-leak",
        "rmse": metrics["rmse"],
        "mae": metrics["mae"],
        "phm08_score": metrics["phm08_score"],
        "coverage": metrics["coverage"],
        "n_units": len(acc),
        "n_predictions": metrics["n"],
        "within_10pct_of_life": fractions["of_life"],
        "within_10pct_of_rul": fractions["of_rul"],
        "within_10pct": fractions,
        "readings": dict(_READINGS),
        "bias": metrics["bias"],
        "mean_interval_width": metrics["mean_width"],
        "level": path.level,
        "indicator": cols[0] if len(cols) == 1 else cols,
        "indicator_ranking": {
            str(k): {m: float(v) for m, v in row.items()} for k, row in top.iterrows()
        },
        "seed_indicator": {
            "name": _SEED_INDICATOR,
            "score": float(ranking.loc[_SEED_INDICATOR, "score"])
            if _SEED_INDICATOR in ranking.index
            else None,
            "rank": int(list(ranking.index).index(_SEED_INDICATOR)) + 1
            if _SEED_INDICATOR in ranking.index
            else None,
        },
        "true_leak": {
            "rmse": true_metrics["rmse"],
            "mae": true_metrics["mae"],
            "coverage": true_metrics["coverage"],
            "within_10pct": true_fractions,
        },
        "simulation": {
            **LEAK_DEFAULTS,
            **{k: v for k, v in dict(dataset_options or {}).items() if k != "cache_dir"},
        },
        "n_train_units": int(train["unit"].nunique()),
        "rul_cap": rul_cap,
        "seed": seed,
        "data_seconds": round(data_seconds, 2),
        "fit_seconds": round(fit_s, 2),
        "predict_seconds": round(pred_s, 2),
        "estimator": repr(estimator),
        **_calibration(pipeline),
        "features": list(indicator.selected_) if indicator is not None else list(cols),
    }

    _save_pipeline(pipeline, sink, summary)
    sink.add_parquet(
        "predictions.parquet", table.drop(columns=[c for c in ("nearest",) if c in table])
    )
    report = Report(f"pdmkit rul: {model} on the pneumatic air-leak runs")
    sim = summary["simulation"]
    report.add_text(
        f"Model: {RUL_MODELS[model]} ({summary['estimator']}). "
        f"{summary['n_train_units']} training and {summary['n_units']} test units of "
        "the pneumatic twin with a chamber-B air leak whose coefficient C_al grows "
        "log-linearly from 1e-10 to 1e-6 m^2 along a unit-specific random walk "
        f"(gamma steps of shape {sim['walk_shape']:g}); one {sim['t_end']:g} s "
        "recording per cycle; a unit fails at the first cycle with C_al >= 1e-6. "
        f"Seed {seed}."
    )
    report.add_heading("Indicator")
    report.add_text(
        f"Candidates: the time-domain statistics of {', '.join(LEAK_SIGNALS)} per "
        "recording (the seed's shape factor among them) and the log RMS deviation of "
        "each recording from the unit's first (as-new) one, ranked on the training "
        "units by the mean of monotonicity, trendability and prognosability. Used: "
        f"{', '.join(map(str, cols))}."
    )
    if summary["seed_indicator"]["rank"] is not None:
        report.add_text(
            f"The seed's indicator ({_SEED_INDICATOR}) ranks "
            f"{summary['seed_indicator']['rank']} of {len(ranking)} with score "
            f"{summary['seed_indicator']['score']:.3f}."
        )
    shown_rank = ranking.head(10)
    if _SEED_INDICATOR in ranking.index and _SEED_INDICATOR not in shown_rank.index:
        shown_rank = pd.concat([shown_rank, ranking.loc[[_SEED_INDICATOR]]])
    report.add_table(shown_rank, caption="Candidate indicators, best first")
    if indicator is not None:
        report.add_figure(
            _indicator_plot(pipeline.transform(train), estimator),
            caption="Health indicator (the chosen indicator mapped to the fraction of "
            "life) of ten training units",
        )
    report.add_heading("Scores over the last half of life")
    rows = ["rmse", "mae", "coverage"]
    scores = pd.DataFrame(
        {
            "indicator": [metrics[k] for k in rows] + [fractions[k] for k in _READINGS],
            "true log10 C_al": [true_metrics[k] for k in rows]
            + [true_fractions[k] for k in _READINGS],
        },
        index=["RMSE (cycles)", "MAE (cycles)", f"{100 * path.level:g} % interval coverage"]
        + [f"units: {text}" for text in _READINGS.values()],
    )
    report.add_table(
        scores,
        caption="Every prediction from half life to the cycle before failure; the "
        "second column is the same model fed the true leak coefficient",
    )
    by_life = list(acc.sort_values("life").index)
    step = max(1, len(by_life) // max(1, n_trajectories))
    shown = by_life[::step][: max(0, n_trajectories)]
    if shown:
        report.add_figure(
            _trajectory_plot(table, shown),
            caption="RUL against cycle for test units (true RUL dashed; dotted: the "
            "model's interval; shaded: within 10 % of the unit's life over its last "
            "half)",
        )
    report.add_table(acc, caption="Per test unit, over the last half of its life")
    return _finish(report, summary, sink)


def _trajectory_plot(table: pd.DataFrame, units, ax=None):
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
    ax.set_xlabel("cycle")
    ax.set_ylabel("RUL (cycles)")
    ax.legend(fontsize="small")
    return ax
