"""Sensor comparison by accuracy and cost; the sensor-cost TOML loader."""

from __future__ import annotations

import json

import matplotlib
import numpy as np
import pandas as pd
import pytest
from scipy import stats
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.decomposition import PCA
from sklearn.model_selection import StratifiedKFold, cross_val_score
from sklearn.neighbors import KNeighborsClassifier
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler

import pdmkit.features
from pdmkit.errors import DataError, DataNotFoundError
from pdmkit.experiments._sensor_costs import load_sensor_costs
from pdmkit.experiments._sensors import SensorComparison, compare_sensors

matplotlib.use("Agg")


class _StandInSelectTopRanked(BaseEstimator, TransformerMixin):
    """Kruskal/ANOVA top-k selector, used only while pdmkit.features lacks the real one."""

    def __init__(self, k=5, method="kruskal"):
        self.k = k
        self.method = method

    def fit(self, X, y):
        X = np.asarray(X, dtype=float)
        y = np.asarray(y)
        groups = [X[y == c] for c in np.unique(y)]
        test = stats.kruskal if self.method == "kruskal" else stats.f_oneway
        self.scores_ = np.array(
            [test(*[g[:, j] for g in groups]).statistic for j in range(X.shape[1])]
        )
        self.selected_ = np.sort(np.argsort(-self.scores_, kind="stable")[: self.k])
        self.n_features_in_ = X.shape[1]
        return self

    def transform(self, X):
        return np.asarray(X, dtype=float)[:, self.selected_]


@pytest.fixture(autouse=True)
def _selector(monkeypatch):
    if not hasattr(pdmkit.features, "SelectTopRanked"):
        monkeypatch.setattr(
            pdmkit.features, "SelectTopRanked", _StandInSelectTopRanked, raising=False
        )


CLASSES = ["normal", "inner", "outer", "ball"]


def _rig(rng, n_per_class=30):
    """DE (signals DEx, DEy) carries the fault; FE is pure noise."""
    y = np.repeat(CLASSES, n_per_class)
    n = len(y)
    data = {}
    for sig in ("DEx", "DEy", "FE"):
        for feat in ("RMS", "Kurtosis", "Crest"):
            data[f"{sig}/stats/{feat}"] = rng.normal(size=n)
    data["DEx/stats/RMS"] += 6.0 * (y == "inner")
    data["DEy/stats/Kurtosis"] += 6.0 * (y == "outer")
    data["DEx/stats/Crest"] += 6.0 * (y == "ball")
    table = pd.DataFrame(data, index=[f"m{i:03d}" for i in range(n)])
    table["fault"] = y
    return table


SENSORS = {"DE": ["DEx", "DEy"], "FE": ["FE"]}


def test_informative_sensor_beats_noise(rng):
    table = _rig(rng)
    cmp = compare_sensors(table, "fault", SENSORS, {"DE": 7000.0, "FE": 3500.0}, top_k=3)
    df = cmp.to_pandas().set_index("sensor")
    assert df.loc["DE", "accuracy"] >= 0.95
    assert df.loc["DE", "heldout_accuracy"] >= 0.95
    # noise: cross-validated accuracy within a binomial band around chance (1/4)
    n = int(df.loc["FE", "n_members"])
    lo, hi = stats.binom.interval(0.9999, n, 0.25)
    assert lo / n <= df.loc["FE", "accuracy"] <= hi / n
    assert df.loc["DE", "signals"] == "DEx, DEy"
    assert df.loc["DE", "n_features"] == 6 and df.loc["FE", "n_features"] == 3
    assert df.loc["DE", "cost"] == 7000.0
    assert (df["n_excluded"] == 0).all() and (df["n_members"] == 120).all()
    assert set(df.loc["DE", "features"].split("; ")) == {
        "DEx/stats/RMS",
        "DEy/stats/Kurtosis",
        "DEx/stats/Crest",
    }
    assert df["pareto"].to_dict() == {"DE": True, "FE": True}  # better but dearer
    assert set(cmp.results) == {"DE", "FE"}


