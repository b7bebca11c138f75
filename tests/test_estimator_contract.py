"""Every public estimator of pdmkit against scikit-learn's contract (issue 16).

The estimators are found, not listed: every public class with ``fit`` in
``pdmkit.models``, ``pdmkit.features`` and ``pdmkit.rul``. Each must be a scikit-learn
``BaseEstimator`` (or be listed in :data:`NOT_SKLEARN` with the reason), and runs
through the checks that apply to it:

* **array estimators** (``fit(X, y)`` on arrays or frames of features) run
  :func:`sklearn.utils.estimator_checks.check_estimator`, every check, with the ones
  that cannot hold listed in :data:`EXPECTED_FAILED` with the reason;
* **table estimators** (the RUL models, health indicators, regime normalisers: they
  fit on a *long table* of rows per unit and time with named columns, which
  scikit-learn's generated arrays cannot express) run the checks that do not feed
  data: constructible with defaults, nothing set in ``__init__``, ``get_params`` /
  ``set_params`` / ``clone`` round trips, ``repr``; and a ``predict`` before ``fit``
  raises scikit-learn's ``NotFittedError``.
"""

from __future__ import annotations

import importlib
import inspect

import numpy as np
import pandas as pd
import pytest
from sklearn.base import BaseEstimator, clone
from sklearn.exceptions import NotFittedError
from sklearn.utils import estimator_checks as checks

import pdmkit.errors

PACKAGES = ("pdmkit.models", "pdmkit.features", "pdmkit.rul")


def _public_estimators() -> dict[str, type]:
    found = {}
    for package in PACKAGES:
        module = importlib.import_module(package)
        for name in module.__all__:
            obj = getattr(module, name)
            if inspect.isclass(obj) and callable(getattr(obj, "fit", None)):
                found[f"{package}.{name}"] = obj
    return found


ESTIMATORS = _public_estimators()

#: estimator -> why it is not a scikit-learn estimator
NOT_SKLEARN: dict[str, str] = {}

#: array estimator -> {check: why it cannot hold}
EXPECTED_FAILED: dict[str, dict[str, str]] = {}

#: estimators whose fit data scikit-learn's generated arrays cannot be -> why; they
#: run the data-free checks of the table estimators
_ONE_RECORD = (
    "fit on one healthy record (time order matters, rows are not samples) and "
    "scored per record: "
)
DATA_FREE_ONLY: dict[str, str] = {
    "pdmkit.models.FractionalConditionClassifier": "fit(H, y) takes complex frequency "
    "responses at the frequencies `freq` it is built with; random real X are no FRFs",
    "pdmkit.models.DiagnosticMask": _ONE_RECORD + "a threshold band with hysteresis "
    "and delay on one symptom track",
    "pdmkit.models.SymbolicAnomaly": _ONE_RECORD + "a partition of the healthy signal; "
    "the measure is a distance between state probabilities",
    "pdmkit.models.PCAAnomaly": _ONE_RECORD + "principal directions of delay windows",
    "pdmkit.models.RBFAnomaly": _ONE_RECORD + "an RBF network's prediction error",
    "pdmkit.models.MLPAnomaly": _ONE_RECORD + "a perceptron's prediction error",
    "pdmkit.models.HammersteinWiener": "a dynamic model of one input/output record "
    "(fit(u, y) as fit(X, y), but rows are time steps, not independent samples)",
    "pdmkit.models.RecursiveARX": "a recursive (online) estimator of one time series; "
    "rows are time steps, not independent samples",
    "pdmkit.models.ParityEquations": _ONE_RECORD + "channel-to-channel ARX relations "
    "between measured outputs",
}

#: estimator -> the arguments it needs (no default can stand for them)
ARGUMENTS: dict[str, dict] = {
    "pdmkit.models.FractionalConditionClassifier": {"freq": np.linspace(1.0, 50.0, 20)},
    "pdmkit.rul.CovariateSurvivalModel": {"covariates": ["s0"]},
    "pdmkit.models.RecursiveARX": {"na": 2},
    "pdmkit.models.ParityEquations": {"pairs": [(0, 1)]},
}


