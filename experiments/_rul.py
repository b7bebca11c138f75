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
- ``"boosting"``: :class:`pdmkit.rul.BoostingRULModel` (gradient-boosted trees on the
  recent means and slopes of the sensors and the age, five fold models, cross-conformal
  intervals): the strong default learned model;
- ``"neural"``: :class:`pdmkit.rul.NeuralRULModel` (a multi-layer perceptron, 128 and
  64 units, over 40-cycle windows of the standardised sensors and the cycle count,
  30 epochs; shorter histories padded with their first row; five networks, one per
  fold of training units; on C-MAPSS FD001 it beat the LSTM, 11.5-11.9 against
  12.4-13.8, in a third of the time).

No RUL cap unless one is asked for (``rul_cap``): the true RULs and the predictions are
in the user's time unit as they are. The named C-MAPSS dataset keeps its literature's
convention, 125 cycles (``rul_cap="convention"``, the default, says so in the summary,
the report and the printed line); the uncapped scores are reported beside the capped
ones. ``time_unit`` (default ``cycles`` for a ``cycle`` column, ``s`` for a ``time``
column) labels every score, figure axis and printed line.

Checks that a model cannot make itself end up as warnings in the output and in the
JSON's ``warnings``: too few training units for the model's settings (``k`` neighbours,
folds, a learned model on a handful of units), an RMSE from fewer than 5 test units,
test units outside the training rows (:func:`pdmkit.rul.ood_scores`, the per-unit
``ood_score`` column of the predictions), units whose last rows look like a shut-down
(:func:`pdmkit.rul.shutdown_endings`), upper bounds pinned at the cap, and units the
model gives no estimate for.

``run_rul(dataset="nasa-battery", ...)`` runs the degradation models on the NASA Li-ion
cells, leave-one-cell-out (:mod:`pdmkit.experiments._rul_battery`).

