"""RUL in the user's units (issue 15): the boosting model, honest intervals, input
checks (out-of-distribution scores, shut-down endings), time units on the plots,
progress on long fits, and a neural training that does not live in the kernel."""

from __future__ import annotations

import subprocess
import sys
import textwrap
import warnings

import numpy as np
import pandas as pd
import pytest
from scipy import stats
from sklearn.ensemble import HistGradientBoostingRegressor

from pdmkit.rul import (
    BoostingRULModel,
    RULPrediction,
    WienerDegradationModel,
    ood_scores,
    shutdown_endings,
)
from pdmkit.rul._boosting import _tree_arrays, _walk, window_features


def _fleet(n, seed, life=(60, 110), noise=0.03):
    rng = np.random.default_rng(seed)
    rows = []
    for u in range(n):
        n_life = int(rng.integers(*life))
        t = np.arange(1, n_life + 1.0)
        frac = t / n_life
        rows.append(
            pd.DataFrame(
                {
                    "unit": u,
                    "time": t,
                    "s1": frac**2 + rng.normal(0, noise, t.size),
                    "s2": 1 - frac**3 + rng.normal(0, noise, t.size),
                }
            )
        )
    return pd.concat(rows, ignore_index=True)


# --------------------------------------------------------------------------- boosting
def test_tree_walk_equals_sklearn_predict(rng):
    X = rng.normal(size=(600, 5))
    y = X[:, 0] ** 2 + np.sin(3 * X[:, 1]) + 0.1 * rng.normal(size=600)
    model = HistGradientBoostingRegressor(max_iter=40, random_state=0).fit(X, y)
    new = rng.normal(size=(300, 5)) * 2
    np.testing.assert_allclose(_walk(_tree_arrays(model), new), model.predict(new))


def test_window_features_match_direct_means_and_polyfit_slopes(rng):
    t = np.cumsum(rng.uniform(0.5, 2.0, 50))
    x = rng.normal(size=(50, 2)).cumsum(axis=0)
    f = window_features(t, x, window=8, short_window=3)
    for i in (0, 1, 5, 7, 30, 49):
        lo = max(0, i - 7)
        np.testing.assert_allclose(f[i, :2], x[max(0, i - 2) : i + 1].mean(axis=0))
        np.testing.assert_allclose(f[i, 2:4], x[lo : i + 1].mean(axis=0))
        for c in range(2):
            slope = np.polyfit(t[lo : i + 1], x[lo : i + 1, c], 1)[0] if i > 0 else 0.0
            assert f[i, 4 + c] == pytest.approx(slope, abs=1e-9)


def test_boosting_predicts_held_out_units_with_calibrated_intervals():
    train = _fleet(40, seed=1)
    test = _fleet(40, seed=2)
    rng = np.random.default_rng(3)
    cut, truth = [], {}
    for u, part in test.groupby("unit"):
        keep = int(rng.integers(10, len(part) - 1))
        cut.append(part.iloc[:keep])
        truth[u] = len(part) - keep
    history = pd.concat(cut)
    model = BoostingRULModel(window=15, max_iter=60).fit(train)
    pred = model.predict(history)
    true = np.array([truth[u] for u in pred.unit], dtype=float)
    spread = np.std(true)
    rmse = float(np.sqrt(np.mean((pred.estimate - true) ** 2)))
    assert rmse < 0.35 * spread  # far better than predicting the mean
    coverage = np.mean((pred.lower <= true) & (true <= pred.upper))
    assert 0.75 <= coverage <= 1.0
    assert model.feature_names_[-1] == "age"


def test_boosting_without_a_cap_predicts_rul_beyond_125():
    train = _fleet(12, seed=4, life=(300, 400))
    model = BoostingRULModel(window=10, max_iter=40, n_folds=3).fit(train)
    early = train[(train.unit == 0) & (train.time <= 20)]
    assert model.predict(early).estimate[0] > 200  # no silent C-MAPSS cap


def test_boosting_trajectory_equals_predictions_of_cut_histories():
    train = _fleet(8, seed=5)
    model = BoostingRULModel(window=10, max_iter=20, n_folds=2).fit(train)
    unit = train[train.unit == 3]
    path = model.predict_trajectory(unit, every=7)
    for t, est in zip(path.time, path.estimate, strict=True):
        assert model.predict(unit[unit.time <= t]).estimate[0] == pytest.approx(est)


def test_boosting_and_neural_show_progress_on_a_terminal(capsys, monkeypatch):
    from pdmkit.rul import NeuralRULModel

    train = _fleet(4, seed=6, life=(30, 40))
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    BoostingRULModel(window=5, max_iter=5, n_folds=2).fit(train)
    NeuralRULModel(window=5, hidden=4, epochs=2, n_folds=2).fit(train)
    err = capsys.readouterr().err
    assert "boosting folds" in err
    assert "neural epochs" in err