def _make(name: str):
    return ESTIMATORS[name](**ARGUMENTS.get(name, {}))


#: estimators fitted on long tables (rows per unit and time, named columns)
TABLE_ESTIMATORS = sorted(
    name
    for name, cls in ESTIMATORS.items()
    if name.startswith("pdmkit.rul.") and name not in NOT_SKLEARN
)
ARRAY_ESTIMATORS = sorted(
    set(ESTIMATORS) - set(NOT_SKLEARN) - set(TABLE_ESTIMATORS) - set(DATA_FREE_ONLY)
)


def test_every_estimator_is_sklearn_or_listed() -> None:
    plain = sorted(n for n, c in ESTIMATORS.items() if not issubclass(c, BaseEstimator))
    assert plain == sorted(NOT_SKLEARN), (
        "estimators that are no BaseEstimator must be listed in NOT_SKLEARN with the "
        f"reason (and listed ones that are, removed): {plain}"
    )


def test_not_fitted_error_is_sklearns() -> None:
    assert issubclass(pdmkit.errors.NotFittedError, NotFittedError)
    assert issubclass(pdmkit.errors.NotFittedError, AttributeError | ValueError)


@pytest.mark.parametrize("name", ARRAY_ESTIMATORS)
def test_array_estimator_passes_sklearns_checks(name: str) -> None:
    checks.check_estimator(
        _make(name), expected_failed_checks=EXPECTED_FAILED.get(name, {})
    )


_DATA_FREE_CHECKS = (
    checks.check_no_attributes_set_in_init,
    checks.check_get_params_invariance,
    checks.check_set_params,
    checks.check_estimator_cloneable,
    checks.check_estimator_repr,
    checks.check_do_not_raise_errors_in_init_or_set_params,
)


@pytest.mark.parametrize("name", TABLE_ESTIMATORS + sorted(DATA_FREE_ONLY))
def test_estimator_keeps_the_parameter_contract(name: str) -> None:
    if name not in ARGUMENTS:
        checks.check_parameters_default_constructible(name, _make(name))
    for check in _DATA_FREE_CHECKS:
        check(name, _make(name))
    estimator = _make(name)
    assert clone(estimator).get_params().keys() == estimator.get_params().keys()


def _history() -> pd.DataFrame:
    rng = np.random.default_rng(0)
    return pd.DataFrame(
        {"unit": np.repeat([1, 2], 20), "time": np.tile(np.arange(20.0), 2)}
        | {f"s{i}": rng.normal(size=40) for i in range(3)}
    )


@pytest.mark.parametrize("name", TABLE_ESTIMATORS)
def test_table_estimator_refuses_to_predict_before_fit(name: str) -> None:
    estimator = _make(name)
    method = next(
        m for m in ("predict", "transform", "predict_rul") if hasattr(estimator, m)
    )
    with pytest.raises(NotFittedError):
        getattr(estimator, method)(_history())


#: estimators whose ``fit`` takes the output before the input, with the reason
OUTPUT_FIRST: dict[str, str] = {
    "pdmkit.models.RecursiveARX": "fit(y, u=None): pole tracking runs on the output "
    "alone (AR) far more often than with an input (ARX), so the output comes first "
    "and the input is optional (said in its docstring)",
}


@pytest.mark.parametrize("name", sorted(ESTIMATORS))
def test_fit_takes_the_input_before_the_output(name: str) -> None:
    """One argument order: ``fit(u, y)`` / ``fit(X, y)``, the exceptions listed."""
    params = list(inspect.signature(ESTIMATORS[name].fit).parameters)[1:]
    if "u" in params and "y" in params:
        output_first = params.index("y") < params.index("u")
        assert output_first == (name in OUTPUT_FIRST), (name, params)
    else:
        assert name not in OUTPUT_FIRST
