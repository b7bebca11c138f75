"""Time-domain statistics against scipy/numpy and closed forms."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.stats

import pdmkit.features as pf
from pdmkit.errors import DataError


@pytest.fixture
def members(rng):
    """Members with different shapes of distribution: Gauss, skewed, impulsive, offset."""
    x = rng.normal(size=(12, 3000)) * rng.uniform(0.5, 3.0, size=(12, 1))
    x[3:6] = rng.exponential(size=(3, 3000))
    x[6:9] = rng.standard_t(3, size=(3, 3000))
    x[9:] += rng.uniform(-5, 5, size=(3, 1))
    return x


def test_moments_match_scipy(members):
    s = pf.stats(members)
    np.testing.assert_allclose(s["Mean"], members.mean(axis=1), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(s["Std"], members.std(axis=1, ddof=1), rtol=1e-12)
    np.testing.assert_allclose(s["RMS"], np.sqrt(np.mean(members**2, axis=1)), rtol=1e-12)
    np.testing.assert_allclose(s["Skewness"], scipy.stats.skew(members, axis=1), rtol=1e-10)
    np.testing.assert_allclose(
        s["Kurtosis"], scipy.stats.kurtosis(members, axis=1, fisher=False), rtol=1e-10
    )


def test_peak_based_factors_match_their_definitions(members):
    s = pf.stats(members)
    peak = np.abs(members).max(axis=1)
    rms = np.sqrt(np.mean(members**2, axis=1))
    mean_abs = np.abs(members).mean(axis=1)
    np.testing.assert_allclose(s["PeakValue"], peak)
    np.testing.assert_allclose(s["PeakToPeak"], np.ptp(members, axis=1))
    np.testing.assert_allclose(s["CrestFactor"], peak / rms, rtol=1e-12)
    np.testing.assert_allclose(
        s["ClearanceFactor"],
        peak / np.mean(np.sqrt(np.abs(members)), axis=1) ** 2,
        rtol=1e-12,
    )
    np.testing.assert_allclose(s["ImpulseFactor"], peak / mean_abs, rtol=1e-12)
    np.testing.assert_allclose(s["ShapeFactor"], rms / mean_abs, rtol=1e-12)


def test_sine_closed_forms():
    # whole periods of a sine of amplitude A: RMS A/sqrt(2), crest sqrt(2), kurtosis 1.5,
    # shape factor pi / (2 sqrt 2), impulse factor pi / 2
    a = 2.5
    t = np.arange(4000) / 4000.0
    s = pf.stats(a * np.sin(2 * np.pi * 10 * t))
    assert s["RMS"] == pytest.approx(a / np.sqrt(2), rel=1e-12)
    assert s["CrestFactor"] == pytest.approx(np.sqrt(2), rel=1e-6)
    assert s["Kurtosis"] == pytest.approx(1.5, rel=1e-9)
    assert s["Skewness"] == pytest.approx(0.0, abs=1e-9)
    # mean |sin| of 400 samples per period is within 1e-4 of 2/pi
    assert s["ShapeFactor"] == pytest.approx(np.pi / (2 * np.sqrt(2)), rel=1e-4)
    assert s["ImpulseFactor"] == pytest.approx(np.pi / 2, rel=1e-4)
    assert s["PeakToPeak"] == pytest.approx(2 * a, rel=1e-6)


def test_gaussian_kurtosis_is_non_excess(rng):
    assert pf.stats(rng.normal(size=200_000))["Kurtosis"] == pytest.approx(3.0, abs=0.05)


def test_axis_and_shapes(members):
    by_rows = pf.stats(members)
    by_cols = pf.stats(members.T, axis=0)
    for name, values in by_rows.items():
        np.testing.assert_allclose(by_cols[name], values, rtol=1e-12, equal_nan=True)
    one = pf.stats(members[0])
    assert isinstance(one["RMS"], float)
    assert one["RMS"] == pytest.approx(by_rows["RMS"][0])
    cube = pf.stats(members.reshape(3, 4, -1))
    assert cube["Kurtosis"].shape == (3, 4)


def test_constant_and_zero_signals_give_nan_not_errors():
    s = pf.stats(np.vstack([np.full(100, 2.0), np.zeros(100)]))
    assert np.isnan(s["Kurtosis"]).all() and np.isnan(s["Skewness"]).all()
    assert s["Std"].tolist() == [0.0, 0.0]
    assert s["CrestFactor"][0] == pytest.approx(1.0)
    assert np.isnan(s["CrestFactor"][1])


def test_integer_input_is_accepted():
    s = pf.stats(np.array([[1, -1, 1, -1]]))
    assert s["RMS"].tolist() == [1.0]


def test_nan_rows_are_named(members):
    members = members.copy()
    members[2, 10] = np.nan
    members[7, 0] = np.inf
    with pytest.raises(DataError, match=r"member rows 2, 7: NaN or inf") as err:
        pf.stats(members)
    assert "row 2: 1 NaN and 0 inf, first at sample 10" in str(err.value)


def test_empty_input_is_rejected():
    with pytest.raises(DataError, match="empty"):
        pf.stats(np.empty((3, 0)))
    with pytest.raises(DataError, match="real numbers"):
        pf.stats(np.array(["a", "b"]))
