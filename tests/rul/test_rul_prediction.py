"""The RULPrediction result object."""

from __future__ import annotations

import matplotlib
import numpy as np
import pytest

from pdmkit.errors import DataError
from pdmkit.rul import RULPrediction

matplotlib.use("Agg")


def _pred():
    return RULPrediction(
        [1, 1, 2],
        [10, 20, 15],
        [30.0, 20.0, 8.0],
        [25.0, 15.0, 2.0],
        [40.0, 26.0, 12.0],
        level=0.8,
        model="m",
        extra={"p_fail": np.array([1.0, 1.0, 0.9])},
    )


def test_to_pandas_has_the_columns_and_extras():
    frame = _pred().to_pandas()
    assert frame.columns.tolist() == ["unit", "time", "rul", "lower", "upper", "p_fail"]
    assert frame["rul"].tolist() == [30.0, 20.0, 8.0]


def test_evaluate_accepts_a_mapping_per_unit():
    p = RULPrediction(["a", "b"], [1, 1], [10.0, 20.0], [5.0, 19.0], [15.0, 21.0])
    m = p.evaluate({"a": 14.0, "b": 25.0})
    assert m["coverage"] == 0.5
    assert m["mae"] == pytest.approx(4.5)
    with pytest.raises(DataError, match="no value for units"):
        p.evaluate({"a": 1.0})


def test_shapes_are_checked():
    with pytest.raises(DataError, match="lower"):
        RULPrediction([1, 2], [1, 2], [1.0, 2.0], [1.0], [1.0, 2.0])


def test_plot_modes():
    import matplotlib.pyplot as plt

    ax = _pred().plot(true=[30.0, 20.0, 10.0])  # trajectory mode: unit 1 has two rows
    assert ax.get_xlabel() == "time"
    plt.close("all")
    single = RULPrediction([1, 2], [5, 5], [10.0, np.inf], [5.0, 8.0], [15.0, np.inf])
    ax = single.plot(true=[12.0, 30.0])
    assert ax.get_xlabel() == "true RUL"
    ax = single.plot()
    assert ax.get_xlabel() == "unit"
    plt.close("all")


def test_repr_names_model_and_counts():
    assert "2 units" in repr(_pred()) and "m" in repr(_pred())