``run_rul(dataset="pneumatic-leak", ...)`` runs the same models on air-leak
run-to-failure units of the pneumatic twin (:mod:`pdmkit.experiments._rul_leak`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pdmkit._checks import check_magnitude
from pdmkit._output_folder import check_output_folder, real_path
from pdmkit._outputs import OutputRun, collect_warnings, write_json_file
from pdmkit._persist import load_model
from pdmkit.ensembles import read_table
from pdmkit.errors import DataError, ModelError
from pdmkit.experiments._rul_battery import run_battery
from pdmkit.experiments._rul_checks import (
    CAP_CONVENTIONS,
    default_time_unit,
    describe_rul,
    ending_checks,
    interval_checks,
    model_keys,
    ood_check,
    rename_keys,
    resolve_cap,
)
from pdmkit.experiments._rul_cv import run_cv
from pdmkit.experiments._rul_leak import (
    _LEAK_NAMES,
    LEAK_DEFAULTS,
    LEAK_SIGNALS,
    _run_leak,
    leak_indicators,
    simulate_leak_dataset,
)
from pdmkit.experiments._rul_models import (
    RUL_MODELS,
    leak_accuracy,
    make_rul_model,
)
from pdmkit.experiments._rul_tables import run_tables
from pdmkit.experiments._rul_trained import register_answer
from pdmkit.rul import resolve_keys, timestamps_to_seconds

__all__ = [
    "CAP_CONVENTIONS",
    "LEAK_DEFAULTS",
    "LEAK_SIGNALS",
    "RUL_MODELS",
    "describe_rul",
    "leak_accuracy",
    "leak_indicators",
    "make_rul_model",
    "predict_rul",
    "run_rul",
    "simulate_leak_dataset",
    "split_run_to_failure",
]


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


def predict_rul(
    model_file: str | Path,
    history: str | Path | pd.DataFrame,
    *,
    json_path: str | Path | None = None,
    expect_sha256: str | None = None,
    unit: str | None = None,
    time: str | None = None,
    time_unit: str | None = None,
    out_dir: str | Path | None = None,
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
        ``summary.json``); a file with another hash is refused before it is read.
    unit, time : str, optional
        The history's unit and time columns when they have other names than the
        model's (renamed to the model's before predicting).
    time_unit : str, optional
        Unit of the time column (default: the one the model was trained with, else
        ``cycles`` for a ``cycle`` column and ``s`` otherwise).
    out_dir : str or Path, optional
        Also write the answer into this output folder: ``predictions.csv`` (unit, its
        last time, ``rul``, ``lower``, ``upper``, ``level``, ``note``, ``ood_score``),
        ``summary.json`` (this answer, with ``model_sha256``) and ``report.html``;
        nothing else in the folder is touched (see :mod:`pdmkit._outputs`).

    Returns
    -------
    dict
        ``model_file``, ``model`` (the estimator), ``level``, ``time_unit``,
        ``rul_cap`` (the model's cap, None when uncapped), ``units``: one entry per
        unit with ``unit``, ``time`` (its last time), ``rul``, ``lower``, ``upper``,
        ``note`` (what the interval means where it is not plain: an upper bound at the
        cap or beyond the horizon, no estimate) and ``text`` (the line ``pdmkit rul
        --trained`` prints), ``time_column`` (the model's name for the time column)
        and ``warnings``; with ``out_dir`` also ``model_sha256``, ``n_units``,
        ``paths`` and ``run_id``.

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
    >>> history = pd.DataFrame({"unit": "pump-7", "hours": [0.0, 10.0],
    ...                         "hi": [0.0, 0.25]})
    >>> answer = predict_rul(path, history, time="hours", time_unit="h")
    >>> answer["units"][0]["unit"], round(answer["units"][0]["rul"])   # 1.0 at t = 40
    ('pump-7', 30)
    >>> answer["units"][0]["text"][:32]
    'unit pump-7 at time 10 h: RUL 30'
    """
    inputs = [model_file] if isinstance(history, pd.DataFrame) else [model_file, history]
    if out_dir is not None:
        if real_path(out_dir) == real_path(Path(model_file).parent):
            raise DataError(
                f"--out {out_dir} is the folder of the trained model {model_file}: its "
                "training run's summary.json and report.html (with the model's SHA-256) "
                "would be replaced; choose another --out"
            )
        with OutputRun(out_dir, "rul-trained", inputs=inputs, json_path=json_path) as run:
            answer = _predict_rul(model_file, history, expect_sha256, unit, time, time_unit)
            answer["warnings"] = run.warnings
            register_answer(run, answer, model_file)
            run.commit()
        return answer
    if json_path is not None:  # before any work: --json must not overwrite an input
        check_output_folder(None, "rul", inputs=inputs, json_path=json_path)
    with collect_warnings() as found:
        answer = _predict_rul(model_file, history, expect_sha256, unit, time, time_unit)
    answer["warnings"] = list(found)
    if json_path is not None:
        write_json_file(answer, json_path, inputs=inputs)
    return answer


def units_in_seconds(
    table: pd.DataFrame, where, time: str | None = None
) -> tuple[pd.DataFrame, str | None]:
    """:func:`pdmkit.rul.timestamps_to_seconds` with errors naming ``where`` (a file).

    ``time`` names the time column (default ``time``, else ``cycle``).

    Examples
    --------
    >>> import pandas as pd
    >>> from pdmkit.experiments._rul import units_in_seconds
    >>> units_in_seconds(pd.DataFrame({"cycle": [1, 2]}), "units.csv")[1] is None
    True
    """
    try:
        return timestamps_to_seconds(table, time)
    except DataError as exc:
        raise DataError(f"{where}: {exc}") from None


def _names_of_training(table: pd.DataFrame, pipeline, where: str) -> pd.DataFrame:
    """A header-less history, given the training table's column names by position.

    A history with generated names (``column_0 ...``) as wide as the model's training table
    gets that table's column names, by position, said.
    """
    import warnings

    names = getattr(pipeline, "table_columns_", None)
    generated = [f"column_{k}" for k in range(table.shape[1])]
    if (
        not names
        or list(map(str, table.columns)) != generated
        or len(names) != len(generated)
    ):
        return table
    warnings.warn(
        f"{where}: no header; its {len(names)} columns are read as the model's training "
        f"table's, by position ({', '.join(names[:4])}, ...)",
        stacklevel=3,
    )
    return table.set_axis(names, axis=1)


def _predict_rul(
    model_file,
    history,
    expect_sha256=None,
    unit=None,
    time=None,
    time_unit=None,
    *,
    pipeline=None,
) -> dict[str, Any]:
    """:func:`predict_rul`'s answer; ``pipeline``: the file's model, already loaded."""
    if pipeline is None:
        pipeline = load_model(model_file, expect_sha256=expect_sha256)
    if not hasattr(pipeline, "predict_trajectory"):
        raise ModelError(
            f"{model_file}: holds a {type(pipeline).__name__}, not a RUL model; train "
            "one with `pdmkit rul ... --out DIR` (it writes DIR/model.pdmkit)"
        )
    table = history if isinstance(history, pd.DataFrame) else read_table(history)
    where = "history" if isinstance(history, pd.DataFrame) else str(history)
    table = _names_of_training(table, pipeline, where)
    model_unit, model_time = model_keys(pipeline)
    if time is not None and time not in table.columns:
        raise DataError(
            f"{where}: --time {time!r} is not a column (columns: "
            f"{list(table.columns)[:12]})"
        )
    table, origin = units_in_seconds(table, where, time)
    wanted_time = model_time or ("time" if time is not None else None)
    table = rename_keys(
        table, where, [(unit, model_unit, "--unit"), (time, wanted_time, "--time")]
    )
    for column in table.select_dtypes("number"):  # overflows: silent wrong answers
        check_magnitude(table[column], f"{where}: column {column!r}")
    if model_unit not in table.columns:  # one unit's history: named after its file
        name = "unit" if isinstance(history, pd.DataFrame) else Path(history).stem
        table = table.assign(**{model_unit: name})
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
    inner = getattr(pipeline, "model", pipeline)
    unit_label = time_unit or getattr(pipeline, "time_unit_", None)
    if unit_label is None:
        unit_label = "cycles" if model_time == "cycle" and origin is None else "s"
    cap = getattr(getattr(inner, "model_", inner), "max_rul", None)
    cap = float(cap) if cap is not None else None
    found: list[str] = []
    notes, _ = interval_checks(prediction, cap, unit_label, found)
    rows = prediction.to_pandas()[["unit", "time", "rul", "lower", "upper"]]
    rows["note"] = notes
    reference = getattr(pipeline, "training_sample_", None)
    if reference is not None:  # how far each history lies from the training rows
        keyed = table.rename(columns={model_unit: "unit", model_time or "time": "time"})
        cols = [c for c in reference.columns if c not in ("unit", "time") and c in keyed]
        # the kept training rows are a thinned sample: only the history's own endings
        # are checked for a shut-down, not the sample's
        ood = ood_check(reference, keyed, cols, found)
        ending_checks({"history": keyed}, cols, found)
        rows["ood_score"] = ood.reindex(rows["unit"]).to_numpy(dtype=float)
    records = rows.to_dict(orient="records")
    for record in records:
        record["text"] = describe_rul(record, prediction.level, unit_label)
    answer = {
        "model_file": str(model_file),
        "model": repr(inner),
        "level": float(prediction.level),
        "time_unit": unit_label,
        "rul_cap": cap,
        "time_column": model_time or "time",
        "units": records,
        "warnings": found,
    }
    return answer


def run_rul(
    dataset: str | tuple[pd.DataFrame, pd.DataFrame] = "cmapss-fd001",
    model: str = "similarity",
    out_dir: str | Path = "results/rul",
    json_path: str | Path | None = None,
    seed: int = 0,
    *,
    features: Sequence[str] | None = None,
    rul_cap: float | str | None = "convention",
    options: dict | None = None,
    n_trajectories: int = 4,
    dataset_options: dict | None = None,
    calibrate: bool = False,
    time_unit: str | None = None,
    cv: str | int | None = None,
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
        ``time``/``cycle`` and the features, the test table holding ``rul_true_final``;
        with ``cv``, one long table of run-to-failure units.
    model : str, default "similarity"
        One of :data:`RUL_MODELS` (``similarity``, ``degradation``, ``survival``,
        ``neural`` and the variants named in the module notes).
    out_dir : str or Path, default "results/rul"
        Folder for ``summary.json``, ``predictions.parquet``, ``report.html`` and
        ``model.pdmkit``, written all at once when everything succeeded; anything else
        in the folder is left as it is (see :mod:`pdmkit._outputs`).
    json_path : str or Path, optional
        Also write the JSON summary here.
    seed : int, default 0
        Seed of the estimators that draw random numbers.
    features : sequence of str, optional
        Input columns (default: the 21 C-MAPSS sensors, or every numeric column of the
        tables but the keys, labels and ``setting*``).
    rul_cap : float, None or "convention", default "convention"
        Cap on the predictions, the learned models' targets and the true RULs of the
        headline scores. ``"convention"``: the named dataset's literature convention
        (125 cycles for C-MAPSS, said in the summary as ``rul_cap_source``), none for
        tables and the other datasets; None: no cap.
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
    time_unit : str, optional
        Unit of the time column, shown with every score, axis and line (default
        ``cycles`` for the named datasets and a ``cycle`` column, ``s`` for a
        ``time`` column).
    cv : "units" or int, optional
        Cross-validate on one table (``dataset``) instead of scoring a test table:
        ``"units"`` holds each unit out in turn, an integer K splits the units into K
        folds; every held-out unit is followed through its life by a model trained
        without it (:mod:`pdmkit.experiments._rul_cv`, the code path of
        ``"nasa-battery"``); the summary's ``cv`` lists the folds.

    Returns
    -------
    dict
        ``model, dataset, rmse, mae, phm08_score, coverage, n_units`` (scored against
        the capped true RUL), the same uncapped (``*_uncapped``), ``bias``,
        ``mean_interval_width``, ``level``, ``rul_cap`` (None: no cap) and
        ``rul_cap_source``, ``time_unit``, ``intervals`` (upper bounds at the cap,
        beyond the horizon, units without an estimate), ``ood`` (the largest
        out-of-distribution score and the number of test units above 1),
        ``shutdown_endings``, ``checks`` and ``warnings`` (the messages), ``seed``,
        ``fit_seconds``, ``predict_seconds``, ``estimator``, ``features``, ``paths``
        and ``coverage_check`` (:func:`pdmkit.rul.coverage_check`: the intervals'
        empirical coverage on the held-out units against their level; a warning when
        far below). With ``cv``: ``cv`` (the scheme and the folds), ``per_unit`` and
        ``n_predictions``. For cross-validation, ``"nasa-battery"`` and
        ``"pneumatic-leak"`` the scores are over every prediction in the last half of
        the held-out units' lives (``n_predictions`` of them). For
        ``"pneumatic-leak"`` ``within_10pct`` holds the fraction of test units within
        10 % under each reading of :func:`leak_accuracy`, ``indicator_ranking`` the
        best candidates, and ``true_leak`` the same scores with the true
        ``log10 C_al`` as the indicator (what the random walk alone allows).

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
            time_unit=time_unit,
            cv=cv,
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
    time_unit=None,
    cv=None,
) -> dict[str, Any]:
    """:func:`run_rul` with its files registered with ``sink`` (not yet written)."""
    if cv is not None or isinstance(dataset, pd.DataFrame):
        if cv is None or not isinstance(dataset, pd.DataFrame):
            raise DataError(
                "cross-validation (cv='units' or K) takes one table of run-to-failure "
                "units as dataset, and one table needs cv (or give (train, test)); "
                f"got cv={cv!r} and a {type(dataset).__name__}"
            )
        if dataset_options:
            raise DataError("dataset options are settings of 'pneumatic-leak'")
        cap, cap_source = resolve_cap(rul_cap, None)
        return run_cv(
            sink, dataset, model, seed, cv=cv, features=features, rul_cap=cap,
            cap_source=cap_source, options=options, calibrate=calibrate,
            time_unit=time_unit,
        )  # fmt: skip
    key = dataset.lower().replace("_", "-") if isinstance(dataset, str) else None
    if key in ("cmapss",):
        key = "cmapss-fd001"
    if key in ("battery",):
        key = "nasa-battery"
    if key in _LEAK_NAMES:
        key = "pneumatic-leak"
    cap, cap_source = resolve_cap(rul_cap, key)
    if key == "nasa-battery":
        if dataset_options:
            raise DataError("'nasa-battery' takes no dataset options")
        summary = run_battery(
            model,
            sink,
            seed,
            rul_cap=cap,
            options=options,
            calibrate=calibrate,
            time_unit=time_unit or default_time_unit(key),
        )
        summary["rul_cap_source"] = cap_source
        return summary
    if key == "pneumatic-leak":
        return _run_leak(
            model,
            sink,
            seed,
            features=features,
            rul_cap=cap,
            cap_source=cap_source,
            options=options,
            n_trajectories=n_trajectories,
            dataset_options=dataset_options,
            calibrate=calibrate,
            time_unit=time_unit or default_time_unit(key),
        )
    if dataset_options:
        raise DataError(
            f"dataset options {sorted(dataset_options)} are simulation settings of "
            "'pneumatic-leak'; the other datasets take none"
        )
    return run_tables(
        sink,
        model,
        seed,
        dataset=dataset,
        features=features,
        rul_cap=cap,
        cap_source=cap_source,
        options=options,
        n_trajectories=n_trajectories,
        calibrate=calibrate,
        time_unit=time_unit,
        key=key,
    )
