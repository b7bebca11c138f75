"""Fisher ratio, ROC AUC, Bhattacharyya distance and ranking stability.

Each score is checked against an independent computation (numpy by hand, scikit-learn,
the closed form for Gaussians); the saturation tests show what the issue asked for:
where Kruskal-Wallis H is the same for every fully-separating feature, Fisher and
Bhattacharyya still order them by the gap between the classes over their spread.
"""

from __future__ import annotations

import json
from itertools import combinations

import numpy as np
import pandas as pd
import pytest
import scipy.stats
from sklearn.metrics import roc_auc_score
from sklearn.model_selection import StratifiedKFold

import pdmkit.features as pf
from pdmkit.errors import DataError

CLASS_METHODS = ("kruskal", "anova", "fisher", "auc", "bhattacharyya")


@pytest.fixture
def three_classes(rng):
    n = 60
    label = np.repeat(["ok", "ir", "or"], n // 3)
    shift = pd.Series(label).map({"ok": 0.0, "ir": 1.5, "or": -0.7}).to_numpy()
    return pd.DataFrame(
        {
            "label": label,
            "de/stats/RMS": rng.normal(size=n) + shift,
            "de/stats/Kurtosis": rng.normal(size=n) * (1 + (shift > 1)) + 0.3 * shift,
            "de/stats/Mean": rng.normal(size=n),
            "de/spectral/PeakFreq1": rng.choice([10.0, 20.0, 30.0], n) + 10 * (shift > 1),
        }
    )


# --------------------------------------------------------------------------- fisher
def _fisher_by_hand(x, y):
    mu = x.mean()
    between = within = 0.0
    for c in np.unique(y):
        xc = x[y == c]
        between += len(xc) * (xc.mean() - mu) ** 2
        within += ((xc - xc.mean()) ** 2).sum()
    return between / within


def test_fisher_ratio_on_a_tiny_table_by_hand():
    table = pd.DataFrame(
        {
            "a": [1.0, 2.0, 3.0, 7.0, 8.0, 9.5, 4.0],
            "b": [0.5, -1.0, 2.0, 1.0, 0.0, 3.0, 1.5],
            "y": ["p", "p", "p", "q", "q", "q", "q"],
        }
    )
    r = pf.rank_features(table, "y", method="fisher", features=["a", "b"])
    y = table["y"].to_numpy()
    for f in ("a", "b"):
        assert r.scores[f] == pytest.approx(_fisher_by_hand(table[f].to_numpy(), y))
    # column a in fractions: means 2 and 57/8, grand mean 69/14; between-class sum of
    # squares 5043/112, within 2 + 259/16 = 291/16
    assert r.scores["a"] == pytest.approx(1681 / 679, rel=1e-12)


def test_fisher_ratio_many_classes_and_its_f_test(three_classes):
    r = pf.rank_features(three_classes, "label", method="fisher")
    anova = pf.rank_features(three_classes, "label", method="anova")
    y = three_classes["label"].to_numpy()
    n, k = len(y), 3
    for f in r.features:
        x = three_classes[f].to_numpy()
        assert r.scores[f] == pytest.approx(_fisher_by_hand(x, y), rel=1e-12)
        # F = J (N - k) / (k - 1): the same p-value as the one-way ANOVA
        f_stat, p = scipy.stats.f_oneway(*[x[y == c] for c in np.unique(y)])
        assert r.scores[f] * (n - k) / (k - 1) == pytest.approx(f_stat, rel=1e-10)
        assert r.p_values[f] == pytest.approx(p, rel=1e-8)
    assert r.features == anova.features  # a rescaled F: the same order


# --------------------------------------------------------------------------- auc
@pytest.mark.parametrize("n_classes", [2, 4])
def test_auc_matches_sklearn_one_vs_rest(rng, n_classes):
    y = np.repeat(np.arange(n_classes), 100 // n_classes)
    x_shift = rng.normal(size=100) + 0.8 * y
    x_ties = rng.integers(0, 5, 100).astype(float) - 0.5 * y  # many ties, falling
    table = pd.DataFrame({"up": x_shift, "down": x_ties})
    r = pf.rank_features(table, y, method="auc")
    for f in ("up", "down"):
        aucs = [roc_auc_score(y == c, table[f]) for c in range(n_classes)]
        expected = np.mean([max(a, 1 - a) for a in aucs])
        assert r.scores[f] == pytest.approx(expected, rel=1e-12)
    assert r.p_values.isna().all()
    assert 0.5 <= r.scores.min() <= r.scores.max() <= 1.0


# --------------------------------------------------------------------------- bhattacharyya
def _bhattacharyya_gauss(m1, v1, m2, v2):
    return (m1 - m2) ** 2 / (4 * (v1 + v2)) + 0.5 * np.log(
        (v1 + v2) / (2 * np.sqrt(v1 * v2))
    )


def test_bhattacharyya_closed_form_for_two_gaussians(rng):
    n = 20_000
    y = np.repeat([0, 1], n)
    x = np.r_[rng.normal(0.0, 1.0, n), rng.normal(2.0, 2.0, n)]
    r = pf.rank_features(pd.DataFrame({"x": x}), y, method="bhattacharyya")
    # the plug-in estimate: the closed form at the sample moments (ddof = 1)
    a, b = x[:n], x[n:]
    plug_in = _bhattacharyya_gauss(a.mean(), a.var(ddof=1), b.mean(), b.var(ddof=1))
    assert r.scores["x"] == pytest.approx(plug_in, rel=1e-10)
    # ... close to the true distance: 4 / 20 + ln(5 / 4) / 2
    assert r.scores["x"] == pytest.approx(0.2 + 0.5 * np.log(1.25), rel=0.03)


def test_bhattacharyya_averages_the_class_pairs(three_classes):
    r = pf.rank_features(three_classes, "label", method="bhattacharyya")
    x = three_classes["de/stats/Kurtosis"].to_numpy()
    y = three_classes["label"].to_numpy()
    parts = [x[y == c] for c in ("ir", "ok", "or")]
    pairs = [
        _bhattacharyya_gauss(p.mean(), p.var(ddof=1), q.mean(), q.var(ddof=1))
        for p, q in combinations(parts, 2)
    ]
    assert r.scores["de/stats/Kurtosis"] == pytest.approx(np.mean(pairs), rel=1e-10)


def test_bhattacharyya_of_a_constant_class_on_a_grid_is_finite():
    # a peak frequency on a 5 Hz grid, constant in class a: variance floor 5^2 / 12
    x = np.array([100.0, 100.0, 100.0, 95.0, 100.0, 105.0, 110.0])
    y = np.array([0, 0, 0, 1, 1, 1, 1])
    r = pf.rank_features(pd.DataFrame({"f": x}), y, method="bhattacharyya")
    floor = 25 / 12
    expected = _bhattacharyya_gauss(100.0, floor, x[3:].mean(), x[3:].var(ddof=1))
    assert r.scores["f"] == pytest.approx(expected, rel=1e-12)
    assert not r.notes


# --------------------------------------------------------------------------- saturation
@pytest.fixture
def separated(rng):
    """Two classes that no feature lets overlap; gap / spread grows from f1 to f4."""
    n = 40
    y = np.repeat(["healthy", "faulty"], n)
    base = rng.uniform(-1, 1, size=(2 * n, 1))
    columns = {}
    for name, gap in (("f1", 3.0), ("f2", 6.0), ("f3", 12.0), ("f4", 48.0)):
        columns[name] = (base[:, 0] + gap * (y == "faulty")) * (1 + rng.uniform(0, 0.01))
    return pd.DataFrame(columns), y


def test_kruskal_saturates_where_fisher_and_bhattacharyya_do_not(separated):
    table, y = separated
    h = pf.rank_features(table, y, method="kruskal")
    n = len(y)
    ceiling = (n**3 - 2 * 40**3) / (n * (n + 1))  # H of disjoint classes, no ties
    assert h.scores.to_numpy() == pytest.approx(np.full(4, h.scores.iloc[0]), rel=1e-12)
    assert h.scores.iloc[0] == pytest.approx(ceiling, rel=1e-12)
    assert all("fully separated" in h.notes[f] for f in table.columns)
    auc = pf.rank_features(table, y, method="auc")
    assert (auc.scores == 1.0).all() and "fully separated" in auc.notes["f1"]
    for method in ("fisher", "bhattacharyya"):
        r = pf.rank_features(table, y, method=method)
        assert r.features == ["f4", "f3", "f2", "f1"], method
        assert r.scores.nunique() == 4
        assert np.all(np.diff(r.scores.to_numpy()) < 0)
        assert not r.notes


def test_every_class_constant_gives_an_infinite_fisher_ratio():
    table = pd.DataFrame({"step": [1.0, 1.0, 2.0, 2.0], "noise": [0.1, 0.4, 0.2, 0.3]})
    r = pf.rank_features(table, [0, 0, 1, 1], method="fisher")
    assert r.scores["step"] == np.inf and r.p_values["step"] == 0.0
    assert "no spread within classes" in r.notes["step"]
    assert r.features[0] == "step"


# --------------------------------------------------------------------------- edge cases
@pytest.mark.parametrize("method", ["fisher", "auc", "bhattacharyya"])
def test_constant_and_nan_features_as_kruskal_and_anova_do(three_classes, method):
    table = three_classes.copy()
    table["de/stats/Const"] = 2.0
    table["de/stats/AllNaN"] = np.nan
    table.loc[[0, 30], "de/stats/RMS"] = np.nan
    r = pf.rank_features(table, "label", method=method)
    ranked = r.to_pandas().set_index("feature")
    assert ranked.loc["de/stats/Const", "note"] == "constant feature"
    assert ranked.loc["de/stats/AllNaN", "note"] == "all values are NaN or inf"
    assert set(r.features[-2:]) == {"de/stats/Const", "de/stats/AllNaN"}
    assert "2 NaN/inf value(s) left out" in ranked.loc["de/stats/RMS", "note"]
    kept = table.drop(index=[0, 30])
    alone = pf.rank_features(kept, "label", method=method, features=["de/stats/RMS"])
    assert ranked.loc["de/stats/RMS", "score"] == pytest.approx(alone.scores.iloc[0])


def test_single_member_classes():
    table = pd.DataFrame({"f": [1.0, 2.0, 3.0]})
    fisher = pf.rank_features(table, ["a", "b", "c"], method="fisher")
    assert np.isnan(fisher.scores["f"])
    assert "every group has a single value" in fisher.notes["f"]
    bhat = pf.rank_features(table, ["a", "b", "c"], method="bhattacharyya")
    # each class spreads over the resolution d = 1: D = gap^2 / (4 * 2 / 12) per pair
    assert bhat.scores["f"] == pytest.approx(np.mean([1, 4, 1]) * 12 / 8)


@pytest.mark.parametrize("method", CLASS_METHODS)
def test_class_methods_need_labels_and_two_classes(three_classes, method):
    with pytest.raises(DataError, match="labels are needed"):
        pf.rank_features(three_classes, method=method)
    with pytest.raises(DataError, match="1 distinct class"):
        pf.rank_features(three_classes, np.zeros(len(three_classes)), method=method)
    assert set(pf.CLASS_METHODS) == set(CLASS_METHODS)


def test_plot_labels_the_new_methods(separated):
    import matplotlib.pyplot as plt

    table, y = separated
    ax = pf.rank_features(table, y, method="bhattacharyya").plot()
    assert "Bhattacharyya" in ax.get_xlabel()
    plt.close("all")


# --------------------------------------------------------------------------- stability
@pytest.fixture
def informative(rng):
    n = 120
    y = np.repeat(["a", "b", "c"], n // 3)
    shift = pd.Series(y).map({"a": 0.0, "b": 2.0, "c": 4.0}).to_numpy()
    table = pd.DataFrame({f"vib/noise{i}": rng.normal(size=n) for i in range(8)})
    table["vib/strong"] = rng.normal(size=n) + 2 * shift
    table["vib/good"] = rng.normal(size=n) + shift
    table["recording"] = np.arange(n) // 5  # 24 recordings of 5 frames, one class each
    table["label"] = y
    return table


def test_informative_features_are_top_k_in_every_fold(informative):
    s = pf.ranking_stability(informative, "label", k=2, features=None)
    df = s.to_pandas().set_index("feature")
    assert set(df.index) == {*(f"vib/noise{i}" for i in range(8)), "vib/strong", "vib/good"}
    assert (
        df.loc["vib/strong", "in_top_k"] == 1.0 and df.loc["vib/strong", "mean_rank"] == 1.0
    )
    assert df.loc["vib/good", "in_top_k"] == 1.0 and df.loc["vib/good", "rank_std"] == 0.0
    noise = df.loc[[f"vib/noise{i}" for i in range(8)]]
    assert (noise["in_top_k"] == 0.0).all()
    assert (noise["mean_rank"] > 2).all()
    assert s.features[:2] == ["vib/strong", "vib/good"]
    assert s.scores.shape == (10, 5) and s.splitter == "StratifiedKFold(5)"


def test_fold_scores_are_rankings_of_the_training_rows(informative):
    cols = ["vib/strong", "vib/good", "vib/noise0", "vib/noise1"]
    s = pf.ranking_stability(informative, "label", features=cols, n_splits=3, k=1)
    y = informative["label"].to_numpy()
    cv = StratifiedKFold(3, shuffle=True, random_state=0)
    for i, (train, _) in enumerate(cv.split(np.zeros(len(y)), y), start=1):
        part = informative.iloc[train]
        ref = pf.rank_features(part, part["label"], method="fisher", features=cols)
        pd.testing.assert_series_equal(
            s.scores[f"fold{i}"], ref.scores.reindex(cols), check_names=False
        )
    # the summary: mean pairwise Spearman / Kendall of the fold ranks
    ranks = s.ranks.to_numpy()
    rho = [
        scipy.stats.spearmanr(ranks[:, i], ranks[:, j])[0]
        for i, j in [(0, 1), (0, 2), (1, 2)]
    ]
    tau = [
        scipy.stats.kendalltau(ranks[:, i], ranks[:, j])[0]
        for i, j in [(0, 1), (0, 2), (1, 2)]
    ]
    assert s.spearman == pytest.approx(np.mean(rho))
    assert s.kendall == pytest.approx(np.mean(tau))


def test_groups_stay_in_one_fold(informative, monkeypatch):
    from sklearn.model_selection import StratifiedGroupKFold

    seen = []
    original = StratifiedGroupKFold.split

    def spy(self, X, y=None, groups=None):
        for train, test in original(self, X, y, groups):
            seen.append((set(groups[train]), set(groups[test])))
            yield train, test

    monkeypatch.setattr(StratifiedGroupKFold, "split", spy)
    s = pf.ranking_stability(informative, "label", groups="recording", n_splits=4)
    assert s.splitter == "StratifiedGroupKFold(4)" and len(seen) == 4
    assert all(not (train & test) for train, test in seen)
    assert "recording" not in s.scores.index  # the group column is not a feature
    assert s.to_pandas()["feature"].iloc[0] == "vib/strong"


def test_saturated_kruskal_shows_as_ties_across_folds(separated):
    table, y = separated
    kruskal = pf.ranking_stability(table, y, method="kruskal", k=1)
    assert (kruskal.ranks.to_numpy() == 2.5).all()  # all four tied in every fold
    assert (kruskal.to_pandas()["in_top_k"] == 1.0).all()  # ties at the border count
    assert np.isnan(kruskal.spearman)  # no order to compare
    fisher = pf.ranking_stability(table, y, k=1)
    assert fisher.features == ["f4", "f3", "f2", "f1"]
    assert fisher.spearman == pytest.approx(1.0)


def test_stability_errors(informative):
    with pytest.raises(DataError, match="method must be one of"):
        pf.ranking_stability(informative, "label", method="monotonicity")
    with pytest.raises(DataError, match="n_splits must be an integer of at least 2"):
        pf.ranking_stability(informative, "label", n_splits=1)
    with pytest.raises(DataError, match="fewer than n_splits=50"):
        pf.ranking_stability(informative, "label", n_splits=50)
    with pytest.raises(DataError, match="24 distinct group"):
        pf.ranking_stability(informative, "label", groups="recording", n_splits=30)
    with pytest.raises(DataError, match="'rec' is not a column"):
        pf.ranking_stability(informative, "label", groups="rec")
    one_class = informative.assign(label="a")
    with pytest.raises(DataError, match="fewer than two classes"):
        pf.ranking_stability(one_class, "label")
    # three groups of one class each in two folds: one fold trains on a single group
    bad = informative.assign(recording=informative["label"])
    with pytest.raises(DataError, match="trains on a single class"):
        pf.ranking_stability(bad, "label", groups="recording", n_splits=2)


def test_stability_plot_and_repr(informative):
    import matplotlib.pyplot as plt

    s = pf.ranking_stability(informative, "label", n_splits=3)
    ax = s.plot(k=4)
    assert [t.get_text() for t in ax.get_yticklabels()][::-1][:2] == [
        "vib/strong",
        "vib/good",
    ]
    assert "3 folds" in repr(s) and len(s) == 10
    plt.close("all")


# --------------------------------------------------------------------------- CLI
def test_rank_cli_new_methods_and_stability(informative, tmp_path):
    from pdmkit.experiments._cli import main

    path = tmp_path / "f.parquet"
    informative.to_parquet(path)
    base = ["rank", "--features", str(path), "--label", "label"]
    out = tmp_path / "default"
    assert (
        main([*base, "--out", str(out), "--stability-folds", "3", "--group", "recording"])
        == 0
    )
    summary = json.loads((out / "summary.json").read_text())
    assert summary["method"] == "fisher"  # the default: it does not saturate
    assert summary["stability"]["splitter"] == "StratifiedGroupKFold(3)"
    assert summary["ranking"][0]["feature"] == "vib/strong"
    ranked = pd.read_parquet(out / "ranking.parquet")
    assert {"mean_rank", "rank_std", "in_top_k"} <= set(ranked.columns)
    for method in ("auc", "bhattacharyya", "kruskal"):
        out = tmp_path / method
        assert main([*base, "--method", method, "--out", str(out)]) == 0
        assert json.loads((out / "summary.json").read_text())["method"] == method


def test_rank_cli_refuses_stability_options_out_of_place(informative, tmp_path, capsys):
    from pdmkit.experiments._cli import main

    path = tmp_path / "f.parquet"
    informative.to_parquet(path)
    base = ["rank", "--features", str(path), "--out", str(tmp_path / "o")]
    assert main([*base, "--label", "label", "--group", "recording"]) == 2
    assert "add --stability-folds" in capsys.readouterr().err
    assert (
        main([*base, "--label", "label", "--stability-folds", "3", "--group", "recordng"])
        == 2
    )
    assert "did you mean 'recording'" in capsys.readouterr().err
    assert main([*base, "--method", "monotonicity", "--stability-folds", "3"]) == 2
    assert "--stability-folds is for the class methods" in capsys.readouterr().err


# --------------------------------------------------------------------------- CWRU
@pytest.fixture(scope="module")
def cwru_table():
    from pdmkit._config import data_dir

    if not data_dir("cwru_bearing").is_dir():
        pytest.skip(
            f"real dataset 'cwru_bearing' not found in {data_dir('cwru_bearing')}; set "
            "PDMKIT_DATA to the folder holding the shared datasets"
        )
    from pdmkit.ensembles import load_cwru

    # DE frames of 2048 samples at 12 kHz (the 48 kHz normal record resampled): 265
    # frames of 5 classes; time-domain statistics and spectral indicators
    ensemble = load_cwru(frame_length=2048, signals=("DE",))
    return pf.extract_ensemble(ensemble, groups=("stats", "spectral"))


def test_cwru_kruskal_saturates_fisher_and_bhattacharyya_tell_features_apart(cwru_table):
    kruskal = pf.rank_features(cwru_table, "fault", method="kruskal")
    top = kruskal.scores.head(10)
    n = cwru_table["fault"].value_counts().to_numpy()
    ceiling = (n.sum() ** 3 - (n**3).sum()) / (n.sum() * (n.sum() + 1))
    at_ceiling = np.isclose(top, ceiling, rtol=1e-9)
    assert at_ceiling.sum() >= 3  # RMS, Std, TotalPower: all at H's ceiling (252.0)
    assert top.round(6).nunique() < 10
    saturated = [f for f, note in kruskal.notes.items() if "fully separated" in note]
    assert sorted(saturated) == sorted(top.index[at_ceiling])
    for method in ("fisher", "bhattacharyya"):
        r = pf.rank_features(cwru_table, "fault", method=method)
        best = r.scores.head(10)
        assert best.round(6).nunique() == 10, method
        assert np.isfinite(best).all()
        assert best.iloc[0] > 1.2 * best.iloc[3]  # spread out, not a flat row of bars
        assert set(r.top(2)) == {"DE/stats/RMS", "DE/stats/Std"}


def test_cwru_ranking_is_stable_across_folds(cwru_table):
    s = pf.ranking_stability(cwru_table, "fault", n_splits=5, k=5)
    assert s.spearman > 0.9
    df = s.to_pandas().set_index("feature")
    assert df.loc[["DE/stats/RMS", "DE/stats/Std"], "in_top_k"].eq(1.0).all()
