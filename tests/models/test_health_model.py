"""HealthModel (issue 31): condition monitoring from healthy rows, against references.

The references are independent of the code under test: the conformal guarantee is
measured on fresh Gaussian rows against the exact beta-binomial law of the false-alarm
count; PCA T² and Q are recomputed by hand with numpy's eigendecomposition; the robust
Mahalanobis distance by scipy.spatial.distance.mahalanobis on scikit-learn's MinCovDet
fitted on the raw (not standardised) rows (the distance is affine invariant); the
isolation forest by scikit-learn's IsolationForest; the symbolic measure by
SymbolicAnomaly on each window; persistence on hand-made sequences.
"""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import stats
from scipy.spatial.distance import mahalanobis
from sklearn.base import clone
from sklearn.covariance import MinCovDet
from sklearn.ensemble import IsolationForest
from sklearn.utils import estimator_checks as checks

import pdmkit
from pdmkit.errors import DataError, ModelError, NotFittedError
from pdmkit.models.diagnosis import (
    HealthModel,
    SymbolicAnomaly,
    calibration_split,
    conformal_threshold,
    persistent_alarm,
)

METHODS = ("pca", "pca_t2", "pca_q", "mahalanobis", "isolation_forest", "symbolic")
MIX = np.array([[1.0, 0.6, 0.2, 0.0], [0.0, 0.8, 0.5, 0.1], [0.0, 0.0, 0.6, 0.4]])
MIX = np.vstack([MIX, [0.0, 0.0, 0.0, 0.3]])


def _healthy(rng, n, shift=0.0):
    """Correlated Gaussian rows with very different feature scales and offsets."""
    Z = rng.normal(size=(n, 4)) @ MIX + shift
    return pd.DataFrame(
        Z * [1.0, 10.0, 0.01, 3.0] + [0.0, 50.0, 1.0, -2.0],
        columns=["rms", "temp", "kurt", "peak"],
    )


def _fit_rows(n, fraction=0.3):
    return n - round(fraction * n)


# ----------------------------------------------------------------- conformal threshold
def test_conformal_threshold_is_the_finite_sample_order_statistic() -> None:
    scores = np.random.default_rng(0).permutation(np.arange(1.0, 200.0))  # 199 scores
    for alpha in (0.01, 0.05, 0.1, 0.5):
        k = math.ceil(200 * (1 - alpha))
        assert conformal_threshold(scores, alpha) == float(k)
    assert conformal_threshold([3.0, np.nan, 1.0, 2.0], 0.25) == 3.0  # NaN dropped


def test_conformal_threshold_refuses_too_few_rows() -> None:
    with pytest.raises(DataError, match="needs at least 99"):
        conformal_threshold(np.arange(98.0), 0.01)
    assert conformal_threshold(np.arange(99.0), 0.01) == 98.0
    with pytest.raises(ModelError):
        conformal_threshold(np.arange(99.0), 0.0)


@pytest.mark.parametrize(
    "method", ["pca", "pca_t2", "pca_q", "mahalanobis", "isolation_forest"]
)
def test_false_alarm_rate_on_fresh_healthy_rows(method: str) -> None:
    """P(score > threshold) <= alpha: the count of 20000 fresh rows over the threshold
    follows the beta-binomial law of a conformal threshold (exchangeable scores)."""
    rng = np.random.default_rng(11)
    alpha, n = 0.05, 3000
    model = HealthModel(method=method, false_alarm_rate=alpha).fit(_healthy(rng, n))
    fresh = _healthy(rng, 20000)
    count = int(np.sum(model.score(fresh) > model.threshold_))
    n_cal = model.n_calibration_
    assert n_cal == 900
    k = math.ceil((n_cal + 1) * (1 - alpha))
    law = stats.betabinom(20000, n_cal + 1 - k, k)  # exceedance prob ~ Beta(n+1-k, k)
    lo, hi = law.ppf(0.0005), law.ppf(0.9995)
    assert lo <= count <= hi, (count, lo, hi)
    assert law.mean() / 20000 <= alpha


