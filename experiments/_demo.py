"""``pdmkit demo``: the whole workbench on the simulated pneumatic piston.

The seed thesis (001, chapters 7-8) runs the predictive-maintenance workflow on a
measured pneumatic piston; its recordings are not public, so the demo runs the same
workflow on pdmkit's digital twin of that rig:

1. simulate a labelled fault ensemble (throttle valves, small and large dampers and
   their pairwise combinations: 16 fault codes) at random operating points;
2. extract statistical, spectral and per-stroke cycle indicators
   (:func:`pdmkit.features.cycle_features`) from all fifteen sensor signals and rank
   them (Kruskal-Wallis);
3. train and evaluate the seed's classifiers (kNN and bagged trees on the top-5
   indicators);
4. compare the eight sensor types by accuracy and cost (seed table 9.1), each with an
   operating-point-aware random forest (:func:`operating_point_forest`: the operator
   knows the load and the supply pressure);
5. classify from residuals against the nominal model (seed 8.3) next to the raw
   encoder position: the seed's residual signal, and the encoder's indicators scored
   against the healthy twin at each member's operating point
   (:func:`reference_zscores`);
6. classify simulated sensor faults (seed 8.1);
7. estimate the remaining useful life of air-leak run-to-failure units (seed 8.4) with
   a linear degradation model (:func:`pdmkit.experiments._rul.run_rul` on
   ``"pneumatic-leak"``, a small setting: 8 training and 4 test units).

It writes ``summary.json`` (machine-readable), ``report.html``, ``features.parquet``
and the RUL step's files (``rul/``) into the output folder, all at once, beside whatever
the folder already holds (:mod:`pdmkit._outputs`).
"""

from __future__ import annotations

import platform
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils.validation import check_is_fitted

from pdmkit.errors import DataError

__all__ = [
    "OperatingPointScaler",
    "add_operating_point",
    "compare_residuals",
    "operating_point_forest",
    "reference_zscores",
    "run_demo",
    "twin_cycle_options",
]

#: Name of the pseudo-signal that carries the operating point in a feature table.
OPERATING = "Operating"


def _step(message: str) -> Callable[[], float]:
    """Print a progress line; return a function giving the seconds since."""
    print(f"pdmkit demo: {message} ...", file=sys.stderr, flush=True)
    start = time.perf_counter()
    return lambda: time.perf_counter() - start


def _feature_columns(table, prefix: str | tuple[str, ...]) -> list[str]:
    """Indicator columns of the given signals that are finite for every member.

    A spectrum with fewer than five peaks leaves ``PeakAmp5`` undefined (NaN), the
    skewness of a constant signal too: such columns cannot feed a classifier and are
    left out.
    """
    columns = [c for c in table.columns if "/" in str(c) and str(c).startswith(prefix)]
    finite = np.isfinite(table[columns].to_numpy(dtype=float)).all(axis=0)
    return [c for c, ok in zip(columns, finite, strict=True) if ok]


# --------------------------------------------------------------------------- reusable
def twin_cycle_options(params=None) -> dict:
    """Cycle-group options matching the twin's valve command.

    Parameters
    ----------
    params : PneumaticParams, optional
        Twin parameters (default ``PneumaticParams()``).

    Returns
    -------
    dict
        ``{"cycle_period": ..., "cycle_start": ...}`` for
        :func:`pdmkit.features.extract` / ``extract_ensemble`` with group ``"cycle"``:
        a cycle is one up and one down command, the first up command at
        ``cycle_start``; segment ``S1`` is the up stroke, ``S2`` the down stroke.

    Examples
    --------
    >>> from pdmkit.experiments._demo import twin_cycle_options
    >>> twin_cycle_options()
    {'cycle_period': 2.0, 'cycle_start': 0.1}
    """
    from pdmkit.models import PneumaticParams

    p = PneumaticParams() if params is None else params
    if float(np.asarray(p.cycle_duty).mean()) != 0.5:
        raise ValueError(
            f"twin_cycle_options assumes cycle_duty 0.5 (segments at phases 0 and 0.5); "
            f"got {p.cycle_duty!r}: pass cycle_phases=(0.0, duty) yourself"
        )
    return {"cycle_period": float(p.cycle_period), "cycle_start": float(p.cycle_start)}


