"""Spectral features against scipy.signal.welch + find_peaks and trapezoid, per member."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.integrate
import scipy.signal
import scipy.stats

import pdmkit.features as pf
from pdmkit.errors import DataError

FS = 2000.0


@pytest.fixture
def members(rng):
    t = np.arange(6000) / FS
    rows = []
    for _ in range(10):
        f1, f2 = rng.uniform(20, 900, size=2)
        x = np.sin(2 * np.pi * f1 * t) + rng.uniform(0.1, 1) * np.sin(2 * np.pi * f2 * t)
        rows.append(x + rng.uniform(0.05, 1.0) * rng.normal(size=t.size) + rng.normal())
    return np.array(rows)


def _reference(x, nperseg, n_peaks=5):
    f, p = scipy.signal.welch(
        x, FS, window="hann", nperseg=nperseg, noverlap=nperseg // 2, detrend="constant"
    )
    peaks, _ = scipy.signal.find_peaks(p)
    order = peaks[np.argsort(-p[peaks], kind="stable")][:n_peaks]
    return f, p, order


def test_peaks_match_welch_and_find_peaks(members):
    s = pf.spectral(members, FS, nperseg=512, n_peaks=5)
    for i, x in enumerate(members):
        f, p, order = _reference(x, 512)
        got_amp = [s[f"PeakAmp{j}"][i] for j in range(1, 6)]
        got_freq = [s[f"PeakFreq{j}"][i] for j in range(1, 6)]
        np.testing.assert_allclose(got_amp, p[order], rtol=1e-10)
        np.testing.assert_allclose(got_freq, f[order])


def test_default_segment_is_1024_or_the_signal_length(members):
    s = pf.spectral(members[:2], FS)
    f, p, order = _reference(members[0], 1024)
    assert s["PeakAmp1"][0] == pytest.approx(p[order[0]], rel=1e-10)
    short = members[:2, :300]
    s = pf.spectral(short, FS)
    f, p = scipy.signal.welch(short[1], FS, window="hann", nperseg=300, noverlap=150)
    assert s["TotalPower"][1] == pytest.approx(scipy.integrate.trapezoid(p, f), rel=1e-10)


def test_band_and_total_power_match_trapezoid(members):
    bands = [(0, 500), (250.5, 700), (900, 1000)]
    s = pf.spectral(members, FS, nperseg=256, bands=bands)
    for i, x in enumerate(members):
        f, p = scipy.signal.welch(x, FS, window="hann", nperseg=256, noverlap=128)
        assert s["TotalPower"][i] == pytest.approx(
            scipy.integrate.trapezoid(p, f), rel=1e-10
        )
        for lo, hi in bands:
            m = (f >= lo) & (f <= hi)
            expected = scipy.integrate.trapezoid(p[m], f[m])
            assert s[f"BandPower_{lo:g}_{hi:g}Hz"][i] == pytest.approx(expected, rel=1e-10)


def test_total_power_is_the_variance_for_white_noise(rng):
    # Parseval: the density integrates to the (mean-removed) power
    x = 3.0 + 2.0 * rng.normal(size=(4, 50_000))
    s = pf.spectral(x, FS, nperseg=512)
    np.testing.assert_allclose(s["TotalPower"], 4.0, rtol=0.05)


def test_spectral_shape_features_match_their_definitions(members):
    s = pf.spectral(members, FS, nperseg=256)
    for i, x in enumerate(members):
        f, p = scipy.signal.welch(x, FS, window="hann", nperseg=256, noverlap=128)
        centroid = np.average(f, weights=p)
        spread = np.sqrt(np.average((f - centroid) ** 2, weights=p))
        kurt = np.average((f - centroid) ** 4, weights=p) / spread**4
        q = p / p.sum()
        entropy = -np.sum(q * np.log2(q)) / np.log2(len(q))
        flatness = scipy.stats.gmean(p) / np.mean(p)
        assert s["SpectralCentroid"][i] == pytest.approx(centroid, rel=1e-10)
        assert s["SpectralSpread"][i] == pytest.approx(spread, rel=1e-10)
        assert s["SpectralKurtosis"][i] == pytest.approx(kurt, rel=1e-9)
        assert s["SpectralEntropy"][i] == pytest.approx(entropy, rel=1e-10)
        assert s["SpectralFlatness"][i] == pytest.approx(flatness, rel=1e-9)


def test_entropy_and_flatness_bounds(rng):
    noise = rng.normal(size=(3, 40_000))
    t = np.arange(40_000) / FS
    tone = np.sin(2 * np.pi * 250 * t)[None, :]
    s_noise = pf.spectral(noise, FS, nperseg=256)
    s_tone = pf.spectral(tone, FS, nperseg=256)
    assert (s_noise["SpectralEntropy"] > 0.95).all() and (
        s_noise["SpectralEntropy"] <= 1
    ).all()
    assert s_tone["SpectralEntropy"][0] < 0.3
    assert (s_noise["SpectralFlatness"] > 0.8).all()
    assert s_tone["SpectralFlatness"][0] < 1e-3
    # white noise spread over [0, fs/2] is uniform: centroid fs/4, kurtosis 1.8
    np.testing.assert_allclose(s_noise["SpectralCentroid"], FS / 4, rtol=0.02)
    np.testing.assert_allclose(s_noise["SpectralKurtosis"], 1.8, rtol=0.03)


def test_fewer_peaks_than_asked_are_nan():
    x = np.zeros((2, 64))
    x[0] = np.sin(2 * np.pi * 8 * np.arange(64) / 64.0)
    s = pf.spectral(x, 64.0, nperseg=64, n_peaks=3, detrend=False)
    assert s["PeakFreq1"][0] == 8.0
    assert np.isnan(s["PeakAmp1"][1]) and np.isnan(s["PeakFreq3"][1])


def test_flat_topped_peaks_follow_find_peaks():
    # a PSD with a plateau: find_peaks reports its middle (rounded down)
    from pdmkit.features._spectral import _peak_mask_rows

    p = np.array([[0.0, 1.0, 3.0, 3.0, 3.0, 3.0, 1.0, 2.0, 2.0, 0.5, 4.0, 4.0]])
    _, cols = _peak_mask_rows(p)
    expected, _ = scipy.signal.find_peaks(p[0])
    assert cols.tolist() == expected.tolist()


def test_axis_and_single_member(members):
    a = pf.spectral(members[:3], FS, nperseg=256)
    b = pf.spectral(members[:3].T, FS, nperseg=256, axis=0)
    c = pf.spectral(members[1], FS, nperseg=256)
    for key in a:
        np.testing.assert_allclose(a[key], b[key], equal_nan=True)
        assert c[key] == pytest.approx(a[key][1], nan_ok=True)


def test_short_signal_names_length_and_nperseg():
    with pytest.raises(DataError, match=r"100 samples.*nperseg=256.*nperseg<=100"):
        pf.spectral(np.ones((2, 100)), FS, nperseg=256)


def test_bad_options():
    x = np.ones(1000)
    with pytest.raises(ValueError, match="noverlap must be less than nperseg"):
        pf.spectral(x, FS, nperseg=100, noverlap=100)
    with pytest.raises(DataError, match=r"band \(10, 11\) Hz covers .* PSD bin"):
        pf.spectral(x, FS, nperseg=100, bands=[(10, 11)])
    with pytest.raises(ValueError, match="lo < hi"):
        pf.spectral(x, FS, bands=[(500, 100)])
    with pytest.raises(ValueError, match="fs must be a positive"):
        pf.spectral(x, -1.0)


@pytest.mark.parametrize(
    ("n", "nperseg", "noverlap", "detrend"),
    [
        (10_000, 1024, 512, "constant"),
        (3000, 256, 100, False),
        (1000, 1000, 500, "constant"),
        (777, 8, 7, "constant"),
        (3000, 255, 127, "constant"),  # odd: scipy itself
        (3000, 256, 128, "linear"),  # scipy itself
    ],
)
def test_batched_psd_equals_scipy_welch(rng, n, nperseg, noverlap, detrend):
    from pdmkit.features._spectral import welch_rows

    t = np.arange(n) / FS
    x = 5.0 + rng.normal(size=(4, n)) * [[0.01], [0.1], [1.0], [3.0]]
    x += np.sin(2 * np.pi * 123.4 * t) + 0.5 * np.cos(2 * np.pi * 600.1 * t)
    f_ref, p_ref = scipy.signal.welch(
        x, FS, window="hann", nperseg=nperseg, noverlap=noverlap, detrend=detrend
    )
    f, p = welch_rows(x, FS, nperseg, noverlap, detrend)
    np.testing.assert_allclose(f, f_ref)
    # bin by bin, relative: noise floors down to ~1e-8 of the tones here
    np.testing.assert_allclose(p, p_ref, rtol=1e-7, atol=1e-14 * p_ref.max())


def _pwelch_by_hand(x, fs):
    """MATLAB's documented ``pwelch`` defaults, written out (not scipy's welch)."""
    n = len(x)
    segment = int(n // 4.5)  # eight segments, overlapping by half
    step = segment - segment // 2
    nfft = max(256, 2 ** int(np.ceil(np.log2(segment))))
    k = np.arange(segment)
    window = 0.54 - 0.46 * np.cos(2 * np.pi * k / (segment - 1))  # MATLAB's hamming
    starts = range(0, n - segment + 1, step)
    power = np.mean(
        [np.abs(np.fft.fft(x[s : s + segment] * window, nfft)) ** 2 for s in starts],
        axis=0,
    ) / (fs * np.sum(window**2))
    onesided = power[: nfft // 2 + 1].copy()
    onesided[1:-1] *= 2.0
    return np.arange(nfft // 2 + 1) * fs / nfft, onesided, len(starts)


def test_matlab_pwelch_is_matlabs_documented_default(rng):
    x = np.cumsum(rng.normal(size=10_000)) + 3.0  # a wandering level: DC kept
    f, p = pf.matlab_pwelch(x, 1000.0)
    f_ref, p_ref, n_segments = _pwelch_by_hand(x, 1000.0)
    assert n_segments == 8 and len(f) == 2049 and f[1] == pytest.approx(1000 / 4096)
    np.testing.assert_allclose(f, f_ref)
    np.testing.assert_allclose(p, p_ref, rtol=1e-10, atol=1e-12 * p_ref.max())
    # a batch gives each row's own PSD
    _, batch = pf.matlab_pwelch(np.stack([x, 2 * x]), 1000.0)
    np.testing.assert_allclose(batch[1], 4 * p, rtol=1e-12)


def test_spectral_on_matlabs_welch_peaks_and_band_power(rng):
    x = np.cumsum(rng.normal(size=(3, 10_000)), axis=1)
    s = pf.spectral(x, 1000.0, frange=(0, 40), n_peaks=10, welch="matlab")
    for i, row in enumerate(x):
        f, p, _ = _pwelch_by_hand(row, 1000.0)
        keep = f <= 40
        f, p = f[keep], p[keep]
        peaks, _ = scipy.signal.find_peaks(p)
        order = peaks[np.argsort(-p[peaks], kind="stable")][:10]
        np.testing.assert_allclose(s["PeakFreq1"][i], f[order[0]])
        np.testing.assert_allclose(
            [s[f"PeakAmp{j + 1}"][i] for j in range(len(order))], p[order], rtol=1e-9
        )
        total = scipy.integrate.trapezoid(p, f)
        assert s["TotalPower"][i] == pytest.approx(total, rel=1e-9)


def test_matlab_welch_bad_options():
    x = np.zeros((2, 1000))
    with pytest.raises(DataError, match="welch must be"):
        pf.spectral(x, 100.0, welch="matlab2")
    with pytest.raises(DataError, match="leave nperseg"):
        pf.spectral(x, 100.0, welch="matlab", nperseg=128)
    with pytest.raises(DataError, match="at least 9 samples"):
        pf.matlab_pwelch(np.zeros(5), 100.0)
    with pytest.raises(DataError, match=r"NaN|inf|finite"):
        pf.matlab_pwelch(np.array([0.0, np.nan] * 20), 100.0)


def test_matlab_welch_is_a_spectral_group_option(rng):
    # the Designer's spectrum through the feature registry (pdmkit features --option
    # welch=matlab): extract's columns are spectral's
    x = np.cumsum(rng.normal(size=(4, 5000)), axis=1)
    table = pf.extract(x, 1000.0, groups=("spectral",), welch="matlab", frange=(0, 40))
    direct = pf.spectral(x, 1000.0, welch="matlab", frange=(0, 40))
    for name in ("PeakAmp1", "PeakFreq2", "TotalPower", "SpectralCentroid"):
        np.testing.assert_allclose(table[f"spectral/{name}"], direct[name])
    assert pf.group_of_option("welch") == "spectral"