def test_calibration_is_the_last_part_of_each_unit() -> None:
    groups = np.repeat(["a", "b", "c"], [10, 20, 5])
    fit, cal = calibration_split(groups.size, 0.3, groups)
    assert cal.tolist() == [7, 8, 9, *range(24, 30), 33, 34]
    assert sorted([*fit, *cal]) == list(range(35))
    X = _healthy(np.random.default_rng(1), 35).assign(unit=groups)
    model = HealthModel(method="pca_t2", false_alarm_rate=0.2).fit(X, groups="unit")
    assert (model.n_fit_, model.n_calibration_) == (24, 11)
    assert list(model.feature_names_in_) == ["rms", "temp", "kurt", "peak"]


# ----------------------------------------------------------------- detectors
def _hand_pca(X, n_fit, share=0.95, cap=None):
    fit = X[:n_fit]
    mu, sd = fit.mean(axis=0), fit.std(axis=0)
    Zf, Z = (fit - mu) / sd, (X - mu) / sd
    lam, V = np.linalg.eigh(np.cov(Zf, rowvar=False))
    lam, V = lam[::-1], V[:, ::-1]
    k = int(np.argmax(np.cumsum(lam) / lam.sum() >= share - 1e-12) + 1)
    k = min(k, cap or k)
    T = Z @ V[:, :k]
    t2 = np.sum(T**2 / lam[:k], axis=1)
    q = np.sum((Z - T @ V[:, :k].T) ** 2, axis=1)
    return t2, q, n_fit


def test_pca_t2_and_q_match_a_hand_computation() -> None:
    rng = np.random.default_rng(2)
    X = _healthy(rng, 800).to_numpy()
    t2, q, n_fit = _hand_pca(X, _fit_rows(800), cap=3)
    pt2 = HealthModel(method="pca_t2", n_components=0.95).fit(X)
    pq = HealthModel(method="pca_q", n_components=0.95).fit(X)
    both = HealthModel(method="pca", n_components=0.95).fit(X)
    assert pt2.components_.shape[0] == pq.components_.shape[0]
    np.testing.assert_allclose(pt2.score(X), t2, rtol=1e-9)
    np.testing.assert_allclose(pq.score(X), q, rtol=1e-9, atol=1e-12)
    combined = t2 / t2[:n_fit].mean() + q / q[:n_fit].mean()
    np.testing.assert_allclose(both.score(X), combined, rtol=1e-9)


def test_pca_keeps_a_residual_and_counts_components() -> None:
    X = _healthy(np.random.default_rng(3), 500)
    assert HealthModel(method="pca", n_components=4).fit(X).components_.shape[0] == 3
    assert HealthModel(method="pca_t2", n_components=4).fit(X).components_.shape[0] == 4
    with pytest.raises(ModelError, match="at least 2 features"):
        HealthModel(method="pca_q").fit(X[["rms"]])
    with pytest.raises(ModelError, match="n_components"):
        HealthModel(method="pca", n_components=1.5).fit(X)


def test_mahalanobis_matches_scipy_on_the_raw_mcd() -> None:
    rng = np.random.default_rng(4)
    X = _healthy(rng, 1000).to_numpy()
    Y = _healthy(rng, 50, shift=0.5).to_numpy()
    model = HealthModel(method="mahalanobis").fit(X)
    mcd = MinCovDet(random_state=0).fit(X[: _fit_rows(1000)])
    ref = [mahalanobis(y, mcd.location_, mcd.get_precision()) ** 2 for y in Y]
    np.testing.assert_allclose(model.score(Y), ref, rtol=1e-7)


def test_isolation_forest_is_sklearns_sign_flipped() -> None:
    rng = np.random.default_rng(5)
    X = _healthy(rng, 600).to_numpy()
    Y = _healthy(rng, 40, shift=1.0).to_numpy()
    model = HealthModel(method="isolation_forest", random_state=3).fit(X)
    fit = X[: _fit_rows(600)]
    mu, sd = fit.mean(axis=0), fit.std(axis=0)
    ref = IsolationForest(random_state=3).fit((fit - mu) / sd)
    np.testing.assert_allclose(model.score(Y), -ref.score_samples((Y - mu) / sd))