class OperatingPointScaler(TransformerMixin, BaseEstimator):
    """Standardise condition indicators within each operating point.

    Load and supply pressure move most indicators of a machine more than many faults
    do (an impact of a 6.75 kg piston carries 13 times the energy of a 0.5 kg one). The
    operator knows the operating point, so it can be taken out: ``fit`` learns, for
    every operating point met in the training data, the mean and standard deviation of
    each indicator over its training members (all classes; no labels are used), and
    ``transform`` puts every member in the units of its own operating point. The
    operating-point columns pass through unchanged, so a model after this step can
    still use them.

    Parameters
    ----------
    columns : sequence of int, default (0, 1)
        Positions of the operating-point columns in ``X`` (e.g. load and supply).
    min_members : int, default 5
        An operating point with fewer training members, or one never met in training,
        is scaled with the statistics of all training members instead.

    Attributes
    ----------
    points_ : numpy.ndarray
        The operating points met in training, one row each.
    mean_, scale_ : numpy.ndarray
        Per point and indicator, shape ``(n_points, n_features)`` (the operating-point
        columns get mean 0 and scale 1).
    global_mean_, global_scale_ : numpy.ndarray
        Over all training members, the fallback.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.experiments._demo import OperatingPointScaler
    >>> load = np.repeat([0.0, 5.0], 6)
    >>> impact = np.tile([1.0, 2.0, 3.0], 4) * (1 + 9 * (load > 0))  # 10x at 5 kg
    >>> X = np.column_stack([load, impact])
    >>> Z = OperatingPointScaler(columns=[0], min_members=3).fit_transform(X)
    >>> Z[:3, 1].round(3).tolist(), Z[6:9, 1].round(3).tolist(), Z[:2, 0].tolist()
    ([-1.225, 0.0, 1.225], [-1.225, 0.0, 1.225], [0.0, 0.0])
    """

    def __init__(self, columns: Sequence[int] = (0, 1), min_members: int = 5):
        self.columns = columns
        self.min_members = min_members

    def _split(self, X):
        X = np.asarray(X, dtype=float)
        if X.ndim != 2:
            raise DataError(f"X must be 2-D (members, columns); got shape {X.shape}")
        cols = np.asarray(self.columns, dtype=int).reshape(-1)
        if cols.size == 0 or np.any(cols < -X.shape[1]) or np.any(cols >= X.shape[1]):
            raise ValueError(
                f"OperatingPointScaler.columns={self.columns!r} must name operating-point "
                f"columns among the {X.shape[1]} columns of X"
            )
        return X, cols % X.shape[1]

    def fit(self, X, y=None):
        """Learn the per-point statistics; ``y`` is ignored."""
        X, cols = self._split(X)
        if isinstance(self.min_members, bool) or int(self.min_members) < 2:
            raise ValueError(
                f"min_members must be an integer >= 2; got {self.min_members!r}"
            )
        if not np.all(np.isfinite(X)):
            raise DataError("X holds NaN or infinite values; clean the indicators first")
        points, inverse = np.unique(X[:, cols], axis=0, return_inverse=True)
        inverse = np.asarray(inverse).reshape(-1)
        self.global_mean_ = X.mean(axis=0)
        self.global_scale_ = _safe_scale(X.std(axis=0))
        mean = np.tile(self.global_mean_, (len(points), 1))
        scale = np.tile(self.global_scale_, (len(points), 1))
        for g in range(len(points)):
            rows = X[inverse == g]
            if len(rows) >= int(self.min_members):
                mean[g] = rows.mean(axis=0)
                scale[g] = _safe_scale(rows.std(axis=0))
        for arr in (mean, scale, self.global_mean_, self.global_scale_):
            arr[..., cols] = 0.0 if arr is mean or arr is self.global_mean_ else 1.0
        self.points_, self.mean_, self.scale_ = points, mean, scale
        self.n_features_in_ = X.shape[1]
        return self

    def transform(self, X):
        """Indicators in units of each member's operating point."""
        check_is_fitted(self, "mean_")
        X, cols = self._split(X)
        if X.shape[1] != self.n_features_in_:
            raise DataError(
                f"X has {X.shape[1]} columns; the scaler was fitted on "
                f"{self.n_features_in_}"
            )
        mean = np.tile(self.global_mean_, (len(X), 1))
        scale = np.tile(self.global_scale_, (len(X), 1))
        key = X[:, cols]
        for g, point in enumerate(self.points_):
            rows = np.all(key == point, axis=1)
            mean[rows] = self.mean_[g]
            scale[rows] = self.scale_[g]
        return (X - mean) / scale


def _safe_scale(std: np.ndarray) -> np.ndarray:
    return np.where(std > 1e-12 * (np.abs(std).max(initial=0.0) + 1e-300), std, 1.0)


def operating_point_forest(
    n_estimators: int = 300,
    *,
    scale: bool = True,
    max_features: float | str = 0.3,
    columns: Sequence[int] = (0, 1),
    random_state: int | None = 0,
    n_jobs: int | None = -1,
):
    """A random forest on indicators standardised per operating point.

    ``Pipeline([("operating_point", OperatingPointScaler(columns)), ("forest",
    RandomForestClassifier(n_estimators, max_features=max_features))])``: the
    classifier the demo and ``benchmarks/twin_classification.py`` use for each sensor.
    It expects the operating-point columns at ``columns`` of ``X`` (see
    :func:`add_operating_point`). Trees need no feature ranking in front: give it all
    of a sensor's indicators. With ``scale=False`` the scaler step is left out and the
    forest gets the operating point as two plain inputs.

    Parameters
    ----------
    n_estimators : int, default 300
        Trees.
    scale : bool, default True
        Standardise the indicators per operating point first.
    max_features : float or str, default 0.3
        Fraction of the indicators each split looks at (0.3 cross-validated better than
        ``"sqrt"`` on the development ensemble, seed 1, training part only).
    columns : sequence of int, default (0, 1)
        Positions of the operating-point columns.
    random_state : int or None, default 0
    n_jobs : int or None, default -1
        Cores for the forest.

    Returns
    -------
    sklearn.pipeline.Pipeline

    Examples
    --------
    >>> from pdmkit.experiments._demo import operating_point_forest
    >>> [name for name, _ in operating_point_forest(50).steps]
    ['operating_point', 'forest']
    >>> [name for name, _ in operating_point_forest(50, scale=False).steps]
    ['forest']
    """
    from sklearn.ensemble import RandomForestClassifier
    from sklearn.pipeline import Pipeline

    forest = RandomForestClassifier(
        n_estimators=n_estimators,
        max_features=max_features,
        random_state=random_state,
        n_jobs=n_jobs,
    )
    steps = [("operating_point", OperatingPointScaler(columns=columns))] if scale else []
    return Pipeline([*steps, ("forest", forest)])


