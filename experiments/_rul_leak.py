"""The RUL workflow on the twin's air-leak run-to-failure units (Voronin, section 8.4).

The candidate indicators of each 10 s cycle are ranked by monotonicity, trendability
and prognosability on the training units, the best one feeds the model (unsmoothed),
and every test unit is followed through its whole life with
:meth:`~pdmkit.rul.LinearDegradationModel.predict_trajectory`; the scores are over the
predictions in the last half of each test unit's life, with the fraction of test units
predicted within 10 % (see :func:`leak_accuracy`).
"""

from __future__ import annotations

import hashlib
import json
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pdmkit._atomic import atomic_path
from pdmkit.ensembles import Ensemble, simulate_leak_runs
from pdmkit.errors import DataError
from pdmkit.experiments._report import Report
from pdmkit.experiments._rul_models import (
    _READINGS,
    RUL_MODELS,
    _calibration,
    _finish,
    _fit_pipeline,
    _indicator_plot,
    _save_pipeline,
    _trajectory_coverage,
    _trajectory_plot,
    _trajectory_scores,
)
from pdmkit.features import extract
from pdmkit.rul import prognostic_ranking

__all__ = [
    "LEAK_DEFAULTS",
    "LEAK_SIGNALS",
    "leak_indicators",
    "simulate_leak_dataset",
]

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


# --------------------------------------------------------------------------- air leak


def leak_indicators(
    ensemble: Ensemble, *, signals: Sequence[str] | None = None
) -> pd.DataFrame:
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
    signals: Sequence[str] = LEAK_SIGNALS,
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


def _leak_data(features, seed, options, cache_dir):
    """(train, test, feature columns, ranking) of the air-leak workflow."""
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


@dataclass(frozen=True)
class _LeakFit:
    """The leak workflow's data, fitted pipeline and scores, with the true-leak ceiling."""

    train: pd.DataFrame
    cols: list
    ranking: pd.DataFrame
    pipeline: Any
    level: float
    table: pd.DataFrame
    metrics: dict
    acc: pd.DataFrame
    fractions: dict
    true_metrics: dict
    true_fractions: dict
    seconds: dict