def test_symbolic_matches_symbolic_anomaly_per_window() -> None:
    rng = np.random.default_rng(6)
    X = _healthy(rng, 400).to_numpy()
    model = HealthModel(method="symbolic", window=25, n_symbols=5, false_alarm_rate=0.05)
    model.fit(X)
    fit = X[: _fit_rows(400)]
    Z = (X - fit.mean(axis=0)) / fit.std(axis=0)
    refs = [SymbolicAnomaly(n_symbols=5).fit(Z[: _fit_rows(400), j]) for j in range(4)]
    s = model.score(X)
    assert np.isnan(s[:24]).all() and np.isfinite(s[24:]).all()
    for t in (24, 100, 399):
        ref = sum(refs[j].score(Z[t - 24 : t + 1, j])[0] ** 2 for j in range(4))
        assert s[t] == pytest.approx(ref, rel=1e-12)
    # windows never span two units: each unit's first 24 rows have no score
    s2 = model.score(X[:100], units=np.repeat([1, 2], 50))
    assert np.isnan(s2[:24]).all() and np.isnan(s2[50:74]).all()
    assert s2[49] == pytest.approx(model.score(X[:50])[49])


# ----------------------------------------------------------------- alarms
def test_persistent_alarm_on_a_hand_made_sequence() -> None:
    e = np.array([1, 0, 1, 1, 0, 1, 1, 1, 0, 0, 0, 1, 1, 1, 1], dtype=bool)
    want_latched = [0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 1, 1]
    assert persistent_alarm(e, 3).astype(int).tolist() == want_latched
    want_clear = [0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 0, 0, 0, 1, 1]
    assert persistent_alarm(e, 3, clear_after=3).astype(int).tolist() == want_clear
    assert persistent_alarm(e, 1).tolist() == np.maximum.accumulate(e).tolist()
    # two units interleaved: each counts its own consecutive rows
    units = np.tile([0, 1], 4)
    ex = np.array([1, 1, 1, 0, 1, 1, 0, 1], dtype=bool)
    assert persistent_alarm(ex, 2, units=units).astype(int).tolist() == [
        0, 0, 1, 0, 1, 0, 1, 1,
    ]  # fmt: skip
    with pytest.raises(ModelError):
        persistent_alarm(e, 0)


def test_one_noisy_recording_does_not_alarm() -> None:
    rng = np.random.default_rng(7)
    model = HealthModel(method="pca", persistence=3).fit(_healthy(rng, 600))
    later = _healthy(rng, 30)
    later.loc[10, "rms"] += 50.0  # one wild recording
    later.loc[20, "temp"] += 500.0  # and another
    s = model.score(later)
    assert s[10] > model.threshold_ and s[20] > model.threshold_
    assert not model.alarm_state(later).any()
    later.loc[25:, "rms"] += 50.0  # a lasting change from row 25
    assert np.flatnonzero(model.alarm_state(later))[0] == 27


def test_health_index_is_one_when_typical_and_half_at_threshold() -> None:
    rng = np.random.default_rng(8)
    model = HealthModel(method="mahalanobis").fit(_healthy(rng, 600))
    hi = model.health_index(_healthy(rng, 2000))
    assert 0 <= hi.min() and hi.max() == 1.0
    assert np.mean(hi == 1.0) == pytest.approx(0.5, abs=0.06)
    # the map itself, at the median and the threshold
    m, t = model.calibration_median_, model.threshold_
    from pdmkit.models.diagnosis._health_threshold import health_index_map

    assert health_index_map(np.array([m, t, 2 * t - m]), m, t).tolist() == [1, 0.5, 0.25]