def add_operating_point(
    table: pd.DataFrame,
    columns: Sequence[str] = ("load_kg", "supply_bar"),
    name: str = OPERATING,
) -> pd.DataFrame:
    """Copy the operating-point conditions into feature columns of a pseudo-signal.

    ``load_kg`` becomes ``Operating/condition/load_kg`` and so on, so that a sensor
    given the signals ``("Operating", ...)`` in :func:`pdmkit.experiments.compare_sensors`
    sees the operating point as its first columns (what
    :func:`operating_point_forest` expects).

    Parameters
    ----------
    table : pandas.DataFrame
        Feature table with the condition columns.
    columns : sequence of str
        The operating-point condition columns.
    name : str
        Name of the pseudo-signal.

    Returns
    -------
    pandas.DataFrame
        A copy with the new columns in front of the indicators.

    Examples
    --------
    >>> import pandas as pd
    >>> from pdmkit.experiments._demo import add_operating_point
    >>> t = pd.DataFrame({"load_kg": [0.0, 5.0], "supply_bar": [5.0, 6.0],
    ...                   "x/stats/RMS": [1.0, 2.0]})
    >>> list(add_operating_point(t).columns)  # doctest: +NORMALIZE_WHITESPACE
    ['load_kg', 'supply_bar', 'Operating/condition/load_kg',
     'Operating/condition/supply_bar', 'x/stats/RMS']
    """
    missing = [c for c in columns if c not in table.columns]
    if missing:
        raise DataError(
            f"the table has no operating-point column(s) {missing}; its conditions are "
            f"{[c for c in table.columns if '/' not in str(c)]}"
        )
    conditions = [c for c in table.columns if "/" not in str(c)]
    rest = [c for c in table.columns if "/" in str(c)]
    extra = pd.DataFrame(
        {f"{name}/condition/{c}": table[c].astype(float) for c in columns},
        index=table.index,
    )
    return pd.concat([table[conditions], extra, table[rest]], axis=1)


def reference_zscores(
    table: pd.DataFrame,
    reference: pd.DataFrame,
    features: Sequence[str],
    by: Sequence[str] = ("load_kg", "supply_bar"),
    suffix: str = "_z",
) -> pd.DataFrame:
    """Indicator residuals: each indicator in standard deviations of a healthy reference.

    For every member, ``(x - mean_ref) / std_ref`` per indicator, with the mean and
    standard deviation of the reference members at the member's operating point (the
    conditions ``by``). With a reference simulated by the healthy twin, this is the
    residual of each condition indicator against the model (seed 8.3 forms the residual
    of the signal; here it is formed after the indicators are extracted), scaled by the
    spread the model expects from healthy variation alone.

    Parameters
    ----------
    table : pandas.DataFrame
        Feature table with the ``by`` conditions.
    reference : pandas.DataFrame
        Feature table of healthy reference members with the same indicator columns and
        ``by`` conditions; at least 2 members at every operating point of ``table``.
    features : sequence of str
        Indicator columns to score.
    by : sequence of str
        Operating-point conditions.
    suffix : str
        Appended to the signal name of each column (``LeverPosition/cycle/S1_T50``
        becomes ``LeverPosition_z/cycle/S1_T50``).

    Returns
    -------
    pandas.DataFrame
        The conditions of ``table`` and the scored indicators.

    Examples
    --------
    >>> import pandas as pd
    >>> from pdmkit.experiments._demo import reference_zscores
    >>> ref = pd.DataFrame({"load_kg": [0.0, 0.0, 5.0, 5.0], "supply_bar": [5.0] * 4,
    ...                     "x/cycle/T50": [0.10, 0.12, 0.20, 0.24]})
    >>> t = pd.DataFrame({"load_kg": [0.0, 5.0], "supply_bar": [5.0, 5.0],
    ...                   "x/cycle/T50": [0.13, 0.22]})
    >>> reference_zscores(t, ref, ["x/cycle/T50"])["x_z/cycle/T50"].round(3).tolist()
    [2.0, 0.0]
    """
    by = list(by)
    for name, frame in (("table", table), ("reference", reference)):
        missing = [c for c in [*by, *features] if c not in frame.columns]
        if missing:
            raise DataError(f"{name} lacks the column(s) {missing}")
    groups = reference.groupby(by)[list(features)]
    mean, std, count = groups.mean(), groups.std(ddof=0), groups.size()
    key = pd.MultiIndex.from_frame(table[by])
    rows = pd.MultiIndex.from_frame(mean.reset_index()[by]).get_indexer(key)
    if np.any(rows < 0) or np.any(count.to_numpy()[rows] < 2):
        bad = table.loc[(rows < 0) | (count.reindex(key).fillna(0).to_numpy() < 2), by]
        raise DataError(
            "the reference has fewer than 2 members at operating point(s) "
            f"{bad.drop_duplicates().to_dict('records')[:5]}; simulate the reference at "
            "every operating point of the table"
        )
    mu = mean.to_numpy()[rows]
    sd = std.to_numpy()[rows]
    z = (table[list(features)].to_numpy(dtype=float) - mu) / _safe_scale_rows(sd)
    names = []
    for c in features:
        head, _, rest = str(c).partition("/")
        names.append(f"{head}{suffix}/{rest}" if rest else f"{head}{suffix}")
    scored = pd.DataFrame(z, index=table.index, columns=names)
    conditions = [c for c in table.columns if "/" not in str(c)]
    return pd.concat([table[conditions], scored], axis=1)