def _leak_fit(model, sink, seed, features, rul_cap, options, dataset_options, calibrate):
    """Simulate (or read) the units, fit, follow the test units, score; the ceiling too."""
    start = time.perf_counter()
    train, test, cols, ranking = _leak_data(features, seed, dataset_options, sink.cache)
    data_seconds = time.perf_counter() - start
    life = test.groupby("unit", sort=False)["cycle"].max()
    pipeline, path, fit_s, pred_s = _leak_fit_predict(
        model, cols, train, test, seed, rul_cap, options, calibrate
    )
    table, metrics, acc, fractions = _trajectory_scores(path, life, rul_cap)
    # the same model on the true leak coefficient: what the random walk alone allows
    true_col = "true/log10_c_leak"
    ceiling_in = [t.assign(**{true_col: np.log10(t["c_leak"])}) for t in (train, test)]
    _, true_path, _, _ = _leak_fit_predict(
        model, [true_col], *ceiling_in, seed, rul_cap, options, calibrate
    )
    _, true_metrics, _, true_fractions = _trajectory_scores(true_path, life, rul_cap)
    seconds = {"data": data_seconds, "fit": fit_s, "predict": pred_s}
    return _LeakFit(
        train, cols, ranking, pipeline, path.level, table, metrics, acc, fractions,
        true_metrics, true_fractions, seconds,
    )  # fmt: skip


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
    cap_source="none",
    time_unit="cycles",
):
    """``run_rul("pneumatic-leak")``: its files registered with ``sink``."""
    fit = _leak_fit(
        model, sink, seed, features, rul_cap, options, dataset_options, calibrate
    )
    fit.pipeline.time_unit_ = time_unit
    summary = _leak_summary(model, seed, fit, dataset_options)
    summary.update(
        {
            "coverage_check": _trajectory_coverage(
                fit.table, rul_cap, fit.level, [], len(fit.acc)
            ),
            "rul_cap": rul_cap,
            "rul_cap_source": cap_source,
            "time_unit": time_unit,
            "seed": seed,
            "data_seconds": round(fit.seconds["data"], 2),
            "fit_seconds": round(fit.seconds["fit"], 2),
            "predict_seconds": round(fit.seconds["predict"], 2),
            "estimator": repr(fit.pipeline.model),
            **_calibration(fit.pipeline),
            "features": list(fit.pipeline.indicator.selected_)
            if fit.pipeline.indicator is not None
            else list(fit.cols),
        }
    )
    _save_pipeline(fit.pipeline, sink, summary)
    table = fit.table
    sink.add_parquet(
        "predictions.parquet", table.drop(columns=[c for c in ("nearest",) if c in table])
    )
    report = Report(f"pdmkit rul: {model} on the pneumatic air-leak runs")
    _leak_report_opening(report, fit, summary)
    _leak_scores_section(report, fit, time_unit)
    by_life = list(fit.acc.sort_values("life").index)
    step = max(1, len(by_life) // max(1, n_trajectories))
    shown = by_life[::step][: max(0, n_trajectories)]
    if shown:
        report.add_figure(
            _trajectory_plot(table, shown, time_unit=time_unit),
            caption="RUL against cycle for test units (true RUL dashed; dotted: the "
            "model's interval; shaded: within 10 % of the unit's life over its last "
            "half)",
        )
    report.add_table(fit.acc, caption="Per test unit, over the last half of its life")
    return _finish(report, summary, sink)


def _leak_summary(model, seed, fit: _LeakFit, dataset_options) -> dict[str, Any]:
    """The scores, the indicator and the simulation of ``summary.json``."""
    metrics, fractions, ranking = fit.metrics, fit.fractions, fit.ranking
    top = ranking.head(5)
    known = _SEED_INDICATOR in ranking.index
    return {
        "model": model,
        "dataset": "pneumatic-leak",
        "rmse": metrics["rmse"],
        "mae": metrics["mae"],
        "phm08_score": metrics["phm08_score"],
        "coverage": metrics["coverage"],
        "n_units": len(fit.acc),
        "n_predictions": metrics["n"],
        "within_10pct_of_life": fractions["of_life"],
        "within_10pct_of_rul": fractions["of_rul"],
        "within_10pct": fractions,
        "readings": dict(_READINGS),
        "bias": metrics["bias"],
        "mean_interval_width": metrics["mean_width"],
        "level": fit.level,
        "indicator": fit.cols[0] if len(fit.cols) == 1 else fit.cols,
        "indicator_ranking": {
            str(k): {m: float(v) for m, v in row.items()} for k, row in top.iterrows()
        },
        "seed_indicator": {
            "name": _SEED_INDICATOR,
            "score": float(ranking.loc[_SEED_INDICATOR, "score"]) if known else None,
            "rank": int(list(ranking.index).index(_SEED_INDICATOR)) + 1 if known else None,
        },
        "true_leak": {
            "rmse": fit.true_metrics["rmse"],
            "mae": fit.true_metrics["mae"],
            "coverage": fit.true_metrics["coverage"],
            "within_10pct": fit.true_fractions,
        },
        "simulation": {
            **LEAK_DEFAULTS,
            **{k: v for k, v in dict(dataset_options or {}).items() if k != "cache_dir"},
        },
        "n_train_units": int(fit.train["unit"].nunique()),
    }


def _leak_report_opening(report: Report, fit: _LeakFit, summary: dict) -> None:
    """The report's opening and its Indicator section (candidates, the one used)."""
    sim, ranking = summary["simulation"], fit.ranking
    report.add_text(
        f"Model: {RUL_MODELS[summary['model']]} ({summary['estimator']}). "
        f"{summary['n_train_units']} training and {summary['n_units']} test units of "
        "the pneumatic twin with a chamber-B air leak whose coefficient C_al grows "
        "log-linearly from 1e-10 to 1e-6 m^2 along a unit-specific random walk "
        f"(gamma steps of shape {sim['walk_shape']:g}); one {sim['t_end']:g} s "
        "recording per cycle; a unit fails at the first cycle with C_al >= 1e-6. "
        f"Seed {summary['seed']}."
    )
    report.add_heading("Indicator")
    report.add_text(
        f"Candidates: the time-domain statistics of {', '.join(LEAK_SIGNALS)} per "
        "recording (the seed's shape factor among them) and the log RMS deviation of "
        "each recording from the unit's first (as-new) one, ranked on the training "
        "units by the mean of monotonicity, trendability and prognosability. Used: "
        f"{', '.join(map(str, fit.cols))}."
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
    if fit.pipeline.indicator is not None:
        report.add_figure(
            _indicator_plot(
                fit.pipeline.transform(fit.train), fit.pipeline.model, summary["time_unit"]
            ),
            caption="Health indicator (the chosen indicator mapped to the fraction of "
            "life) of ten training units",
        )


def _leak_scores_section(report: Report, fit: _LeakFit, time_unit: str) -> None:
    """The scores over the last half of life, beside the true-leak ceiling's."""
    report.add_heading("Scores over the last half of life")
    rows = ["rmse", "mae", "coverage"]
    scores = pd.DataFrame(
        {
            "indicator": [fit.metrics[k] for k in rows]
            + [fit.fractions[k] for k in _READINGS],
            "true log10 C_al": [fit.true_metrics[k] for k in rows]
            + [fit.true_fractions[k] for k in _READINGS],
        },
        index=[
            f"RMSE ({time_unit})",
            f"MAE ({time_unit})",
            f"{100 * fit.level:g} % interval coverage",
        ]
        + [f"units: {text}" for text in _READINGS.values()],
    )
    report.add_table(
        scores,
        caption="Every prediction from half life to the cycle before failure; the "
        "second column is the same model fed the true leak coefficient",
    )