def test_margin_only_raises_the_threshold() -> None:
    X = _healthy(np.random.default_rng(9), 600)
    plain = HealthModel(method="pca").fit(X)
    wide = HealthModel(method="pca", margin=4.0).fit(X)
    m, q = plain.calibration_median_, plain.conformal_quantile_
    assert plain.threshold_ == q
    assert wide.threshold_ == pytest.approx(m + 4 * (q - m))
    with pytest.raises(ModelError, match="margin"):
        HealthModel(margin=0.5).fit(X)


def test_first_alarm_per_unit_in_any_row_order() -> None:
    rng = np.random.default_rng(10)
    model = HealthModel(method="pca_t2", persistence=2).fit(_healthy(rng, 600))
    a, b = _healthy(rng, 12), _healthy(rng, 12)
    b.loc[6:, "temp"] += 200.0
    log = pd.concat([a.assign(unit="a"), b.assign(unit="b")], ignore_index=True)
    log["t"] = pd.Timestamp("2024-01-01") + pd.to_timedelta(np.tile(range(12), 2), "h")
    shuffled = log.sample(frac=1.0, random_state=0)
    first = model.first_alarm(shuffled, time="t", units="unit")
    assert first.name == "first_alarm"
    assert first.to_dict() == {"b": pd.Timestamp("2024-01-01 07:00"), "a": None}
    one = model.first_alarm(b.to_numpy(), time=np.arange(12.0) * 10)
    assert one.to_dict() == {0: 70.0}


# ----------------------------------------------------------------- contributions
@pytest.mark.parametrize("method", ["pca", "pca_t2", "pca_q", "mahalanobis", "symbolic"])
def test_contributions_sum_to_the_score(method: str) -> None:
    rng = np.random.default_rng(12)
    model = HealthModel(method=method, false_alarm_rate=0.05).fit(_healthy(rng, 600))
    later = _healthy(rng, 60, shift=0.3)
    c = model.contributions(later)
    assert list(c.columns) == ["rms", "temp", "kurt", "peak"]
    assert c.index.equals(later.index)
    assert (c.fillna(0) >= -1e-12).all().all()
    np.testing.assert_allclose(c.sum(axis=1, min_count=1), model.score(later), rtol=1e-9)


@pytest.mark.parametrize("method", ["pca", "mahalanobis", "isolation_forest"])
def test_contributions_point_at_the_changed_feature(method: str) -> None:
    rng = np.random.default_rng(13)
    model = HealthModel(method=method).fit(_healthy(rng, 600))
    later = _healthy(rng, 20)
    later["kurt"] += 0.08  # eight healthy standard deviations of kurt
    assert (model.contributions(later).idxmax(axis=1) == "kurt").mean() >= 0.9


# ----------------------------------------------------------------- inputs
def test_columns_are_matched_by_name() -> None:
    rng = np.random.default_rng(14)
    model = HealthModel(method="pca").fit(_healthy(rng, 600))
    later = _healthy(rng, 10)
    reordered = later[["peak", "kurt", "rms", "temp"]].assign(extra=1.0)
    np.testing.assert_array_equal(model.score(reordered), model.score(later))
    with pytest.raises(DataError, match=r"\['temp', 'kurt'\]"):
        model.score(later.drop(columns=["temp", "kurt"]))
    np.testing.assert_array_equal(model.score(later.to_numpy()), model.score(later))
    with pytest.raises(DataError, match="3 feature"):
        model.score(later.to_numpy()[:, :3])


def test_non_finite_values_are_named_in_one_line() -> None:
    rng = np.random.default_rng(15)
    model = HealthModel(method="pca").fit(_healthy(rng, 600))
    bad = _healthy(rng, 10).set_axis(list("abcdefghij"))
    bad.loc["c", "temp"] = np.nan
    bad.loc["h", "peak"] = np.inf
    with pytest.raises(DataError) as err:
        model.score(bad)
    msg = str(err.value)
    assert "\n" not in msg and "2 row(s) (c, h)" in msg and "['temp', 'peak']" in msg
    with pytest.raises(DataError, match="NaN/inf"):
        HealthModel().fit(bad)
    with pytest.raises(DataError, match="2-D"):
        model.score(np.zeros(4))
    with pytest.raises(DataError, match="non-numeric"):
        model.score(_healthy(rng, 3).assign(rms="x"))