def _safe_scale_rows(sd: np.ndarray) -> np.ndarray:
    """A reference spread of zero (a constant indicator) scales by 1 instead."""
    return np.where(np.isfinite(sd) & (sd > 0), sd, 1.0)


def _forest_top(result, k: int = 5) -> list[str]:
    """The k indicators the fitted forest of a classify result leans on most."""
    model = result.pipeline.named_steps["model"]
    forest = model.named_steps["forest"] if hasattr(model, "named_steps") else model
    weights = getattr(forest, "feature_importances_", None)
    names = list(result.input_features)
    if weights is None or len(weights) != len(names):
        return names[:k]
    order = np.argsort(-np.asarray(weights), kind="stable")
    return [names[i] for i in order if not names[i].startswith(f"{OPERATING}/")][:k]


# --------------------------------------------------------------------------- workflow
def run_demo(
    out_dir: str | Path = "results/demo",
    *,
    members: int | None = None,
    seed: int = 0,
    recording_s: float = 10.0,
    json_path: str | Path | None = None,
) -> dict:
    """Run the demo workflow and write ``summary.json`` and ``report.html``.

    Parameters
    ----------
    out_dir : str or Path
        Output folder (created when missing). Receives ``summary.json``,
        ``report.html``, ``features.parquet`` and ``rul/`` (the RUL step's report,
        predictions, JSON and model), all at once when everything succeeded; anything
        else in the folder is left as it is.
    members : int, optional
        Size of the simulated fault ensemble (default 640: 40 recordings of each of
        the 16 fault codes, healthy, five single faults and their ten pairs). At least
        64 (a test split needs one member of each code); below 320 the forests are
        smaller (quick checks).
    seed : int, default 0
        Seed of the simulation and of the data splits.
    recording_s : float, default 10.0
        Length of each simulated recording in s (the seed's are 10 s; shorter runs
        are for quick checks).
    json_path : str or Path, optional
        Also write the summary here.

    Returns
    -------
    dict
        The summary written to ``summary.json``.

    Examples
    --------
    >>> import tempfile
    >>> from pdmkit.experiments._demo import run_demo
    >>> summary = run_demo(tempfile.mkdtemp(), members=64, seed=1)  # doctest: +SKIP
    >>> sorted(summary)  # doctest: +SKIP
    ['classification', 'residuals', 'rul', 'sensor_faults', 'sensors', 'timing_s', ...]
    """
    from pdmkit._outputs import OutputRun

    n_members = int(members) if members is not None else 640
    if n_members < 64:
        raise DataError(
            f"members={n_members} is too few for the 16 fault codes: the 25 % test split "
            "needs one member of each code and training at least two; use 64 or more"
        )
    with OutputRun(out_dir, "demo", json_path=json_path) as run:
        summary = _demo(run, n_members, seed, recording_s)
        run.commit()
    return summary