def test_accuracy_matches_hand_built_cross_validation(rng):
    table = _rig(rng)
    table.loc[table.index[:10], [c for c in table.columns if c.startswith("FE/")]] = np.nan
    cmp = compare_sensors(
        table, "fault", SENSORS, {}, model="knn", selection="pca", top_k=2, random_state=4
    )
    df = cmp.to_pandas().set_index("sensor")
    for sensor, prefix in (("DE", ("DEx/", "DEy/")), ("FE", ("FE/",))):
        cols = [c for c in table.columns if c.startswith(prefix)]
        kept = table[table[cols].notna().all(axis=1)]
        pipe = Pipeline(
            [
                ("s", StandardScaler()),
                ("p", PCA(n_components=2, random_state=4)),
                ("m", KNeighborsClassifier(n_neighbors=5, weights="distance")),
            ]
        )
        folds = StratifiedKFold(n_splits=5, shuffle=True, random_state=4)
        scores = cross_val_score(
            pipe, kept[cols].to_numpy(), kept["fault"].to_numpy(), cv=folds
        )
        assert df.loc[sensor, "accuracy"] == pytest.approx(scores.mean(), abs=1e-12)
        assert df.loc[sensor, "accuracy_std"] == pytest.approx(scores.std(), abs=1e-12)
        assert df.loc[sensor, "n_members"] == len(kept)


def test_members_without_a_sensor_are_excluded_and_reported(rng):
    table = _rig(rng)
    fe = [c for c in table.columns if c.startswith("FE/")]
    # CWRU-like: the 'normal' recordings have no FE channel, nor do two faulty ones
    normal = table.index[(table["fault"] == "normal").to_numpy()].tolist()
    lacking = [*normal, "m040", "m100"]
    table.loc[lacking, fe] = np.nan
    cmp = compare_sensors(table, "fault", SENSORS, {"DE": 1.0, "FE": 1.0})
    row = cmp.to_pandas().set_index("sensor").loc["FE"]
    assert row["n_excluded"] == len(lacking) == 32
    assert row["n_members"] == 120 - 32
    assert row["n_classes"] == 3
    assert "32 member(s) without this sensor excluded" in row["note"]
    assert "'normal'" in row["note"] and "3 of 4 classes" in row["note"]
    # it never had to recognise 'normal': it does not compete for the Pareto front,
    # even though it is as cheap as DE
    assert not row["pareto"] and "left off the Pareto front" in row["note"]
    de = cmp.to_pandas().set_index("sensor").loc["DE"]
    assert de["n_excluded"] == 0 and de["note"] == ""
    assert cmp.results["FE"].n_train + cmp.results["FE"].n_test == 88


def test_a_member_lacking_one_signal_of_a_sensor_is_excluded(rng):
    table = _rig(rng)
    table.loc["m007", [c for c in table.columns if c.startswith("DEy/")]] = np.nan
    df = compare_sensors(table, "fault", SENSORS, {}).to_pandas().set_index("sensor")
    assert df.loc["DE", "n_excluded"] == 1
    assert df.loc["FE", "n_excluded"] == 0


def test_a_class_left_with_one_member_is_dropped_with_a_note(rng):
    table = _rig(rng, n_per_class=8)
    ball = table.index[(table["fault"] == "ball").to_numpy()]
    table.loc[ball[1:], [c for c in table.columns if c.startswith("FE/")]] = np.nan
    row = (
        compare_sensors(table, "fault", SENSORS, {})
        .to_pandas()
        .set_index("sensor")
        .loc["FE"]
    )
    assert row["n_members"] == 24 and row["n_excluded"] == 7
    assert "['ball'] have a single member" in row["note"]


def test_partially_missing_features_are_an_error(rng):
    table = _rig(rng)
    table.loc["m012", "DEy/stats/Crest"] = np.nan
    with pytest.raises(
        DataError, match=r"sensor 'DE', signal 'DEy'.*'m012'.*DEy/stats/Crest"
    ):
        compare_sensors(table, "fault", SENSORS, {})


