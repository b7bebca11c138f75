"""The seed's recipes, exactly, each named after its section (Voronin, chapters 7-9).

The seed (a master's thesis on a double-acting pneumatic piston rig) reports its
numbers from MATLAB's Diagnostic Feature Designer and Classification Learner. Its
author's code (github.com/xvoron/thesis: ``sb/sensor_*/``, ``mb/functions/``,
``mb/rul.mlx``) fixes what the text leaves open; each recipe follows it (the recipes
live in ``_seed_recipes``, their indicators, ranking and models in
``_seed_indicators``):

==========================  ===========================================================
:func:`seed_flow_knn`       7.3, table 7.2 "ANOVA / Fine KNN" 97.52 %: FlowContraction's
                            24 indicators, Kruskal-Wallis top 5 (correlation weighted),
                            1-nearest neighbour on standardised indicators, 30 % holdout
:func:`seed_flow_bagged_trees`  table 7.2 "all features / Bagged Trees" 99.45 %: the 24
                            indicators, 30 bagged full-depth trees, 5-fold CV
:func:`seed_flow_pca_bagged_trees`  table 7.2 "PCA / Bagged Trees" 95.18 %: PCA of the
                            raw indicators keeping 98 % of the variance, then the same
:func:`seed_residual_classification`  8.3, 99.49 %: the seed's smaller data set
                            (healthy and four single faults at 6.25 kg), LeverPosition
                            minus one healthy twin response, 13 statistics, top 5,
                            quadratic SVM, 30 % holdout
:func:`seed_sensor_faults`  8.1.1, 100 %: healthy / noise / offset of the flow sensor,
                            5 statistics, 1-nearest neighbour, 5-fold CV
:func:`seed_air_leak_rul`   8.4, "deviation of about 10 %": 25 training runs on the
                            author's leak schedule (scaled to the twin's valves,
                            identical runs), flow shape factor, linear degradation
                            model, one test run predicted after 60 cycles
:func:`seed_sensor_table`   7.4 / table 9.1: each sensor with the author's recipe for it
==========================  ===========================================================

The seed's condition indicators of a signal (:func:`seed_indicators`) are the 13
"signal statistics" of the Diagnostic Feature Designer (``<signal>_stats/...``:
ClearanceFactor, CrestFactor, ImpulseFactor, Kurtosis, Mean, PeakValue, RMS, SINAD, SNR,
ShapeFactor, Skewness, Std, THD; pdmkit's ``stats`` group without PeakToPeak, and its
``harmonic`` group) and its Welch-spectrum features (``<signal>_ps_spec/...``:
PeakAmp1..N, PeakFreq1..N and BandPower of a band; pdmkit's ``spectral`` group with
``frange``). For the flow sensor: 13 + 5 + 5 + 1 = 24 per signal, FlowContraction only;
the seed's "25" counts the label column of that table.

Each recipe returns a :class:`SeedResult` with the seed's published number beside
pdmkit's on the twin; :func:`seed_comparison` turns a list of them into the report
table, and :func:`run_seed_study` runs them all on a simulated seed ensemble
(:func:`pdmkit.ensembles.simulate_seed_ensemble`) in parts, to bound the memory.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from typing import Any

import pandas as pd

from pdmkit._progress import progress
from pdmkit.ensembles import simulate_seed_ensemble
from pdmkit.errors import DataError
from pdmkit.experiments._seed_indicators import (
    SeedResult,
    seed_feature_table,
)
from pdmkit.experiments._seed_recipes import (
    seed_air_leak_rul,
    seed_flow_bagged_trees,
    seed_flow_knn,
    seed_flow_pca_bagged_trees,
    seed_residual_classification,
    seed_sensor_faults,
    seed_sensor_table,
)

__all__ = ["run_seed_study", "seed_comparison", "seed_ensemble_parts"]


# --------------------------------------------------------------------------- report
def seed_comparison(
    results: Sequence[SeedResult] | Mapping[str, SeedResult],
) -> pd.DataFrame:
    """The report table: the seed's number | pdmkit on the twin | why they differ.

    Parameters
    ----------
    results : sequence or mapping of SeedResult
        Results of the ``seed_*`` recipes.

    Returns
    -------
    pandas.DataFrame
        Columns ``recipe, section, metric, seed, pdmkit, difference, why``.

    Examples
    --------
    >>> from pdmkit.experiments.thesis import SeedResult, seed_comparison
    >>> r = SeedResult("flow_knn", "7.3.4, table 7.2", "accuracy %", 97.52, 93.1, "twin")
    >>> seed_comparison([r])[["seed", "pdmkit", "difference"]].iloc[0].tolist()
    [97.52, 93.1, -4.42]
    """
    items = list(results.values()) if isinstance(results, Mapping) else list(results)
    bad = [type(r).__name__ for r in items if not isinstance(r, SeedResult)]
    if bad:
        raise DataError(f"results must hold SeedResult objects; got {bad}")
    return pd.DataFrame(
        [
            {
                "recipe": r.recipe,
                "section": r.section,
                "metric": r.metric,
                "seed": r.seed,
                "pdmkit": r.pdmkit,
                "difference": r.difference,
                "why": r.why,
            }
            for r in items
        ],
        columns=["recipe", "section", "metric", "seed", "pdmkit", "difference", "why"],
    )


def seed_ensemble_parts(n_members: int, *, part_size: int = 242, **options):
    """The seed data set simulated part by part, so memory holds one part's recordings.

    Each part is :func:`pdmkit.ensembles.simulate_seed_ensemble` of the whole design
    (``n_members`` and ``options``) restricted to ``part_size`` consecutive members;
    parts made of whole ``batch_size`` blocks record exactly what the whole ensemble
    records, so ``batch_size`` is ``part_size``.

    Parameters
    ----------
    n_members : int
        Size of the whole data set.
    part_size : int, default 242
        Members per part.
    **options
        Passed to :func:`pdmkit.ensembles.simulate_seed_ensemble`.

    Yields
    ------
    Ensemble

    Examples
    --------
    >>> from pdmkit.experiments._seed_study import seed_ensemble_parts
    >>> parts = seed_ensemble_parts(40, part_size=25, t_end=0.2,
    ...                             signals=["FlowContraction"])
    >>> [len(p) for p in parts]
    [25, 15]
    """
    starts = range(0, n_members, part_size)
    for start in progress(starts, desc="seed data set", total=len(starts)):
        yield simulate_seed_ensemble(
            n_members,
            batch_size=part_size,
            members=slice(start, min(start + part_size, n_members)),
            **options,
        )


def run_seed_study(
    n_members: int = 4840,
    *,
    repeats: int = 20,
    variation: str = "rig",
    jitter: float | None = None,
    part_size: int = 242,
    leak_runs: int = 25,
    leak_max_cycles: int = 200,
    sensor_fault_members: int = 150,
    t_end: float = 10.0,
    split: str = "seed",
    seed: int = 0,
    test_cycle: str = "twin",
    rig: str = "seed",
) -> dict[str, Any]:
    """The whole seed study on the twin: data set, every recipe, the sensor table.

    The seed ensemble (:func:`pdmkit.ensembles.simulate_seed_ensemble`) is simulated
    ``part_size`` members at a time and reduced to :func:`seed_feature_table` at once,
    so memory stays at one part's recordings (15 signals of 10 s at 1 kHz: 1.2 MB a
    member, 290 MB for 242); then every recipe runs on the table.

    Parameters
    ----------
    n_members : int, default 4840
        The seed's data set size.
    repeats, variation, jitter
        As :func:`pdmkit.ensembles.simulate_seed_ensemble` (``jitter=None``: its
        default).
    part_size : int, default 242
        Members simulated at once.
    leak_runs, leak_max_cycles
        :func:`seed_air_leak_rul`'s ``n_runs`` and ``max_cycles``; ``leak_runs=0``
        skips it.
    sensor_fault_members : int, default 150
        :func:`seed_sensor_faults`' members; 0 skips it.
    t_end : float, default 10.0
    split : {"seed", "code"}, default "seed"
    seed : int, default 0
    test_cycle : {"twin", "seed_rig"}, default "twin"
        The valve program of every recording
        (:func:`pdmkit.ensembles.simulate_seed_ensemble`).
    rig : {"seed", "twin"}, default "seed"
        The machine that records both data sets and the residuals' reference: the
        seed rig's identified one, or the generic twin.

    Returns
    -------
    dict
        ``results`` (SeedResult per recipe), ``comparison`` (:func:`seed_comparison`),
        ``sensors`` (:func:`seed_sensor_table`), ``table`` (the indicators) and
        ``seconds`` per stage.

    Examples
    --------
    >>> from pdmkit.experiments.thesis import run_seed_study
    >>> out = run_seed_study(40, repeats=2, t_end=1.0, leak_runs=0,
    ...                      sensor_fault_members=0, part_size=20)
    >>> out["comparison"]["recipe"].tolist()
    ['flow_knn', 'flow_bagged_trees', 'flow_pca_bagged_trees', 'residual_classification']
    """
    seconds: dict[str, float] = {}
    started = time.perf_counter()
    parts = [
        seed_feature_table(ens)
        for ens in seed_ensemble_parts(
            int(n_members),
            part_size=int(part_size),
            repeats=repeats,
            variation=variation,
            **({} if jitter is None else {"jitter": jitter}),
            t_end=t_end,
            seed=seed,
            test_cycle=test_cycle,
            rig=rig,
        )
    ]
    table = pd.concat(parts)
    seconds["simulate_and_indicators"] = round(time.perf_counter() - started, 1)
    results: dict[str, SeedResult] = {}
    stage = time.perf_counter()
    results["flow_knn"] = seed_flow_knn(table, split=split, seed=seed)
    results["flow_bagged_trees"] = seed_flow_bagged_trees(table, split=split, seed=seed)
    results["flow_pca_bagged_trees"] = seed_flow_pca_bagged_trees(
        table, split=split, seed=seed
    )
    # the seed's residual study has its own, smaller data set (8.2.1, 8.3)
    results["residual_classification"] = seed_residual_classification(
        split=split, t_end=t_end, seed=seed, test_cycle=test_cycle, rig=rig
    )
    sensors = seed_sensor_table(table, split=split, seed=seed)
    seconds["classification"] = round(time.perf_counter() - stage, 1)
    if sensor_fault_members:
        stage = time.perf_counter()
        results["sensor_faults"] = seed_sensor_faults(
            int(sensor_fault_members), t_end=t_end, seed=seed
        )
        seconds["sensor_faults"] = round(time.perf_counter() - stage, 1)
    if leak_runs:
        stage = time.perf_counter()
        results["air_leak_rul"] = seed_air_leak_rul(
            int(leak_runs), max_cycles=int(leak_max_cycles), t_end=t_end, seed=seed
        )
        seconds["air_leak_rul"] = round(time.perf_counter() - stage, 1)
    seconds["total"] = round(time.perf_counter() - started, 1)
    return {
        "results": results,
        "comparison": seed_comparison(results),
        "sensors": sensors,
        "table": table,
        "seconds": seconds,
        "settings": {
            "n_members": int(n_members),
            "repeats": int(repeats),
            "variation": variation,
            "jitter": jitter,
            "split": split,
            "seed": int(seed),
            "t_end": float(t_end),
            "test_cycle": test_cycle,
            "rig": rig,
        },
    }