def _demo(run, n_members: int, seed: int, recording_s: float) -> dict:
    """:func:`run_demo` with its files registered with ``run`` (not yet written)."""
    from pdmkit.ensembles import (
        PNEUMATIC_SENSORS,
        simulate_fault_ensemble,
        simulate_sensor_fault_ensemble,
    )
    from pdmkit.experiments._classify import classify
    from pdmkit.experiments._demo_mismatch import add_mismatch_section, demo_mismatch_cases
    from pdmkit.experiments._report import Report
    from pdmkit.experiments._sensors import SensorComparison, compare_sensors
    from pdmkit.features import extract_ensemble, rank_features

    cycle = twin_cycle_options()
    groups = ("stats", "spectral", "cycle")
    trees = 150 if n_members >= 320 else 50  # small ensembles are quick checks
    timing: dict[str, float] = {}
    report = Report("pdmkit demo: predictive maintenance of a pneumatic piston (simulated)")
    report.add_text(
        "The workflow of the seed thesis (Predictive maintenance of pneumatic pistons, "
        "chapters 7-8) on pdmkit's digital twin of its rig: a double-acting vertical "
        "piston with throttle valves, adjustable small end dampers, static large dampers, "
        "load masses of 0-6.25 kg and 5 or 6 bar supply, recorded 10 s at 1 kHz by the "
        "fifteen sensors of the seed's table 3.1. All data on this page are simulated."
    )

    # 1. fault ensemble --------------------------------------------------------------
    elapsed = _step(
        f"simulating {n_members} recordings of the twin ({recording_s:g} s, 15 sensors, "
        "16 fault codes)"
    )
    ensemble = simulate_fault_ensemble(
        n_members, max_faults=2, seed=seed, t_end=recording_s
    )
    timing["simulate"] = elapsed()
    counts = ensemble.conditions["fault"].value_counts().sort_index()

    # 2. indicators and ranking --------------------------------------------------------
    elapsed = _step("extracting condition indicators")
    table = extract_ensemble(ensemble, groups=groups, **cycle)
    table = add_operating_point(table)
    run.add_parquet("features.parquet", table.copy())
    features = _feature_columns(table, tuple(ensemble.signal_names))
    ranking = rank_features(table, table["fault"], method="kruskal", features=features)
    timing["features"] = elapsed()

    report.add_heading("1. Simulated fault ensemble")
    report.add_table(
        counts.rename("recordings").to_frame(), caption="Recordings per fault code"
    )
    report.add_figure(_example_figure(ensemble), caption="One recording per fault code")
    report.add_heading("2. Condition indicators, ranked")
    report.add_text(
        f"{len(features)} indicators of the fifteen signals: whole-recording statistics "
        "and Welch-spectrum features (the seed's), and per-stroke cycle indicators "
        "(stroke times, the speed on passing points ever closer to each end, the speed "
        "the end dampers take out, bounces, impact peaks and their ring-down), ranked by "
        "the Kruskal-Wallis statistic against the fault code."
    )
    report.add_figure(ranking.plot(k=20), caption="Top 20 indicators (Kruskal-Wallis)")
    report.add_figure(
        _damper_figure(table),
        caption="Encoder position, up stroke: speed passing 8 mm and 3.2 mm before the "
        "top (cycle indicators Rate95 and Rate98) by upper-damper setting; the damper "
        "takes out the difference",
    )

    # 3. classifiers -------------------------------------------------------------------
    elapsed = _step("training fault classifiers")
    report.add_text(
        "The seed's recipe (section 7.3): kNN and bagged trees on the five best-ranked "
        "indicators of all sensors. Five indicators cannot span five independent faults "
        "at two stroke ends, so with all 16 codes it stays far below pdmkit's default "
        "for this machine: a random forest on all indicators standardised per "
        "operating point (load and supply, which the operator knows), shown last."
    )
    classification = {}
    operating = _feature_columns(table, f"{OPERATING}/")
    for model in ("knn", "bagged_trees"):  # the seed's recipe
        result = classify(
            table, "fault", features=features, model=model, top_k=5, random_state=seed
        )
        classification[model] = scores = result.summary()
        used = f"the top-5 indicators {', '.join(scores['features'])}"
        report.add_figure(
            result.plot(),
            caption=f"{model}: held-out accuracy {scores['accuracy']:.3f} on {used}",
        )
    forest = operating_point_forest(trees, random_state=seed)
    result = classify(
        table,
        "fault",
        features=[*operating, *features],
        model=forest,
        selection=None,
        cv=None,
        random_state=seed,
    )
    scores = result.summary()
    scores["features"] = _forest_top(result)  # all are inputs: name the five it uses most
    classification["operating_point_forest"] = scores
    report.add_figure(
        result.plot(),
        caption=f"operating_point_forest: held-out accuracy {scores['accuracy']:.3f} "
        f"on all {len(features)} indicators and the operating point",
    )
    timing["classify"] = elapsed()

    # 4. sensors ------------------------------------------------------------------------
    elapsed = _step("comparing the eight sensor types")
    sensors = {name: (OPERATING, *signals) for name, signals in PNEUMATIC_SENSORS.items()}
    comparison = compare_sensors(
        table[[*operating, *features, "fault"]],
        "fault",
        sensors,
        model=forest,
        selection=None,
        cv=3,
        random_state=seed,
    )
    comparison = _with_forest_features(comparison, SensorComparison)
    timing["sensors"] = elapsed()
    report.add_heading("3. Sensors by accuracy and cost")
    report.add_text(
        "Each sensor type is scored on all its own indicators plus the operating point "
        "(load and supply, which the operator knows) with a random forest on indicators "
        "standardised per operating point (3-fold cross-validation, and a 25 % held-out "
        "split). Costs are the seed's table 9.1 (CZK); the temperature sensors have no "
        "cost there."
    )
    report.add_figure(comparison.plot(), caption="Accuracy against cost; Pareto front")
    report.add_table(
        comparison.to_pandas().drop(columns=["note"]),
        caption="Sensor comparison (features: the five the forest leans on most)",
    )

    # 5. residuals against the nominal model --------------------------------------------
    elapsed = _step("classifying from residuals against the nominal model")
    results, residuals, reference = compare_residuals(
        ensemble, table, groups=groups, n_estimators=trees, seed=seed
    )
    residual_summary = _residual_summary(results, "LeverPosition", len(reference))
    timing["residuals"] = elapsed()
    scaled = residual_summary["per_point_standardised"]
    report.add_heading("4. Residuals against the nominal model (seed 8.3)")
    report.add_text(
        "Encoder position, 25 % held out, a random forest with the operating point as "
        "input: raw-signal indicators "
        f"{residual_summary['accuracy_signal']:.3f}; indicators of the seed's residual "
        "signal (position minus the healthy twin at the member's load and supply) "
        f"{residual_summary['accuracy_residual_signal']:.3f}; indicator residuals "
        "(each indicator in standard deviations of "
        f"{residual_summary['reference_members']} healthy twin runs at the members' "
        f"operating points) {residual_summary['accuracy_residual']:.3f}. With the "
        "indicators standardised per operating point from the training data instead "
        f"(the sensor table's classifier): {scaled['accuracy_signal']:.3f}, "
        f"{scaled['accuracy_residual_signal']:.3f} and "
        f"{scaled['accuracy_residual']:.3f}; indicator residuals and raw indicators "
        "then differ only by an affine map per operating point, which that "
        "standardisation undoes."
    )
    report.add_figure(_residual_figure(residuals), caption="Position residuals by fault")

    # 6. sensor faults ------------------------------------------------------------------
    elapsed = _step("classifying simulated sensor faults")
    sensor_faults = simulate_sensor_fault_ensemble(
        max(50, n_members // 4), seed=seed + 7, t_end=recording_s
    )
    sf_table = extract_ensemble(sensor_faults, groups=("stats",))
    sf_result = classify(sf_table, "sensor_fault", model="knn", top_k=5, random_state=seed)
    timing["sensor_faults"] = elapsed()
    report.add_heading("5. Sensor faults (seed 8.1)")
    report.add_figure(
        sf_result.plot(),
        caption=f"Flow sensor healthy / noisy / offset / drifting / lost: held-out "
        f"accuracy {sf_result.summary()['accuracy']:.3f}",
    )

    # 7. air-leak RUL -------------------------------------------------------------------
    elapsed = _step(
        f"estimating the RUL of {_RUL_UNITS[0] + _RUL_UNITS[1]} air-leak units "
        "(linear degradation)"
    )
    rul_summary, rul_figure = _air_leak_rul(run.view("rul"), seed, recording_s)
    timing["rul"] = elapsed()
    acc = rul_summary["within_10pct"]
    report.add_heading("6. Remaining useful life of a leaking chamber (seed 8.4)")
    report.add_text(
        f"{_RUL_UNITS[0]} training and {_RUL_UNITS[1]} test units of the twin with a "
        "chamber-B air leak growing from 1e-10 to 1e-6 m^2 along unit-specific random "
        f"walks, one {recording_s:g} s recording per cycle. Indicator (best of the "
        "candidates by monotonicity, trendability and prognosability on the training "
        f"units): {rul_summary['indicator']}; the seed's flow shape factor ranks "
        f"{rul_summary['seed_indicator']['rank']}. A linear degradation model with "
        "Bayesian updating follows each test unit through its life. Over the last half "
        f"of life: MAE {rul_summary['mae']:.2f} cycles, RMSE {rul_summary['rmse']:.2f}; "
        f"test units with every prediction within 10 % of their life "
        f"{acc['of_life']:.2f}, with the mean error within 10 % of life "
        f"{acc['mean_of_life']:.2f}, with every prediction within 10 % of the true RUL "
        f"{acc['of_rul']:.2f}. The full RUL report is rul/report.html; "
        "`pdmkit rul --dataset pneumatic-leak` runs the larger setting."
    )
    report.add_figure(
        rul_figure,
        caption="Predicted (solid) and true (dashed) RUL of the test units, the model's "
        "90 % interval dotted; shaded: within 10 % of the unit's life over its last half",
    )

    # 8. mismatch discovery --------------------------------------------------------------
    elapsed = _step("discovering what a model file left out (mismatch)")
    # quick checks (small ensembles) leave the real-data case out
    mismatch_cases = demo_mismatch_cases(seed, real_data=None if trees > 50 else False)
    timing["mismatch"] = elapsed()
    add_mismatch_section(report, mismatch_cases, 7)

    sensor_rows = comparison.summary()["sensors"]
    best = max(
        (r for r in sensor_rows if r["heldout_accuracy"] is not None),
        key=lambda r: r["heldout_accuracy"],
        default=None,
    )
    summary = {
        "members": n_members,
        "recording_s": recording_s,
        "labels": sorted(counts.index.tolist()),
        "n_features": len(features),
        "feature_groups": list(groups),
        "top_features": ranking.top(5),
        "classification": classification,
        "sensors": sensor_rows,
        "sensor_model": f"operating_point_forest({trees}): OperatingPointScaler + "
        "RandomForestClassifier(max_features=0.3), 3-fold CV + 25 % held out",
        "best_sensor": None
        if best is None
        else {"sensor": best["sensor"], "heldout_accuracy": best["heldout_accuracy"]},
        "residuals": residual_summary,
        "sensor_faults": sf_result.summary(),
        "rul": rul_summary,
        "mismatch": [c.summary() for c in mismatch_cases],
        "timing_s": {k: round(v, 2) for k, v in timing.items()},
        "environment": {"python": platform.python_version(), "seed": seed},
    }
    summary["timing_s"]["total"] = round(sum(timing.values()), 2)
    report.add_heading("Summary")
    report.add_json(summary["timing_s"], caption="Time per step (s)")
    run.add_report("report.html", report)
    run.add_json("summary.json", summary)
    return summary


#: Training and test units of the demo's air-leak RUL step, and their longest life.
_RUL_UNITS = (8, 4)
_RUL_MAX_CYCLES = 40


def _air_leak_rul(sink, seed: int, recording_s: float):
    """The demo's RUL step: (summary, trajectory figure); its files go to ``sink``."""
    from pdmkit.experiments._rul import _rul, _trajectory_plot

    full = _rul(
        sink,
        "pneumatic-leak",
        "linear-degradation",
        seed,
        features=None,
        rul_cap=125.0,
        options=None,
        n_trajectories=_RUL_UNITS[1],
        dataset_options={
            "n_train": _RUL_UNITS[0],
            "n_test": _RUL_UNITS[1],
            "max_cycles": _RUL_MAX_CYCLES,
            "t_end": float(recording_s),
        },
        calibrate=False,
    )
    table = sink.frame("predictions.parquet")
    figure = _trajectory_plot(table, list(pd.unique(table["unit"])))
    keys = (
        "model",
        "indicator",
        "n_train_units",
        "n_units",
        "n_predictions",
        "rmse",
        "mae",
        "phm08_score",
        "coverage",
        "within_10pct",
        "seed_indicator",
        "simulation",
    )
    summary = {k: full[k] for k in keys}
    summary["true_leak_within_10pct"] = full["true_leak"]["within_10pct"]
    summary["report"] = str(sink.path("report.html"))
    return summary, figure


def _with_forest_features(comparison, cls):
    """Replace each sensor's feature list (all its indicators) by the forest's top 5."""
    frame = comparison.table.copy()
    for i, sensor in enumerate(frame["sensor"]):
        result = comparison.results.get(str(sensor))
        if result is not None:
            frame.loc[i, "features"] = "; ".join(_forest_top(result))
    return cls(
        frame.drop(columns=["pareto"]),
        results=comparison.results,
        label=comparison.label,
        model="operating-point forest",
        cost_unit=comparison.cost_unit,
    )


#: The two classifiers of the residual comparison: the forest with the operating point
#: as two plain inputs, and with the indicators standardised per operating point.
RESIDUAL_CLASSIFIERS = {"forest": False, "operating_point_forest": True}


def compare_residuals(
    ensemble,
    table: pd.DataFrame,
    *,
    signal: str = "LeverPosition",
    groups: Sequence[str] = ("stats", "spectral", "cycle"),
    reference_per_point: int = 12,
    n_estimators: int = 150,
    cv: int | None = None,
    seed: int = 0,
):
    """Fault classification from one signal's indicators and from residuals (seed 8.3).

    Three indicator sets of ``signal``, each scored by the two classifiers of
    :data:`RESIDUAL_CLASSIFIERS` on the same stratified 25 % held-out split
    (:func:`pdmkit.experiments.classify`):

    ``signal``
        Indicators of the recorded signal (the ``table`` columns ``<signal>/...``).
    ``residual_signal``
        Indicators of the seed's residual signal: the recording minus the healthy twin
        simulated at the member's load and supply
        (:func:`pdmkit.ensembles.pneumatic_residuals`).
    ``indicator_residuals``
        Each indicator of the recording in standard deviations of
        ``reference_per_point`` healthy twin runs (random unlabelled variation) at the
        member's operating point (:func:`reference_zscores`).

    Parameters
    ----------
    ensemble : Ensemble
        The fault ensemble (with ``load_kg``, ``supply_bar`` and ``fault``).
    table : pandas.DataFrame
        Its feature table from :func:`add_operating_point` with the ``groups``.
    signal : str
        The signal to compare on.
    groups : sequence of str
        Indicator groups (extracted with :func:`twin_cycle_options`).
    reference_per_point : int
        Healthy twin runs per operating point.
    n_estimators : int
        Trees per forest.
    cv : int or None
        Folds of the cross-validation on the training part (None: held-out only).
    seed : int
        Seed of the reference simulation, the split and the forests.

    Returns
    -------
    results : dict
        ``results[classifier][indicator_set]`` -> ClassificationResult.
    residual : Ensemble
        The residual signals (for plots).
    reference : Ensemble
        The healthy reference runs.

    Examples
    --------
    >>> from pdmkit.ensembles import simulate_fault_ensemble
    >>> from pdmkit.experiments._demo import (add_operating_point, compare_residuals,
    ...     twin_cycle_options)
    >>> from pdmkit.features import extract_ensemble
    >>> ens = simulate_fault_ensemble(48, t_end=2.5, signals=["LeverPosition"], seed=3)
    >>> table = add_operating_point(extract_ensemble(
    ...     ens, groups=("cycle",), **twin_cycle_options()))
    >>> results, _, ref = compare_residuals(ens, table, groups=("cycle",),
    ...     reference_per_point=3, n_estimators=20)  # doctest: +SKIP
    >>> sorted(results["forest"])  # doctest: +SKIP
    ['indicator_residuals', 'residual_signal', 'signal']
    """
    from pdmkit.ensembles import pneumatic_residuals, simulate_fault_ensemble
    from pdmkit.experiments._classify import classify
    from pdmkit.features import extract_ensemble

    cycle = twin_cycle_options()
    operating = _feature_columns(table, f"{OPERATING}/")
    raw_cols = _feature_columns(table, f"{signal}/")

    residual = pneumatic_residuals(ensemble, [signal])
    res_table = add_operating_point(extract_ensemble(residual, groups=groups, **cycle))

    points = ensemble.conditions[["load_kg", "supply_bar"]].drop_duplicates()
    n_samples = ensemble.stack(signal)[0].shape[1]
    reference = simulate_fault_ensemble(
        int(reference_per_point) * len(points),
        labels=["healthy"],
        t_end=n_samples / ensemble.fs[signal],
        signals=[signal],
        seed=seed + 1000,
        operating_points=points,
    )
    ref_table = extract_ensemble(reference, groups=groups, **cycle)
    ref_cols = [c for c in raw_cols if c in ref_table.columns]
    scored = add_operating_point(reference_zscores(table, ref_table, ref_cols))

    sets = {
        "signal": (table, raw_cols),
        "residual_signal": (res_table, _feature_columns(res_table, f"{signal}_res/")),
        "indicator_residuals": (scored, _feature_columns(scored, f"{signal}_z/")),
    }
    results: dict = {}
    for name, scale in RESIDUAL_CLASSIFIERS.items():
        model = operating_point_forest(n_estimators, scale=scale, random_state=seed)
        results[name] = {}
        for key, (frame, cols) in sets.items():
            results[name][key] = classify(
                frame,
                "fault",
                features=[*operating, *cols],
                model=model,
                selection=None,
                cv=cv,
                random_state=seed,
            )
    return results, residual, reference


def _residual_summary(results, signal, n_reference) -> dict:
    plain = results["forest"]
    scaled = results["operating_point_forest"]
    summary = {
        "signal": signal,
        "accuracy_residual": plain["indicator_residuals"].accuracy,
        "accuracy_signal": plain["signal"].accuracy,
        "accuracy_residual_signal": plain["residual_signal"].accuracy,
        "features_residual": _forest_top(plain["indicator_residuals"]),
        "features_signal": _forest_top(plain["signal"]),
        "features_residual_signal": _forest_top(plain["residual_signal"]),
        "model": "forest (RandomForestClassifier(max_features=0.3), operating point as "
        "input), 25 % held out",
        "per_point_standardised": {
            "accuracy_residual": scaled["indicator_residuals"].accuracy,
            "accuracy_signal": scaled["signal"].accuracy,
            "accuracy_residual_signal": scaled["residual_signal"].accuracy,
        },
        "reference_members": int(n_reference),
    }
    return summary


def _example_figure(ensemble):
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 1, figsize=(9, 5), sharex=True)
    faults = ensemble.conditions["fault"]
    fs = ensemble.fs["LeverPosition"]
    for code in sorted(faults.unique()):
        if "+" in code:
            continue
        i = int(np.flatnonzero(faults.to_numpy() == code)[0])
        x = ensemble.signal("LeverPosition")[i]
        q = ensemble.signal("FlowExtrusion")[i]
        t = np.arange(x.size) / fs
        axes[0].plot(t, x * 1e3, lw=0.8, label=code)
        axes[1].plot(t, q, lw=0.8)
    axes[0].set_ylabel("position (mm)")
    axes[1].set_ylabel("flow into A (l/min)")
    axes[1].set_xlabel("time (s)")
    axes[0].legend(fontsize=7, ncol=3)
    fig.tight_layout()
    return fig


