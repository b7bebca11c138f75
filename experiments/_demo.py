"""``pdmkit demo``: the whole workbench on the simulated pneumatic piston, in one report.

The seed thesis (001, chapters 3, 7-8) runs the predictive-maintenance workflow on a
measured pneumatic piston; its recordings are not public, so the demo runs the same
study on pdmkit's digital twin of that rig and shows, top to bottom:

1. a summary box: what was simulated, the seed's headline recipe, the best classifier
   and sensor, the RUL error, the mismatch found (each linked to its section);
2. the seed's data set (:func:`pdmkit.ensembles.simulate_seed_ensemble`: fault codes
   recorded about 20 times each, grouped into the seed's 20 labels), simulated in parts
   and reduced to indicators at once, so memory holds one part's recordings;
3. the seed's recipes exactly, each named by its section
   (:mod:`pdmkit.experiments._seed_study`), in the seed comparison table (seed's number
   | pdmkit's on the twin | why they differ) and the seed's sensor table 9.1;
4. pdmkit's own recipe beside them: per-stroke cycle indicators and a random forest on
   indicators standardised per operating point (:func:`operating_point_forest`), and
   the eight sensor types by accuracy and cost;
5. the remaining useful life of air-leak run-to-failure units (seed 8.4) with a linear
   degradation model;
6. mismatch discovery (:mod:`pdmkit.experiments._demo_mismatch`): an air leak concealed
   in recordings of the piston model file, and the real Cascaded Tanks when the data
   directory is there.

It writes ``summary.json`` (machine-readable; ``seed_comparison`` and ``mismatch`` among
its keys), ``report.html``, ``features.parquet`` and the RUL step's files (``rul/``) into
the output folder, all at once, beside whatever the folder already holds
(:mod:`pdmkit._outputs`).
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

from pdmkit._outputs import OutputRun
from pdmkit.ensembles import PNEUMATIC_SENSORS, pneumatic_residuals, simulate_fault_ensemble
from pdmkit.errors import DataError
from pdmkit.experiments._classify import classify
from pdmkit.experiments._demo_mismatch import add_mismatch_section, demo_mismatch_cases
from pdmkit.experiments._report import Report
from pdmkit.experiments._seed_indicators import seed_feature_table
from pdmkit.experiments._seed_recipes import (
    seed_flow_bagged_trees,
    seed_flow_knn,
    seed_flow_pca_bagged_trees,
    seed_residual_classification,
    seed_sensor_faults,
    seed_sensor_table,
)
from pdmkit.experiments._seed_study import seed_comparison, seed_ensemble_parts
from pdmkit.experiments._sensors import SensorComparison, compare_sensors

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
        Size of the simulated seed data set (default 480: 24 fault codes of the seed's
        20 labels, 20 recordings each; the seed had 4840). At least 80 (every label
        needs members on both sides of the test split); below 320 the forests are
        smaller and the real-data mismatch case is left out (quick checks).
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
    n_members = int(members) if members is not None else 480
    if n_members < 80:
        raise DataError(
            f"members={n_members} is too few for the seed's 20 labels: every label needs "
            "members on both sides of the 25 % test split; use 80 or more"
        )
    with OutputRun(out_dir, "demo", json_path=json_path) as run:
        summary = _demo(run, n_members, seed, recording_s)
        run.commit()
    return summary


def _demo(run, n_members: int, seed: int, recording_s: float) -> dict:  # noqa: PLR0915
    """:func:`run_demo` with its files registered with ``run`` (not yet written)."""
    from pdmkit.features import extract_ensemble, rank_features

    cycle = twin_cycle_options()
    groups = ("stats", "spectral", "cycle")
    quick = n_members < 320  # small ensembles are quick checks
    trees = 50 if quick else 150
    timing: dict[str, float] = {}
    report = Report("pdmkit demo: predictive maintenance of a pneumatic piston (simulated)")
    report.add_text(
        "The study of the seed thesis (Predictive maintenance of pneumatic pistons, "
        "chapters 3, 7 and 8) on pdmkit's digital twin of its rig: a double-acting "
        "vertical piston with throttle valves, adjustable small end dampers, static large "
        "dampers, load masses of 0-6.25 kg and 5 or 6 bar supply, recorded 10 s at 1 kHz "
        "by the fifteen sensors of the seed's table 3.1. All data on this page are "
        "simulated, except the Cascaded Tanks recordings of the last section."
    )

    # 1. the seed's data set: simulated in parts, reduced to indicators at once ----------
    elapsed = _step(
        f"simulating {n_members} recordings of the twin ({recording_s:g} s, 15 sensors, "
        "the seed's 20 labels) and extracting indicators"
    )
    seed_parts, own_parts, example = [], [], None
    for ensemble in seed_ensemble_parts(
        n_members, part_size=160, seed=seed, t_end=recording_s
    ):
        seed_parts.append(seed_feature_table(ensemble, residuals=False))
        own_parts.append(extract_ensemble(ensemble, groups=groups, **cycle))
        if example is None:
            example = ensemble
        del ensemble
    seed_table = pd.concat(seed_parts)
    table = add_operating_point(pd.concat(own_parts))
    del seed_parts, own_parts
    run.add_parquet("features.parquet", table.copy())
    timing["simulate_and_indicators"] = elapsed()
    counts = seed_table["seed_label"].value_counts().sort_index()

    # 2. the seed's recipes ---------------------------------------------------------------
    elapsed = _step("the seed's recipes (flow kNN, bagged trees, PCA, residuals, sensors)")
    results = {
        "flow_knn": seed_flow_knn(seed_table, seed=seed),
        "flow_bagged_trees": seed_flow_bagged_trees(seed_table, seed=seed),
        "flow_pca_bagged_trees": seed_flow_pca_bagged_trees(seed_table, seed=seed),
        # its own set, as the seed's: five classes at one operating point (8.2.1, 8.3)
        "residual_classification": seed_residual_classification(
            n_members=100 if quick else 220, t_end=recording_s, seed=seed
        ),
        "sensor_faults": seed_sensor_faults(
            60 if quick else 150, t_end=recording_s, seed=seed
        ),
    }
    seed_sensors = seed_sensor_table(seed_table, seed=seed)
    timing["seed_recipes"] = elapsed()

    # 3. pdmkit's own recipe on the same recordings ----------------------------------
    elapsed = _step("pdmkit's recipe: cycle indicators and an operating-point forest")
    operating = _feature_columns(table, f"{OPERATING}/")
    features = _feature_columns(table, tuple(example.signal_names))
    ranking = rank_features(table, table["fault"], method="kruskal", features=features)
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
    own = result.summary()
    own["features"] = _forest_top(result)  # all are inputs: name the five it uses most
    own_figure = result.plot()
    sensors = {name: (OPERATING, *signals) for name, signals in PNEUMATIC_SENSORS.items()}
    comparison = compare_sensors(
        table[[*operating, *features, "fault"]],
        "fault",
        sensors,
        model=forest,
        selection=None,
        cv=None if quick else 3,
        random_state=seed,
    )
    comparison = _with_forest_features(comparison, SensorComparison)
    timing["pdmkit_recipe"] = elapsed()

    # 4. air-leak RUL ----------------------------------------------------------------------
    elapsed = _step(
        f"estimating the RUL of {_RUL_UNITS[0] + _RUL_UNITS[1]} air-leak units "
        "(linear degradation)"
    )
    rul_summary, rul_figure = _air_leak_rul(run.view("rul"), seed, recording_s)
    timing["rul"] = elapsed()

    # 5. mismatch discovery ------------------------------------------------------------
    elapsed = _step("discovering what a model file left out (mismatch)")
    # quick checks leave the real-data case out
    mismatch_cases = demo_mismatch_cases(seed, real_data=False if quick else None)
    timing["mismatch"] = elapsed()

    # ------------------------------------------------------------------------ the report
    rul_row = _seed_rul_row(rul_summary)
    comparison_table = seed_comparison(results)
    comparison_table = pd.concat([comparison_table, pd.DataFrame([rul_row])])
    sensor_rows = comparison.summary()["sensors"]
    best = max(
        (r for r in sensor_rows if r["heldout_accuracy"] is not None),
        key=lambda r: r["heldout_accuracy"],
        default=None,
    )
    anchors = {}

    def heading(key: str, text: str) -> None:
        anchors[key] = report.anchor(text)
        report.add_heading(text)

    heading("data", "1. The seed's data set, simulated")
    report.add_text(
        f"{n_members} recordings in the seed's design (section 3.3, 7.2.1; the author's "
        "faultCode2Label): fault codes, each a fixed setting of the rig recorded about "
        "20 times, grouped into the seed's 20 labels by the place of the fault "
        "(healthy, throttle valve 1 or 2, small damper bottom or upper, and pairs of "
        "these with the large dampers and the supply pressure). docs/seed_study.md "
        "tells how the labels were derived."
    )
    report.add_table(
        counts.rename("recordings").to_frame(), caption="Recordings per seed label"
    )
    report.add_figure(_example_figure(example), caption="One recording per single fault")
    heading("seed", "2. The seed's recipes on the twin")
    report.add_text(
        "Each recipe exactly as the seed ran it (its section in the table), on the "
        "simulated data set; the seed's number is from the measured rig. The twin "
        "cannot be expected to match the rig to the point: the table says why each "
        "number differs."
    )
    report.add_table(
        comparison_table[["recipe", "section", "metric", "seed", "pdmkit", "why"]],
        caption="The seed's numbers beside pdmkit's on the twin",
    )
    report.add_table(
        seed_sensors[["sensor", "seed", "pdmkit", "difference", "model"]],
        caption="Seed table 9.1: accuracy (%) of each sensor with the seed's recipe for "
        f"it; Spearman rho of the ordering {seed_sensors.attrs.get('spearman_rho', 0):.2f}",
    )
    heading("pdmkit", "3. pdmkit's recipe: per-stroke indicators, operating-point forest")
    report.add_text(
        f"pdmkit's default for this machine, beside the seed's: {len(features)} "
        "indicators of the fifteen signals (whole-recording statistics and spectra and "
        "per-stroke cycle indicators: stroke times, the speed passing points ever "
        "closer to each end, the speed the end dampers take out, bounces, impacts) into "
        "a random forest on indicators standardised per operating point (load and "
        "supply, which the operator knows). Held-out accuracy on the same 20 labels: "
        f"{own['accuracy']:.3f}. Read it as the seed's numbers are read: members are "
        "split at random, so recordings of one fault code (one setting recorded about "
        "20 times) fall on both sides of the split, and the accuracy measures "
        "recognising settings seen in training; with whole codes held out the seed's "
        "flow recipe falls to about 41 % (docs/seed_study.md)."
    )
    report.add_figure(ranking.plot(k=20), caption="Top 20 indicators (Kruskal-Wallis)")
    report.add_figure(
        own_figure,
        caption=f"operating-point forest: held-out accuracy {own['accuracy']:.3f}",
    )
    report.add_figure(comparison.plot(), caption="Sensors: accuracy against cost")
    report.add_table(
        comparison.to_pandas().drop(columns=["note"]),
        caption="Each sensor type with pdmkit's recipe (its indicators plus the "
        "operating point); costs from the seed's table 9.1 (CZK)",
    )
    heading("rul", "4. Remaining useful life of a leaking chamber (seed 8.4)")
    report.add_text(
        f"{_RUL_UNITS[0]} training and {_RUL_UNITS[1]} test units of the twin with a "
        "chamber air leak growing along unit-specific random walks, one "
        f"{recording_s:g} s recording per cycle; indicator chosen by monotonicity, "
        f"trendability and prognosability: {rul_summary['indicator']}; linear "
        "degradation with Bayesian updating. Over the last half of life: MAE "
        f"{rul_summary['mae']:.2f} cycles, RMSE {rul_summary['rmse']:.2f}. The seed's "
        "own reading (one run after 60 cycles, 25 training runs, the flow shape factor) "
        "is in benchmarks/seed_study.py; the full RUL report is rul/report.html."
    )
    report.add_figure(
        rul_figure,
        caption="Predicted (solid) and true (dashed) RUL of the test units, the model's "
        "90 % interval dotted; shaded: within 10 % of the unit's life over its last half",
    )
    anchors["mismatch"] = report.anchor("5. Mismatch discovery: what the model left out")
    add_mismatch_section(report, mismatch_cases, 5)

    mismatch = [c.summary() for c in mismatch_cases]
    flow = results["flow_knn"]
    report.add_summary_box(
        [
            (
                "Simulated",
                f"{n_members} recordings of the pneumatic piston twin, {recording_s:g} s "
                "at 1 kHz, fifteen sensors, the seed's 20 labels",
                anchors["data"],
            ),
            (
                "Seed's recipe",
                f"flow sensor, Kruskal-Wallis top 5 + 1-NN: {flow.pdmkit:.1f} % "
                f"(seed {flow.seed:.1f} % on the rig)",
                anchors["seed"],
            ),
            (
                "Best classifier",
                f"pdmkit's operating-point forest on all indicators: "
                f"{100 * own['accuracy']:.1f} % held out",
                anchors["pdmkit"],
            ),
            (
                "Best sensor",
                "none scored"
                if best is None
                else f"{best['sensor']}: {100 * best['heldout_accuracy']:.1f} % held out",
                anchors["pdmkit"],
            ),
            (
                "RUL",
                f"air-leak units, last half of life: MAE {rul_summary['mae']:.2f} cycles",
                anchors["rul"],
            ),
            (
                "Mismatch found",
                "; ".join(
                    f"{m['name']}: {m['named']}, RMSE "
                    f"{m['fit']['rmse_nominal']:.3g} -> {m['fit']['rmse_augmented']:.3g}"
                    for m in mismatch
                ),
                anchors["mismatch"],
            ),
        ]
    )
    summary = {
        "members": n_members,
        "recording_s": recording_s,
        "labels": sorted(counts.index.tolist()),
        "seed_comparison": comparison_table.to_dict(orient="records"),
        "seed_sensors": {
            "rows": seed_sensors.to_dict(orient="records"),
            "spearman_rho": seed_sensors.attrs.get("spearman_rho"),
        },
        "n_features": len(features),
        "feature_groups": list(groups),
        "top_features": ranking.top(5),
        "classification": {"operating_point_forest": own},
        "sensors": sensor_rows,
        "sensor_model": f"operating_point_forest({trees}): OperatingPointScaler + "
        "RandomForestClassifier(max_features=0.3), held out 25 %"
        + ("" if quick else " + 3-fold CV"),
        "best_sensor": None
        if best is None
        else {"sensor": best["sensor"], "heldout_accuracy": best["heldout_accuracy"]},
        "sensor_faults": results["sensor_faults"].to_dict(),
        "rul": rul_summary,
        "mismatch": mismatch,
        "timing_s": {k: round(v, 2) for k, v in timing.items()},
        "environment": {"python": platform.python_version(), "seed": seed},
    }
    summary["timing_s"]["total"] = round(sum(timing.values()), 2)
    report.add_heading("Time per step")
    report.add_json(summary["timing_s"], caption="Time per step (s)")
    run.add_report("report.html", report)
    run.add_json("summary.json", summary)
    return summary


def _seed_rul_row(rul: dict) -> dict:
    """The seed-comparison row of the demo's RUL step (pdmkit's indicator and model)."""
    share = rul["within_10pct"].get("mean_of_life")
    return {
        "recipe": "air_leak_rul (pdmkit)",
        "section": "8.4",
        "metric": "test units with mean error within 10 % of life",
        "seed": 10.0,
        "pdmkit": None if share is None else round(100 * float(share), 1),
        "difference": None,
        "why": "The seed: one run predicted after 60 cycles deviates about 10 %. Here: "
        "pdmkit's indicator and linear degradation on a few short units (the seed's own "
        "reading runs in benchmarks/seed_study.py); not the same measure.",
    }


#: Training and test units of the demo's air-leak RUL step, and their longest life.
_RUL_UNITS = (8, 4)
_RUL_MAX_CYCLES = 40


def _air_leak_rul(sink, seed: int, recording_s: float):
    """The demo's RUL step: (summary, trajectory figure); its files go to ``sink``."""
    from pdmkit.experiments._rul import _rul
    from pdmkit.experiments._rul_models import _trajectory_plot

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