def test_unknown_signal_is_named(rng):
    table = _rig(rng)
    with pytest.raises(DataError, match=r"no feature columns start with 'BA/'.*'DEx'"):
        compare_sensors(table, "fault", {"BA": ["BA"]}, {})


def test_missing_cost_gives_nan_and_a_note(rng):
    table = _rig(rng, n_per_class=10)
    cmp = compare_sensors(table, "fault", SENSORS, {"DE": 10.0})
    row = cmp.to_pandas().set_index("sensor").loc["FE"]
    assert np.isnan(row["cost"]) and not row["pareto"]
    assert "no cost for sensor 'FE'" in row["note"]
    s = cmp.summary()
    json.dumps(s, allow_nan=False)
    fe = next(r for r in s["sensors"] if r["sensor"] == "FE")
    assert fe["cost"] is None and fe["signals"] == ["FE"]
    assert s["pareto_front"] == ["DE"]


def test_default_costs_are_used_when_none(rng):
    table = _rig(rng, n_per_class=10)
    cmp = compare_sensors(table, "fault", {"Flow": ["DEx"], "Mics": ["FE"]})
    df = cmp.to_pandas().set_index("sensor")
    assert df.loc["Flow", "cost"] == 6000.0 and df.loc["Mics", "cost"] == 1500.0
    assert cmp.cost_unit == "CZK"


# --------------------------------------------------------------------------- Pareto
TABLE_9_1 = pd.DataFrame(
    {  # Voronin's thesis, table 9.1: accuracy on the test set, cost in CZK
        "sensor": ["Acc", "Encoder", "Flow", "Mics", "Pressure", "Proximity", "Strain"],
        "accuracy": [0.916, 0.961, 0.972, 0.958, 0.766, 0.805, 0.950],
        "cost": [2 * 3500, 25000, 6000, 3 * 500, 1000, 2 * 1000, 15000],
    }
)


def test_pareto_front_of_table_9_1():
    cmp = SensorComparison(TABLE_9_1)
    # by hand: Pressure is cheapest; Mics beats all dearer but Flow on accuracy; Flow
    # is the most accurate. Proximity loses to Mics, Acc/Encoder/Strain lose to Flow.
    assert cmp.pareto_front()["sensor"].tolist() == ["Pressure", "Mics", "Flow"]
    assert cmp.to_pandas()["pareto"].sum() == 3


def test_sensors_scored_on_fewer_classes_are_off_the_front():
    t = TABLE_9_1.assign(n_classes=[20, 20, 20, 20, 20, 20, 19])
    t.loc[t["sensor"] == "Strain", ["accuracy", "cost"]] = [1.0, 100.0]  # would dominate
    front = SensorComparison(t).pareto_front()["sensor"].tolist()
    assert front == ["Pressure", "Mics", "Flow"]


def test_pareto_front_edge_cases():
    t = pd.DataFrame(
        {
            "sensor": ["a", "b", "c", "d", "e", "f"],
            "accuracy": [0.9, 0.9, 0.8, 0.95, np.nan, 0.99],
            "cost": [10.0, 10.0, 10.0, 12.0, 1.0, np.nan],
        }
    )
    front = SensorComparison(t).pareto_front()["sensor"].tolist()
    # a and b tie (neither dominates the other); c is dominated by a; d is dearer but
    # better; e (no accuracy) and f (no cost) cannot be placed
    assert front == ["a", "b", "d"]


def test_plot_draws_points_and_front(rng):
    import matplotlib.pyplot as plt

    t = TABLE_9_1.assign(accuracy_std=0.01)
    ax = SensorComparison(t, cost_unit="CZK").plot()
    assert ax.get_xlabel() == "sensor cost [CZK]"
    assert ax.get_xscale() == "log"  # 1000 .. 25000
    assert {t.get_text() for t in ax.texts} == set(TABLE_9_1["sensor"])
    step = [ln for ln in ax.get_lines() if ln.get_label() == "Pareto front"]
    assert len(step) == 1
    xs = step[0].get_xdata()
    assert [1000, 1500, 6000] == sorted(set(np.asarray(xs, dtype=float).tolist()))
    plt.close(ax.figure)


