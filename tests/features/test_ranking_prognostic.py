"""Prognostic ranking (Coble & Hines 2009): timestamps as the time, smoothing, a single
unit, and the IMS run-to-failure test where bearing 1 failed (issue 15)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import pdmkit.features as pf
from pdmkit.errors import DataError


def _coble_hines_monotonicity(paths: list[np.ndarray]) -> float:
    """mean over units of |#positive - #negative differences| / (n - 1)."""
    return float(
        np.mean(
            [
                abs((np.diff(p) > 0).sum() - (np.diff(p) < 0).sum()) / (len(p) - 1)
                for p in paths
            ]
        )
    )


def _noisy_units(rng, n_units=3, n=120):
    rows = []
    for u in range(n_units):
        life = np.arange(n)
        wear = np.exp(life / 40.0) + rng.normal(0, 0.8, n)
        start = pd.Timestamp("2004-02-12 10:32:39") + pd.Timedelta(days=30 * u)
        stamps = start + pd.to_timedelta(10 * life, unit="min")
        rows.append(
            pd.DataFrame(
                {
                    "unit": u,
                    "stamp": stamps.strftime("%Y-%m-%d %H:%M:%S"),
                    "wear": wear,
                    "noise": rng.normal(size=n),
                }
            )
        )
    return pd.concat(rows, ignore_index=True)


def test_text_timestamps_order_the_rows(rng):
    table = _noisy_units(rng)
    shuffled = table.sample(frac=1.0, random_state=3)
    by_stamp = pf.rank_features(shuffled, method="monotonicity", time="stamp")
    reference = _coble_hines_monotonicity(
        [g["wear"].to_numpy() for _, g in table.groupby("unit")]
    )
    assert by_stamp.scores["wear"] == pytest.approx(reference)
    # the same ranking with the time as numbers (seconds)
    numeric = table.assign(
        stamp=pd.to_datetime(table["stamp"]).astype("int64") / 1e9
    ).sample(frac=1.0, random_state=3)
    same = pf.rank_features(numeric, method="monotonicity", time="stamp")
    assert same.scores["wear"] == pytest.approx(reference)


def test_text_that_is_no_time_is_named(rng):
    table = _noisy_units(rng).assign(stamp="soon")
    with pytest.raises(DataError, match="time column 'stamp' holds 'soon'"):
        pf.rank_features(table, method="monotonicity", time="stamp")


def test_window_smooths_each_unit_before_scoring(rng):
    table = _noisy_units(rng)
    raw = pf.rank_features(table, method="monotonicity", time="stamp")
    smooth = pf.rank_features(table, method="monotonicity", time="stamp", window=15)
    # centred moving mean, shrinking at the ends (MATLAB movmean), per unit
    reference = _coble_hines_monotonicity(
        [
            g["wear"].rolling(15, center=True, min_periods=1).mean().to_numpy()
            for _, g in table.groupby("unit")
        ]
    )
    assert smooth.scores["wear"] == pytest.approx(reference)
    # noise hides the rising trend until smoothed; pure noise stays low
    assert raw.scores["wear"] < 0.5 < smooth.scores["wear"]
    assert smooth.top(1) == ["wear"]
    with pytest.raises(DataError, match="window must be a positive number of rows"):
        pf.rank_features(table, method="monotonicity", window=0)


def test_prognosability_of_a_single_unit_is_undefined(rng):
    one = _noisy_units(rng, n_units=1)
    r = pf.rank_features(one, method="prognosability", time="stamp")
    assert r.scores.isna().all()
    assert r.notes["wear"] == "prognosability needs at least two units"
    # with units: exp(-std(failure values) / mean |start - end|) (Coble & Hines)
    three = _noisy_units(rng, n_units=3)
    ends = three.groupby("unit")["wear"].last()
    starts = three.groupby("unit")["wear"].first()
    expected = np.exp(-ends.std(ddof=1) / (starts - ends).abs().mean())
    got = pf.rank_features(three, method="prognosability", time="stamp")
    assert got.scores["wear"] == pytest.approx(expected)


@pytest.mark.real_data
def test_ims_test_2_failed_bearing_is_the_most_monotonic(require_data):
    """IMS test 2 ended in an outer-race failure of bearing 1 (the data set's readme).
    Its smoothed vibration level rises most steadily of the four."""
    path = require_data("ims_bearing_features") / "merged_dataset_BearingTest_2.csv"
    table = pd.read_csv(path)  # first column: the snapshot timestamps, unnamed
    r = pf.rank_features(table, method="monotonicity", time=table.columns[0], window=50)
    assert r.top(1) == ["Bearing 1"]
    raw = pf.rank_features(table, method="monotonicity", time=table.columns[0])
    assert raw.scores.max() < r.scores["Bearing 1"]