# --------------------------------------------------------------------------- intervals
def test_wiener_unit_beyond_threshold_from_its_start_is_not_rul_zero():
    t = np.arange(0.0, 50.0)
    rng = np.random.default_rng(7)
    train = pd.concat(
        [
            pd.DataFrame({"unit": u, "time": t, "hi": r * t + rng.normal(0, 0.05, 50)})
            for u, r in enumerate([0.02, 0.025, 0.03, 0.022])
        ]
    )
    model = WienerDegradationModel(threshold=1.0).fit(train)
    flat = pd.DataFrame({"unit": "flat", "time": t[:10], "hi": 1.2 + 0 * t[:10]})
    crossed = pd.DataFrame({"unit": "crossed", "time": t[:3], "hi": [0.5, 0.9, 1.1]})
    pred = model.predict(pd.concat([flat, crossed]))
    table = pred.to_pandas().set_index("unit")
    assert np.isnan(table.loc["flat", "rul"])  # no "RUL 0 (0 to 0)"
    assert table.loc["flat", "upper"] == np.inf
    assert "since its first row" in table.loc["flat", "note"]
    assert table.loc["crossed", "rul"] == 0.0  # it crossed: the model's answer


def test_negative_drift_warning_says_what_the_predictions_are():
    t = np.arange(0.0, 40.0)
    train = pd.concat(
        [
            pd.DataFrame({"unit": u, "time": t, "hi": 1.0 - r * t + 0.01 * np.sin(t * u)})
            for u, r in enumerate([0.01, 0.012, 0.015])
        ]
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        WienerDegradationModel(threshold=2.0).fit(train)
    text = " ".join(str(w.message) for w in caught)
    assert "not positive" in text
    assert "most RULs will be inf" not in text
    assert "beyond the horizon" in text and "RUL 0" in text


def test_prediction_plot_shows_the_time_unit_on_both_axes():
    p = RULPrediction([1, 1], [10.0, 20.0], [30.0, 20.0], [25.0, 15.0], [35.0, 25.0])
    ax = p.plot(true=[31.0, 21.0], time_unit="h")
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("time (h)", "RUL (h)")
    one = RULPrediction([1, 2], [10.0, 20.0], [30.0, 20.0], [25.0, 15.0], [35.0, 25.0])
    one.time_unit = "min"
    ax = one.plot(true=[31.0, 21.0])
    assert ax.get_xlabel() == "true RUL (min)"


# --------------------------------------------------------------------------- input checks
def test_ood_score_of_a_point_matches_the_chi_distribution_quantile():
    rng = np.random.default_rng(8)
    p = 3
    train = pd.DataFrame(rng.normal(size=(30000, p)), columns=["a", "b", "c"])
    train["unit"] = np.repeat(np.arange(30), 1000)
    train["time"] = np.tile(np.arange(1000), 30)
    r = 6.0
    test = pd.DataFrame({"unit": "u", "time": np.arange(20), "a": r, "b": 0.0, "c": 0.0})
    score = ood_scores(train, test, ["a", "b", "c"])["u"]
    reference = np.sqrt(stats.chi2.ppf(0.99, p))  # 99 % of N(0, I) rows lie within
    assert score == pytest.approx(r / reference, rel=0.05)


def test_ood_flags_a_shifted_fleet_and_not_a_fresh_draw():
    train = _fleet(20, seed=9)
    same = _fleet(10, seed=10)
    shifted = same.assign(s2=same["s2"] + 0.8, s1=same["s1"] - 0.5)
    assert (ood_scores(train, same, ["s1", "s2"]) < 1).all()
    assert (ood_scores(train, shifted, ["s1", "s2"]) > 1).all()


def test_shutdown_endings_finds_zero_and_flat_endings_only():
    t = np.arange(60.0)
    rising = 1 + t / 60
    table = pd.concat(
        [
            pd.DataFrame({"unit": "zero", "time": t, "v": np.r_[rising[:-2], 0.001, 0.0]}),
            pd.DataFrame({"unit": "flat", "time": t, "v": np.r_[rising[:-4], [1.5] * 4]}),
            pd.DataFrame({"unit": "fails", "time": t, "v": np.r_[rising[:-2], 3.0, 4.0]}),
        ]
    )
    found = shutdown_endings(table, ["v"]).set_index("unit")
    assert set(found.index) == {"zero", "flat"}
    assert found.loc["zero", "kind"] == "near zero" and found.loc["zero", "rows"] == 2
    assert found.loc["flat", "kind"] == "flat" and found.loc["flat", "rows"] == 4


# --------------------------------------------------------------------------- neural
@pytest.mark.slow
def test_neural_training_spends_little_time_in_the_kernel():
    """The heap's top was grown and trimmed every batch: kernel time was 35-40 % of
    the training (0.41 on this fit before, under 0.01 after)."""
    code = textwrap.dedent(
        """
        import resource, numpy as np, pandas as pd
        from pdmkit.rul import NeuralRULModel
        rng = np.random.default_rng(0)
        rows = []
        for u in range(40):  # C-MAPSS-like: 21 sensors, 40-sample windows
            t = np.arange(1, 201.0)
            rows.append(pd.DataFrame({"unit": u, "time": t,
                **{f"s{i}": (t / 200) ** 2 + rng.normal(0, 0.05, 200) for i in range(21)}}))
        train = pd.concat(rows, ignore_index=True)
        model = NeuralRULModel(window=40, hidden=64, epochs=1, n_folds=2)
        model.fit(train)  # the first fit pays for the heap's first touch
        before = resource.getrusage(resource.RUSAGE_SELF)
        model.fit(train)
        after = resource.getrusage(resource.RUSAGE_SELF)
        user = after.ru_utime - before.ru_utime
        system = after.ru_stime - before.ru_stime
        print(system / (user + system))
        """
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120
    )
    assert out.returncode == 0, out.stderr
    assert float(out.stdout.strip().splitlines()[-1]) < 0.15