# --------------------------------------------------------------------------- costs
def test_default_costs_match_table_9_1():
    costs = load_sensor_costs()
    expected = dict(zip(TABLE_9_1["sensor"], TABLE_9_1["cost"].astype(float), strict=True))
    assert {k: costs[k] for k in expected} == expected
    assert costs["DE"] == costs["FE"] == costs["BA"] > 0
    assert costs.currency == "CZK"


def test_cost_file_with_units(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text(
        'currency = "EUR"\n[costs]\nA = 12.5\nB = { unit_cost = 4, count = 3 }\n'
    )
    costs = load_sensor_costs(path)
    assert costs == {"A": 12.5, "B": 12.0}
    assert costs.currency == "EUR" and costs.source == str(path)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("[costs]\nA = \n", "not valid TOML"),
        ('[costs]\nA = "cheap"\n', r"key costs\.A: the cost must be a number.*'cheap'"),
        ("[costs]\nA = -3\n", r"key costs\.A: the cost must be finite and >= 0"),
        ("[costs]\nA = nan\n", r"key costs\.A: the cost must be finite"),
        ("[costs]\nA = true\n", r"key costs\.A: the cost must be a number"),
        ("[costs]\nA = { unit_cost = 4, n = 2 }\n", r"key costs\.A: .*'unit_cost'"),
        ("[costs]\nA = { unit_cost = 4, count = 0 }\n", r"costs\.A: count must be"),
        ('[costs]\nA = { unit_cost = "x" }\n', r"costs\.A: unit_cost must be a number"),
        ("A = 3\n", "unknown top-level key"),
        ('currency = "EUR"\n', r"no \[costs\] table"),
        ("currency = 3\n[costs]\n", "'currency' must be a string"),
    ],
)
def test_bad_cost_files_are_named(tmp_path, text, match):
    path = tmp_path / "bad_costs.toml"
    path.write_text(text)
    with pytest.raises(DataError, match=match) as info:
        load_sensor_costs(path)
    assert "bad_costs.toml" in str(info.value)


def test_missing_cost_file(tmp_path):
    with pytest.raises(DataNotFoundError, match=r"nope\.toml"):
        load_sensor_costs(tmp_path / "nope.toml")
    with pytest.raises(FileNotFoundError):
        load_sensor_costs(tmp_path / "nope.toml")


def test_bad_cost_mapping(rng):
    table = _rig(rng, n_per_class=5)
    with pytest.raises(DataError, match=r"costs\['DE'\] must be a number"):
        compare_sensors(table, "fault", SENSORS, {"DE": "cheap"})


# --------------------------------------------------------------------------- real data
@pytest.mark.real_data
def test_cwru_sensors(require_data):
    """CWRU 0 hp: the normal recordings have no base (BA) accelerometer."""
    require_data("cwru_bearing")
    from pdmkit.experiments._datasets import dataset_features

    table, profile = dataset_features("cwru")
    cmp = compare_sensors(table, profile.label, dict(profile.sensors))
    df = cmp.to_pandas().set_index("sensor")
    n_normal = int((table[profile.label] == "normal").sum())
    assert n_normal > 0
    assert df.loc["BA", "n_excluded"] == n_normal
    assert df.loc["BA", "n_classes"] == table[profile.label].nunique() - 1
    assert "'normal'" in df.loc["BA", "note"] and not df.loc["BA", "pareto"]
    assert df.loc["DE", "n_excluded"] == df.loc["FE", "n_excluded"] == 0
    # a sanity floor, not a published figure: each class is one recording, so frames of
    # the same class share their spectra and the two full-set sensors separate them well
    assert df.loc["DE", "accuracy"] >= 0.9 and df.loc["FE", "accuracy"] >= 0.9
    json.dumps(cmp.summary(), allow_nan=False)
