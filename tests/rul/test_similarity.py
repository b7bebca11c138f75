"""Residual, pairwise and hash similarity models."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from pdmkit.errors import DataError, NotFittedError
from pdmkit.rul import HashSimilarityModel, PairwiseSimilarityModel, ResidualSimilarityModel
from pdmkit.rul._similarity import _dtw_subsequence, _sliding_corr, _sliding_ss

LIVES = [60, 75, 90, 105, 120, 135, 150]


def _fleet(noise=0.0, seed=0, offsets=None):
    """Units whose indicator rises as (t / life)^2 (+ an initial-wear offset)."""
    rng = np.random.default_rng(seed)
    rows = []
    for u, life in enumerate(LIVES):
        t = np.arange(1.0, life + 1)
        start = 0.0 if offsets is None else offsets[u]
        hi = start + (t / life) ** 2 + rng.normal(0, noise, t.size)
        rows.append(pd.DataFrame({"unit": u, "cycle": t, "hi": hi}))
    return pd.concat(rows, ignore_index=True)


def _history(unit, n, table):
    return table[(table.unit == unit) & (table.cycle <= n)].assign(unit="test")


# ------------------------------------------------------------------ building blocks
def test_sliding_sum_of_squares_matches_brute_force(rng):
    f = rng.normal(size=(40, 2))
    x = rng.normal(size=(7, 2))
    ref = [np.sum((x - f[tau : tau + 7]) ** 2) for tau in range(34)]
    assert np.allclose(_sliding_ss(f, x), ref)


def test_sliding_correlation_matches_numpy(rng):
    f = rng.normal(size=(30, 1))
    x = rng.normal(size=(6, 1))
    ref = [1 - np.corrcoef(x[:, 0], f[tau : tau + 6, 0])[0, 1] for tau in range(25)]
    assert np.allclose(_sliding_corr(f, x), ref)


def _naive_subsequence_dtw(x, y, open_begin):
    n, m = len(x), len(y)
    D = np.full((n, m), np.inf)
    for i in range(n):
        for j in range(m):
            c = np.abs(x[i] - y[j]).sum()
            if i == 0:
                D[i, j] = c if open_begin else c + (D[0, j - 1] if j else 0.0)
                continue
            best = D[i - 1, j]
            if j:
                best = min(best, D[i - 1, j - 1], D[i, j - 1])
            D[i, j] = c + best
    end = int(np.argmin(D[-1]))
    return D[-1, end] / n, end


@pytest.mark.parametrize("open_begin", [True, False])
def test_vectorised_dtw_matches_the_textbook_recursion(rng, open_begin):
    x = rng.normal(size=(9, 1))
    paths = [rng.normal(size=(length, 1)) for length in (12, 20, 15)]
    cost, end = _dtw_subsequence(x, paths, open_begin)
    for j, y in enumerate(paths):
        ref_cost, ref_end = _naive_subsequence_dtw(x, y, open_begin)
        assert cost[j] == pytest.approx(ref_cost)
        assert end[j] == ref_end


# ------------------------------------------------------------------ finding the unit
MODELS = [
    ResidualSimilarityModel(k=1, degree=2),
    ResidualSimilarityModel(k=1, degree=2, align="start"),
    PairwiseSimilarityModel(k=1),
    PairwiseSimilarityModel(k=1, align="start"),
    PairwiseSimilarityModel(k=1, distance="absolute"),
    PairwiseSimilarityModel(k=1, distance="correlation"),
    PairwiseSimilarityModel(k=1, distance="dtw"),
    HashSimilarityModel(k=1, window=10, features=("mean", "slope", "last", "age")),
]


@pytest.mark.parametrize("model", MODELS, ids=repr)
def test_a_copy_of_a_training_unit_is_matched_exactly(model):
    train = _fleet()
    test = _history(3, 70, train)  # unit 3 lives 105 cycles: RUL 35 after cycle 70
    p = model.fit(train).predict(test)
    assert p.extra["nearest"][0] == (3,)
    assert p.estimate[0] == pytest.approx(35.0)


def test_best_alignment_handles_initial_wear():
    # the test unit starts 30 % into unit 4's life; start-alignment is fooled, best is not
    train = _fleet()
    t = np.arange(1.0, 121)
    hi = (t / 120) ** 2
    late = pd.DataFrame({"unit": "worn", "cycle": np.arange(1.0, 51), "hi": hi[36:86]})
    best = ResidualSimilarityModel(k=1, degree=2).fit(train).predict(late)
    start = ResidualSimilarityModel(k=1, degree=2, align="start").fit(train).predict(late)
    assert best.estimate[0] == pytest.approx(120 - 86, abs=1)
    assert abs(start.estimate[0] - 34) > 10


def test_k_neighbours_give_median_and_quantile_interval():
    train = _fleet(noise=0.01)
    model = ResidualSimilarityModel(k=5, level=0.8).fit(train)
    p = model.predict(_history(3, 50, train))
    assert len(p.extra["nearest"][0]) == 5
    assert p.lower[0] <= p.estimate[0] <= p.upper[0]
    frame = p.to_pandas()
    assert {"nearest", "distance"} <= set(frame.columns)


def test_k_is_capped_at_the_number_of_training_units():
    train = _fleet()
    p = PairwiseSimilarityModel(k=50).fit(train).predict(_history(0, 30, train))
    assert len(p.extra["nearest"][0]) == len(LIVES)


def test_max_rul_caps_estimates_and_intervals():
    train = _fleet()
    p = ResidualSimilarityModel(k=3, max_rul=20).fit(train).predict(_history(6, 10, train))
    assert p.estimate[0] == 20 and p.upper[0] == 20


def test_trajectory_ends_at_the_unit_failure():
    train = _fleet(noise=0.005)
    test = train[train.unit == 2].assign(unit="copy")
    path = (
        ResidualSimilarityModel(k=1, degree=2).fit(train).predict_trajectory(test, every=15)
    )
    assert path.time[-1] == 90 and path.estimate[-1] == pytest.approx(0.0, abs=2)
    assert len(path) == len(range(1, 91, 15)) + 1


# ------------------------------------------------------------------ clear errors
def test_censored_training_units_are_rejected():
    train = _fleet()
    train["failed"] = train["unit"] != 2
    with pytest.raises(DataError, match="censored"):
        ResidualSimilarityModel().fit(train)


def test_constant_indicator_is_rejected():
    train = _fleet().assign(hi=1.0)
    with pytest.raises(DataError, match="constant"):
        PairwiseSimilarityModel().fit(train)


def test_history_shorter_than_the_hash_window():
    train = _fleet()
    short = _history(1, 5, train)
    model = HashSimilarityModel(window=20).fit(train)
    with pytest.raises(DataError, match=r"5 samples.*window=20"):
        model.predict(short)
    padded = HashSimilarityModel(window=20, pad="edge").fit(train).predict(short)
    assert np.isfinite(padded.estimate[0])


def test_unfitted_and_bad_parameters():
    train = _fleet()
    with pytest.raises(NotFittedError):
        ResidualSimilarityModel().predict(train)
    with pytest.raises(ValueError, match="distance"):
        PairwiseSimilarityModel(distance="cosine").fit(train)
    with pytest.raises(ValueError, match="align"):
        ResidualSimilarityModel(align="end").fit(train)
    with pytest.raises(DataError, match=r"indicator column.*nope.*not in the table"):
        ResidualSimilarityModel(indicator="nope").fit(train)
    with pytest.raises(ValueError, match="Invalid parameter"):
        HashSimilarityModel().set_params(widow=3)
