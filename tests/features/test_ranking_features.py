"""Feature ranking against scipy.stats and the prognostic metrics' definitions."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import scipy.stats
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.utils.estimator_checks import parametrize_with_checks

import pdmkit.features as pf
from pdmkit.errors import DataError


@pytest.fixture
def table(rng):
    n = 90
    label = np.repeat(["ok", "ir", "or"], n // 3)
    shift = pd.Series(label).map({"ok": 0.0, "ir": 1.5, "or": -0.7}).to_numpy()
    return pd.DataFrame(
        {
            "member": [f"m{i}" for i in range(n)],
            "label": label,
            "load": rng.integers(0, 3, n),  # condition column: no '/', not ranked
            "de/stats/RMS": rng.normal(size=n) + shift,
            "de/stats/Kurtosis": rng.normal(size=n) + 0.3 * shift,
            "de/stats/Mean": rng.normal(size=n),
            "de/spectral/PeakFreq1": rng.choice([10.0, 20.0, 30.0], n) + 10 * (shift > 1),
            "de/stats/Const": np.full(n, 2.0),
        }
    )


FEATURES = ["de/stats/RMS", "de/stats/Kurtosis", "de/stats/Mean", "de/spectral/PeakFreq1"]


@pytest.mark.parametrize(
    ("method", "reference"),
    [("kruskal", scipy.stats.kruskal), ("anova", scipy.stats.f_oneway)],
)
def test_scores_match_scipy_per_feature(table, method, reference):
    r = pf.rank_features(table, "label", method=method)
    ranked = r.to_pandas().set_index("feature")
    groups = [g for _, g in table.groupby("label")]
    for f in FEATURES:
        stat, p = reference(*[g[f].to_numpy() for g in groups])
        assert ranked.loc[f, "score"] == pytest.approx(stat, rel=1e-10)
        assert ranked.loc[f, "p_value"] == pytest.approx(p, rel=1e-8, abs=1e-300)
    assert set(ranked.index) == {*FEATURES, "de/stats/Const"}  # load, label not ranked
    assert ranked["method"].eq(method).all()


def test_order_and_constant_feature_last(table):
    r = pf.rank_features(table, "label")
    assert r.top(1) == ["de/stats/RMS"]
    assert r.features[-1] == "de/stats/Const"
    df = r.to_pandas()
    assert df["rank"].tolist() == list(range(1, len(df) + 1))
    assert df["score"].iloc[:-1].is_monotonic_decreasing
    assert df.set_index("feature").loc["de/stats/Const", "note"] == "constant feature"
    assert "de/stats/Const" not in r.top(10)


def test_nan_values_are_left_out_with_a_note(table):
    table = table.copy()
    table.loc[[0, 40], "de/stats/RMS"] = np.nan
    table["de/stats/AllNaN"] = np.nan
    ranked = pf.rank_features(table, "label").to_pandas().set_index("feature")
    kept = table.dropna(subset=["de/stats/RMS"])
    h, _ = scipy.stats.kruskal(*[g["de/stats/RMS"] for _, g in kept.groupby("label")])
    assert ranked.loc["de/stats/RMS", "score"] == pytest.approx(h, rel=1e-10)
    assert "2 NaN/inf value(s) left out" in ranked.loc["de/stats/RMS", "note"]
    assert np.isnan(ranked.loc["de/stats/AllNaN", "score"])
    assert ranked.index[-1] in {"de/stats/AllNaN", "de/stats/Const"}


def test_ties_use_the_tie_correction(rng):
    y = np.repeat([0, 1, 2], 20)
    x = rng.integers(0, 4, 60).astype(float) + y  # many ties
    h, p = scipy.stats.kruskal(*[x[y == k] for k in range(3)])
    r = pf.rank_features(pd.DataFrame({"f": x}), y)
    assert r.scores["f"] == pytest.approx(h, rel=1e-12)
    assert r.p_values["f"] == pytest.approx(p, rel=1e-9)


def test_labels_as_series_array_and_explicit_features(table):
    by_name = pf.rank_features(table, "label").scores
    by_series = pf.rank_features(table, table["label"]).scores
    by_array = pf.rank_features(table, table["label"].to_numpy()).scores
    pd.testing.assert_series_equal(by_name, by_series)
    pd.testing.assert_series_equal(by_name, by_array)
    only = pf.rank_features(table, "label", features=["load", "de/stats/Mean"])
    assert sorted(only.features) == ["de/stats/Mean", "load"]


def test_supervised_errors(table):
    with pytest.raises(DataError, match="labels are needed"):
        pf.rank_features(table)
    with pytest.raises(DataError, match="'fault' is not a column"):
        pf.rank_features(table, "fault")
    with pytest.raises(DataError, match="1 distinct class"):
        pf.rank_features(table, np.zeros(len(table)))
    with pytest.raises(ValueError, match="method must be one of"):
        pf.rank_features(table, "label", method="mutual_info")
    with pytest.raises(DataError, match="one per table row"):
        pf.rank_features(table, [0, 1])


# --------------------------------------------------------------------------- prognostics
@pytest.fixture
def run_to_failure(rng):
    rows = []
    for unit, life in enumerate([40, 55, 70, 90], start=1):
        t = np.arange(life)
        frac = t / (life - 1)
        rows.append(
            pd.DataFrame(
                {
                    "unit": unit,
                    "time": t,
                    "Rising": np.exp(2 * frac) + 0.001 * t,  # strictly monotonic
                    "Noise": rng.normal(size=life),
                    "Wear": frac**2 + 0.02 * rng.normal(size=life),
                    "Offset": 5 * unit + frac,  # same shape, different levels
                }
            )
        )
    frame = pd.concat(rows, ignore_index=True)
    return frame.sample(frac=1.0, random_state=0)  # shuffled: time orders it back


def _reference_monotonicity(frame, feature):
    values = []
    for _, g in frame.sort_values("time").groupby("unit"):
        d = np.diff(g[feature].to_numpy())
        values.append(abs((d > 0).sum() - (d < 0).sum()) / (len(g) - 1))
    return np.mean(values)


def test_monotonicity(run_to_failure):
    r = pf.rank_features(run_to_failure, method="monotonicity")
    assert r.scores["Rising"] == pytest.approx(1.0)
    assert r.scores["Noise"] < 0.2
    for f in ("Noise", "Wear"):
        assert r.scores[f] == pytest.approx(_reference_monotonicity(run_to_failure, f))
    assert r.features[0] in {"Rising", "Offset"}


def test_trendability(run_to_failure):
    r = pf.rank_features(run_to_failure, method="trendability")
    assert r.scores["Rising"] == pytest.approx(1.0, abs=1e-3)
    assert r.scores["Wear"] > 0.9
    assert r.scores["Noise"] < 0.3
    # definition: min |corr| of the paths resampled to the shortest length
    paths = []
    for _, g in run_to_failure.sort_values("time").groupby("unit"):
        life = (g["time"] - g["time"].min()) / (g["time"].max() - g["time"].min())
        paths.append((life.to_numpy(), g["Noise"].to_numpy()))
    grid = np.linspace(0, 1, min(len(v) for _, v in paths))
    resampled = np.array([np.interp(grid, t, v) for t, v in paths])
    corr = np.abs(np.corrcoef(resampled))[~np.eye(4, dtype=bool)]
    assert r.scores["Noise"] == pytest.approx(corr.min())


def test_prognosability(run_to_failure):
    r = pf.rank_features(run_to_failure, method="prognosability")
    ordered = run_to_failure.sort_values("time").groupby("unit")["Offset"]
    start, end = ordered.first(), ordered.last()
    expected = np.exp(-np.std(end, ddof=1) / np.mean(np.abs(start - end)))
    assert r.scores["Offset"] == pytest.approx(expected)
    # all units fail at the same value: prognosability close to 1
    assert r.scores["Rising"] > 0.99
    assert r.scores["Offset"] < 0.01


def test_prognostic_methods_take_no_labels(run_to_failure):
    with pytest.raises(ValueError, match="takes no labels"):
        pf.rank_features(run_to_failure, "unit", method="monotonicity")


def test_single_unit_trendability_is_undefined(run_to_failure):
    one = run_to_failure[run_to_failure["unit"] == 1]
    r = pf.rank_features(one, method="trendability")
    assert r.scores.isna().all()
    assert r.notes["Wear"] == "trendability needs at least two units"


# --------------------------------------------------------------------------- result object
def test_plot_returns_axes_with_the_top_features(table):
    import matplotlib.pyplot as plt

    r = pf.rank_features(table, "label")
    ax = r.plot(k=3)
    labels = [t.get_text() for t in ax.get_yticklabels()]
    assert labels[::-1] == r.top(3)  # best at the top
    _, ax2 = plt.subplots()
    assert r.plot(ax=ax2) is ax2
    plt.close("all")


# --------------------------------------------------------------------------- selector
@parametrize_with_checks([pf.SelectTopRanked(), pf.SelectTopRanked(k=2, method="anova")])
def test_select_top_ranked_passes_check_estimator(estimator, check):
    """The full scikit-learn estimator check suite (check_array_api_input skips itself
    unless SCIPY_ARRAY_API is set)."""
    check(estimator)


def test_selector_keeps_the_informative_columns(table):
    X = table[[*FEATURES, "de/stats/Const"]]
    y = table["label"]
    sel = pf.SelectTopRanked(k=2).fit(X, y)
    best_two = pf.rank_features(table, "label").top(2)
    assert "de/stats/RMS" in best_two
    # transform keeps the input order of the kept columns
    assert list(sel.get_feature_names_out()) == [f for f in FEATURES if f in best_two]
    assert sel.transform(X).shape == (len(X), 2)
    assert sel.ranking_.features[-1] == "de/stats/Const"
    np.testing.assert_allclose(
        sel.scores_[:4], pf.rank_features(table, "label").scores[FEATURES].to_numpy()
    )


def test_selector_in_a_pipeline(table):
    from sklearn.linear_model import LogisticRegression

    X = table[FEATURES].to_numpy()
    y = table["label"].to_numpy()
    pipe = make_pipeline(StandardScaler(), pf.SelectTopRanked(k=1), LogisticRegression())
    pipe.fit(X, y)
    assert pipe.named_steps["selecttopranked"].selected_.tolist() == [0]
    assert pipe.score(X, y) > 0.6


def test_selector_rejects_bad_parameters(table):
    X, y = table[FEATURES], table["label"]
    with pytest.raises(ValueError, match="k must be a positive integer"):
        pf.SelectTopRanked(k=0).fit(X, y)
    with pytest.raises(ValueError, match="use rank_features"):
        pf.SelectTopRanked(method="monotonicity").fit(X, y)
    with pytest.raises(ValueError, match="needs at least two classes"):
        pf.SelectTopRanked().fit(X, np.zeros(len(X)))
