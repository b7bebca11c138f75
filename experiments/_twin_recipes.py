"""pdmkit's own recipes on the pneumatic twin, shown beside the seed's in the demo.

Per-stroke cycle indicators (:func:`twin_cycle_options`), indicators standardised per
operating point and a random forest on them (:class:`OperatingPointScaler`,
:func:`operating_point_forest`, :func:`add_operating_point`), residuals against a
healthy reference (:func:`reference_zscores`, :func:`compare_residuals`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils.validation import check_is_fitted

from pdmkit.ensembles import pneumatic_residuals, simulate_fault_ensemble
from pdmkit.errors import DataError
from pdmkit.experiments._classify import classify

__all__ = [
    "OPERATING",
    "RESIDUAL_CLASSIFIERS",
    "OperatingPointScaler",
    "add_operating_point",
    "compare_residuals",
    "operating_point_forest",
    "reference_zscores",
    "twin_cycle_options",
]


#: Name of the pseudo-signal that carries the operating point in a feature table.
OPERATING = "Operating"


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
    >>> from pdmkit.experiments._twin_recipes import twin_cycle_options
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
    >>> from pdmkit.experiments._twin_recipes import OperatingPointScaler
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
    >>> from pdmkit.experiments._twin_recipes import operating_point_forest
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
    >>> from pdmkit.experiments._twin_recipes import add_operating_point
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
    >>> from pdmkit.experiments._twin_recipes import reference_zscores
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
    >>> from pdmkit.experiments._twin_recipes import (
    ...     add_operating_point, compare_residuals, twin_cycle_options)
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
