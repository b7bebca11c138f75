"""A trained RUL model in one object: the health indicator and the estimator on it.

:class:`RULPipeline` is what ``pdmkit rul`` saves (``model.pdmkit`` in its output
folder) and what ``pdmkit rul --trained MODEL --history TABLE`` loads to answer a
unit's RUL from its history so far: the raw columns go in, the indicator is built
the way it was on the training units, and the estimator predicts.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import pandas as pd
from sklearn.base import BaseEstimator

from pdmkit.rul._base import RULModel, check_fitted, check_rul_model

if TYPE_CHECKING:
    from typing import Self

    from pdmkit.rul._indicators import HealthIndicator
    from pdmkit.rul._result import RULPrediction


class RULPipeline(BaseEstimator):
    """A health indicator (optional) followed by a RUL model.

    Parameters
    ----------
    indicator : HealthIndicator or None
        Maps the raw columns of a long table to the indicator column the model reads
        (``fit_transform`` on the training table, ``transform`` on histories); None
        passes the table through (models that read the sensors themselves, e.g.
        :class:`NeuralRULModel`, :class:`ReliabilitySurvivalModel`).
    model : estimator
        Any pdmkit RUL model (``fit``, ``predict``, ``predict_trajectory``).

    Attributes
    ----------
    n_units_ : int
        Training units the model saw. ``indicator`` and ``model`` are fitted in place,
        as in a scikit-learn ``Pipeline``.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from pdmkit.rul import HealthIndicator, LinearDegradationModel, RULPipeline
    >>> rng = np.random.default_rng(0)
    >>> rows = []
    >>> for u, life in enumerate([40, 50, 60, 45]):
    ...     t = np.arange(life + 1.0)
    ...     rows.append(pd.DataFrame({"unit": u, "time": t,
    ...         "s1": t / life + rng.normal(0, 0.02, t.size),
    ...         "s2": -2 * t / life + rng.normal(0, 0.04, t.size)}))
    >>> train = pd.concat(rows, ignore_index=True)
    >>> pipe = RULPipeline(HealthIndicator(["s1", "s2"]), LinearDegradationModel())
    >>> history = train[(train.unit == 1) & (train.time <= 30)]
    >>> rul = pipe.fit(train).predict(history)   # true RUL: 50 - 30 = 20 cycles
    >>> bool(abs(rul.estimate[0] - 20) < 3), rul.unit.tolist()
    (True, [1])
    """

    def __init__(
        self, indicator: HealthIndicator | None = None, model: RULModel | None = None
    ) -> None:
        self.indicator = indicator
        self.model = model

    def _inputs(self, table: pd.DataFrame) -> pd.DataFrame:
        return table if self.indicator is None else self.indicator.transform(table)

    def fit(self, table: pd.DataFrame, y: object = None) -> Self:
        """Fit the indicator on ``table``, then the model on the indicator."""
        check_rul_model(self.model, "RULPipeline")
        data = table if self.indicator is None else self.indicator.fit_transform(table)
        self.model.fit(data)
        self.n_units_ = self.model.n_units_
        return self

    def transform(self, table: pd.DataFrame) -> pd.DataFrame:
        """The table with the indicator column the model reads."""
        check_fitted(self, "n_units_")
        return self._inputs(table)

    def predict(self, table: pd.DataFrame) -> RULPrediction:
        """RUL of each unit of ``table`` at its last row (a :class:`RULPrediction`)."""
        check_fitted(self, "n_units_")
        return self.model.predict(self._inputs(table))

    def predict_trajectory(self, table: pd.DataFrame, **kwargs: Any) -> RULPrediction:
        """RUL at every point of each unit's history (see the model's method)."""
        check_fitted(self, "n_units_")
        return self.model.predict_trajectory(self._inputs(table), **kwargs)