def _damper_figure(table):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    x = table.get("LeverPosition/cycle/S1_Rate95")
    y = table.get("LeverPosition/cycle/S1_Rate98")
    if x is None or y is None or "damper_upper" not in table:
        ax.text(0.5, 0.5, "no cycle indicators", ha="center", transform=ax.transAxes)
        return ax
    keep = ~table["fault"].astype(str).str.contains("throttle").to_numpy()
    x, y, table = x[keep], y[keep], table[keep]
    setting = table["damper_upper"].to_numpy(dtype=float)
    groups = [
        ("too soft (1-2.5)", setting <= 2.5, "tab:blue"),
        ("healthy (4.5-5.5)", (setting > 2.5) & (setting < 8.5), "tab:green"),
        ("too hard (8.5-10)", setting >= 8.5, "tab:red"),
    ]
    for label, sel, colour in groups:
        ax.scatter(x[sel], y[sel], s=8, c=colour, label=label, alpha=0.7)
    ax.set_xlabel("speed 8 mm before the top (m/s)")
    ax.set_ylabel("speed 3.2 mm before the top (m/s)")
    ax.set_title("upper damper (members without a throttle fault)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return ax


def _residual_figure(residuals):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 3))
    faults = residuals.conditions["fault"].to_numpy()
    fs = residuals.fs["LeverPosition_res"]
    for code in sorted(set(faults)):
        if "+" in code:
            continue
        i = int(np.flatnonzero(faults == code)[0])
        e = residuals.signal("LeverPosition_res")[i]
        ax.plot(np.arange(e.size) / fs, e * 1e3, lw=0.8, label=code)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("residual (mm)")
    ax.legend(fontsize=7, ncol=3)
    fig.tight_layout()
    return fig
