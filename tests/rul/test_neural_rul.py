"""The small torch RUL network (tiny configurations: each test takes seconds)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from pdmkit.errors import DataError, NotFittedError
from pdmkit.rul import NeuralRULModel, rmse

torch = pytest.importorskip("torch")
pytestmark = pytest.mark.torch

TINY = {
    "window": 8,
    "hidden": 8,
    "epochs": 4,
    "n_folds": 2,
    "batch_size": 64,
    "n_threads": 1,
    "max_rul": 40,
}


def _fleet(seed, n=14, cut=False):
    rng = np.random.default_rng(seed)
    rows, rul = [], []
    for u in range(n):
        life = int(rng.integers(50, 90))
        t = np.arange(1, life + 1)
        wear = np.clip((t - life + 45) / 45, 0, None) ** 1.5  # flat, then degrading
        stop = int(rng.integers(20, life - 3)) if cut else life
        rows.append(
            pd.DataFrame(
                {
                    "unit": u,
                    "cycle": t[:stop],
                    "s1": (wear + rng.normal(0, 0.05, life))[:stop],
                    "s2": (-wear + rng.normal(0, 0.05, life))[:stop],
                    "flat": 1.0,
                }
            )
        )
        rul.append(life - stop)
    return pd.concat(rows, ignore_index=True), np.array(rul, dtype=float)


def test_learns_better_than_a_constant_guess():
    train, _ = _fleet(0)
    test, rul = _fleet(1, n=20, cut=True)
    model = NeuralRULModel(**{**TINY, "epochs": 12}).fit(train)
    p = model.predict(test)
    truth = np.minimum(rul, 40)
    assert rmse(truth, p.estimate) < 0.7 * rmse(truth, np.full_like(truth, truth.mean()))
    assert model.dropped_ == {"flat": "constant over the training table"}
    assert (p.lower <= p.estimate).all() and (p.estimate <= p.upper).all()
    assert ((p.estimate >= 0) & (p.estimate <= 40)).all()
    assert list(model.history_.columns) == ["fold", "epoch", "loss"]


def test_same_seed_same_predictions_and_threads_restored():
    train, _ = _fleet(0, n=6)
    before = torch.get_num_threads()
    a = NeuralRULModel(**TINY, random_state=3).fit(train).predict(train)
    assert torch.get_num_threads() == before
    b = NeuralRULModel(**TINY, random_state=3).fit(train).predict(train)
    c = NeuralRULModel(**TINY, random_state=4).fit(train).predict(train)
    assert np.array_equal(a.estimate, b.estimate)
    assert not np.array_equal(a.estimate, c.estimate)


def test_history_shorter_than_the_window():
    train, _ = _fleet(0, n=6)
    short = train[(train.unit == 0) & (train.cycle <= 5)]
    model = NeuralRULModel(**TINY).fit(train)
    with pytest.raises(DataError, match=r"5 samples.*window=8"):
        model.predict(short)
    padded = NeuralRULModel(**TINY, pad="edge").fit(train).predict(short)
    assert np.isfinite(padded.estimate).all()


def test_censored_units_and_constant_features_are_rejected():
    train, _ = _fleet(0, n=6)
    with pytest.raises(DataError, match="censored"):
        NeuralRULModel(**TINY).fit(train.assign(failed=train.unit != 2))
    with pytest.raises(DataError, match="constant"):
        NeuralRULModel(["flat"], **TINY).fit(train)


def test_unfitted_and_bad_parameters():
    train, _ = _fleet(0, n=4)
    with pytest.raises(NotFittedError):
        NeuralRULModel().predict(train)
    with pytest.raises(ValueError, match="arch"):
        NeuralRULModel(arch="transformer").fit(train)
    with pytest.raises(ValueError, match="window"):
        NeuralRULModel(window=1).fit(train)


def test_cnn_variant_runs():
    train, _ = _fleet(0, n=6)
    p = NeuralRULModel(**TINY, arch="cnn").fit(train).predict(train)
    assert len(p) == 6
