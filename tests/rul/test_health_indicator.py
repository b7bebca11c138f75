"""Health-indicator construction: smoothing, regimes, ranking, fusion."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from sklearn.pipeline import make_pipeline

from pdmkit.errors import DataError, NotFittedError
from pdmkit.rul import (
    HealthIndicator,
    RegimeNormalizer,
    ResidualSimilarityModel,
    prognostic_ranking,
    smooth_indicators,
)


def _fleet(rng, n=8, noise=0.0, lives=None):
    rows = []
    lives = lives or [int(x) for x in rng.integers(60, 120, n)]
    for u, life in enumerate(lives):
        t = np.arange(1, life + 1)
        frac = (t - 1) / (life - 1)
        rows.append(
            pd.DataFrame(
                {
                    "unit": u,
                    "cycle": t,
                    "temp": 500 + 30 * frac + rng.normal(0, noise * 30, life),
                    "flow": 2.0 - 0.5 * frac + rng.normal(0, noise * 0.5, life),
                    "junk": rng.normal(0, 1, life),
                    "const": 7.0,
                }
            )
        )
    return pd.concat(rows, ignore_index=True)


def test_smoothing_matches_pandas_per_unit_and_keeps_row_order(rng):
    table = _fleet(rng, n=3, noise=0.2).sample(frac=1.0, random_state=1)  # shuffled rows
    out = smooth_indicators(table, ["temp"], span=7, unit="unit", time="cycle")
    assert out.index.equals(table.index)
    for _, part in table.groupby("unit"):
        ref = part.sort_values("cycle")["temp"].ewm(span=7).mean()
        assert np.allclose(out.loc[ref.index, "temp"], ref)


def test_smoothing_is_causal(rng):
    table = _fleet(rng, n=1, noise=0.2)
    changed = table.copy()
    changed.loc[changed.index[-1], "temp"] += 1000.0  # change only the last sample
    for method in ("ewm", "moving_average", "moving_median"):
        a = smooth_indicators(table, "temp", method=method, span=5)["temp"].to_numpy()
        b = smooth_indicators(changed, "temp", method=method, span=5)["temp"].to_numpy()
        assert np.array_equal(a[:-1], b[:-1])


def test_moving_average_by_hand():
    t = pd.DataFrame({"unit": 1, "time": [1, 2, 3, 4], "x": [0.0, 2.0, 4.0, 10.0]})
    out = smooth_indicators(t, "x", method="moving_average", span=3)
    assert out["x"].tolist() == [0.0, 1.0, 2.0, 16 / 3]


def test_regime_normalizer_removes_regime_offsets(rng):
    n = 600
    regime = rng.integers(0, 3, n)
    table = pd.DataFrame(
        {
            "unit": np.repeat([1, 2, 3], n // 3),
            "time": np.tile(np.arange(n // 3), 3),
            "alt": np.array([0.0, 20.0, 35.0])[regime] + rng.normal(0, 0.01, n),
            "mach": np.array([0.0, 0.7, 0.84])[regime],
            "t2": np.array([100.0, 200.0, 400.0])[regime] + rng.normal(0, 2, n),
            "flat": 3.0,
        }
    )
    norm = RegimeNormalizer(settings=["alt", "mach"], n_regimes=3).fit(table)
    z = norm.transform(table)
    labels = norm.regimes(table)
    assert len(set(labels)) == 3
    for r in range(3):
        part = z.loc[labels == r, "t2"]
        assert abs(part.mean()) < 1e-9 and part.std() == pytest.approx(1.0)
    assert norm.constant_ == ["flat"]
    assert (z["flat"] == 0).all()


def test_regime_normalizer_needs_settings_for_several_regimes():
    t = pd.DataFrame({"unit": 1, "time": [1, 2, 3], "x": [1.0, 2.0, 3.0]})
    with pytest.raises(ValueError, match="settings"):
        RegimeNormalizer(n_regimes=2).fit(t)


def test_prognostic_ranking_by_hand():
    t = pd.DataFrame(
        {
            "unit": [1] * 4 + [2] * 4,
            "time": [1, 2, 3, 4] * 2,
            "up": [0.0, 1, 2, 3, 0, 2, 4, 6],  # monotonic, trendable
            "zigzag": [0.0, 1, 0, 1, 1, 0, 1, 0],
        }
    )
    r = prognostic_ranking(t)
    assert r.index.tolist() == ["up", "zigzag"]
    assert r.loc["up", "monotonicity"] == 1.0
    assert r.loc["up", "trendability"] == pytest.approx(1.0)
    # ends 3 and 6: std 2.1213, mean |start - end| 4.5
    assert r.loc["up", "prognosability"] == pytest.approx(
        np.exp(-np.std([3, 6], ddof=1) / 4.5)
    )
    assert r.loc["zigzag", "monotonicity"] == pytest.approx(1 / 3)


def test_linear_health_indicator_recovers_life_fraction_exactly(rng):
    table = _fleet(rng, noise=0.0)
    hi = HealthIndicator(["temp", "flow"]).fit(table)
    out = hi.transform(table)
    frac = out.groupby("unit")["cycle"].transform(
        lambda c: (c - c.min()) / (c.max() - c.min())
    )
    assert np.allclose(out["hi"], frac, atol=1e-9)


def test_pca_health_indicator_runs_from_0_to_1(rng):
    table = _fleet(rng, noise=0.0)
    out = HealthIndicator(["temp", "flow"], method="pca").fit_transform(table)
    ends = out.groupby("unit")["hi"].agg(["first", "last"])
    assert np.allclose(ends["first"], 0.0, atol=1e-9)
    assert np.allclose(ends["last"], 1.0, atol=1e-9)


def test_feature_selection_keeps_the_trending_candidates(rng):
    table = _fleet(rng, noise=0.3)
    hi = HealthIndicator(n_features=2, smoothing=5).fit(table)
    assert sorted(hi.selected_) == ["flow", "temp"]
    assert hi.dropped_["const"] == "constant over the training table"
    assert hi.dropped_["junk"] == "ranked below the best n_features"
    assert hi.ranking_.index[-1] in ("junk", "const")


def test_all_constant_candidates_give_a_clear_error():
    t = pd.DataFrame({"unit": [1, 1, 2, 2], "time": [1, 2, 1, 2], "a": 1.0, "b": 2.0})
    with pytest.raises(DataError, match="constant"):
        HealthIndicator().fit(t)


def test_linear_fusion_refuses_censored_units(rng):
    table = _fleet(rng, n=3)
    table["failed"] = table["unit"] != 0
    with pytest.raises(DataError, match="censored"):
        HealthIndicator(["temp"]).fit(table)


def test_transform_before_fit_raises():
    with pytest.raises(NotFittedError):
        HealthIndicator().transform(pd.DataFrame({"unit": [1], "time": [1], "x": [1.0]}))


def test_health_indicator_composes_in_a_sklearn_pipeline(rng):
    train = _fleet(rng, n=10, noise=0.05)
    test = train[(train.unit == 3) & (train.cycle <= 40)]
    pipe = make_pipeline(HealthIndicator(["temp", "flow"]), ResidualSimilarityModel(k=3))
    pred = pipe.fit(train).predict(test)
    life = train.loc[train.unit == 3, "cycle"].max()
    assert pred.estimate[0] == pytest.approx(life - 40, abs=15)