def test_parameter_and_fitting_errors() -> None:
    X = _healthy(np.random.default_rng(16), 200)
    with pytest.raises(NotFittedError):
        HealthModel().score(X)
    with pytest.raises(ModelError, match="method"):
        HealthModel(method="lof").fit(X)
    with pytest.raises(DataError, match="needs at least 99"):
        HealthModel(false_alarm_rate=0.01).fit(X)  # 60 calibration rows
    with pytest.raises(ModelError, match="false_alarm_rate"):
        HealthModel(false_alarm_rate=1.5).fit(X)


def test_keeps_scikit_learns_parameter_contract() -> None:
    name = "HealthModel"
    checks.check_parameters_default_constructible(name, HealthModel())
    for check in (
        checks.check_no_attributes_set_in_init,
        checks.check_get_params_invariance,
        checks.check_set_params,
        checks.check_estimator_cloneable,
        checks.check_estimator_repr,
        checks.check_do_not_raise_errors_in_init_or_set_params,
    ):
        check(name, HealthModel())
    model = HealthModel(method="symbolic", window=8, margin=2.0)
    assert clone(model).get_params() == model.get_params()
    X = _healthy(np.random.default_rng(17), 400)
    assert HealthModel().fit(X) is not None
    assert not hasattr(clone(HealthModel().fit(X)), "threshold_")


# ----------------------------------------------------------------- persistence
@pytest.mark.parametrize("method", METHODS)
def test_save_load_round_trip_gives_identical_answers(method: str, tmp_path) -> None:
    rng = np.random.default_rng(18)
    model = HealthModel(method=method, false_alarm_rate=0.05).fit(_healthy(rng, 500))
    later = _healthy(rng, 80, shift=0.5)
    path = pdmkit.save_model(model, tmp_path / f"{method}.pdmkit")
    loaded = pdmkit.load_model(path)
    assert type(loaded) is HealthModel and loaded.get_params() == model.get_params()
    np.testing.assert_array_equal(loaded.score(later), model.score(later))
    np.testing.assert_array_equal(loaded.alarm_state(later), model.alarm_state(later))
    pd.testing.assert_frame_equal(loaded.contributions(later), model.contributions(later))
    assert loaded.threshold_ == model.threshold_


# ----------------------------------------------------------------- real data
def _benchmark():
    path = Path(__file__).resolve().parents[2] / "benchmarks" / "monitor_run_to_failure.py"
    spec = importlib.util.spec_from_file_location("monitor_run_to_failure", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_ims_test_2_bearing_1_alarms_in_its_second_half(require_data) -> None:
    """IMS test 2 (NASA/IMS bearing data): the outer-race failure of bearing 1."""
    require_data("ims_bearing_features")
    bench = _benchmark()
    table = bench.run(["ims2"], methods=("pca",), baselines=("rms6",)).set_index("unit")
    # the plain 6-sigma RMS threshold, as the issue measured it
    assert table["rms6"].round(3).to_dict() == {
        "bearing 1": 0.548, "bearing 2": 0.852, "bearing 3": 0.916, "bearing 4": 0.715,
    }  # fmt: skip
    assert 0.5 <= table.loc["bearing 1", "hm-pca"] < 0.6
    # the model on bearing 1's baseline: its score climbs far past the threshold
    unit = next(u for u in bench.ims_units(2) if u["unit"] == "bearing 1")
    base = unit["frac"] <= 0.3
    model = HealthModel(false_alarm_rate=0.02).fit(unit["X"][base])
    hi = model.health_index(unit["X"])
    assert np.median(hi[base]) > 0.9 and np.median(hi[unit["frac"] > 0.9]) < 0.01
