"""Localisation of a residual in time, state/input space and frequency; whiteness."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal, stats

from pdmkit.models.mismatch._locate import (
    region_statistics,
    residual_spectrum,
    residual_windows,
    whiteness_test,
)
from pdmkit.models.ode import showcase_model


def test_windows_rank_bursts_and_shares_sum_to_one(rng):
    t = np.arange(2000) * 0.5
    r = rng.normal(0, 0.01, t.size)
    r[1500:1560] += 0.5  # big burst in window 15 (samples 1500-1599)
    r[400:430] += 0.2  # smaller burst in window 4
    w = residual_windows(t, r, n_windows=20, top=2)
    assert [(x["start"], x["end"]) for x in w] == [(750.0, 800.0), (200.0, 250.0)]
    expected = np.sum(r[1500:1600] ** 2) / np.sum(r**2)
    assert w[0]["share"] == pytest.approx(expected)
    every = residual_windows(t, r, n_windows=20, top=20)
    assert len(every) == 1 and every[0]["share"] == pytest.approx(1.0)


def test_whiteness_pvalues_uniform_under_white_noise():
    """Ljung-Box p-values of white noise are U(0, 1) (KS test) and rarely below 1 %."""
    rng = np.random.default_rng(7)
    p = np.array([whiteness_test(rng.normal(size=600))["p_value"] for _ in range(300)])
    assert stats.kstest(p, "uniform").pvalue > 1e-3
    assert np.mean(p < 0.01) < 0.035


def test_whiteness_detects_correlation_and_input_lag(rng):
    e = rng.normal(size=3000)
    ar = signal.lfilter([1.0], [1.0, -0.5], e)
    res = whiteness_test(ar)
    assert not res["white"] and res["acf_max"] == pytest.approx(0.5, abs=0.05)
    u = rng.normal(size=3000)
    r = np.r_[np.zeros(4), u[:-4]] * 0.5 + rng.normal(size=3000)
    res = whiteness_test(r, {"u": u})
    assert res["inputs"]["u"]["xcorr_lag"] == 4
    assert not res["inputs"]["u"]["uncorrelated"]
    assert res["bound"] == pytest.approx(2.58 / np.sqrt(3000))
    clean = whiteness_test(rng.normal(size=3000), {"u": u})
    assert clean["inputs"]["u"]["xcorr_outside"] <= 0.1
    assert clean["inputs"]["u"]["xcorr_max"] < 4.5 / np.sqrt(3000)


def test_regions_point_at_low_speed_and_high_level():
    t = np.linspace(0, 40, 4000)
    x, v = np.sin(t), np.cos(t)
    msd = showcase_model("mass_spring_damper")
    r = 0.01 * np.sign(v) * (np.abs(v) < 0.08)
    tab = region_statistics(msd, {"x": x, "v": v}, {"F": np.sin(2.3 * t)}, r)
    assert tab.iloc[0]["region"] in ("v near 0", "v reversals")
    assert tab.set_index("region").loc["v near 0", "enrichment"] > 5
    tanks = showcase_model("two_tanks")
    h1 = 0.5 + 0.4 * np.sin(0.3 * t)
    r = np.where(h1 > 0.85, 0.05, 0.0)
    tab = region_statistics(tanks, {"h1": h1, "h2": 0.3 + 0 * t}, {"u": 3 + np.sin(t)}, r)
    assert tab.iloc[0]["region"] == "h1 high"


def test_spectrum_coherence_high_for_input_driven_residual(rng):
    u = rng.normal(size=8192)
    b, a = signal.butter(2, 0.2)
    driven = residual_spectrum(signal.lfilter(b, a, u), {"u": u}, fs=10.0)
    band = driven.index < 0.5  # well inside the pass band (cut-off 1 Hz)
    assert driven.loc[band, "coherence u"].min() > 0.95
    noise = residual_spectrum(rng.normal(size=8192), {"u": u}, fs=10.0)
    assert noise["coherence u"].mean() < 0.05
