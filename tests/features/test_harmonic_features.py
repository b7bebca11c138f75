"""SINAD, SNR and THD against closed forms for tones in white noise."""

from __future__ import annotations

import numpy as np
import pytest

import pdmkit.features as pf

FS = 1000.0
N = 10_000
T = np.arange(N) / FS


@pytest.mark.parametrize("sigma", [0.01, 0.05, 0.2])
def test_snr_of_a_sine_in_white_noise(rng, sigma):
    # off-bin frequency and a DC offset: neither may disturb the estimate
    x = 0.5 + np.sin(2 * np.pi * 50.3 * T) + sigma * rng.normal(size=N)
    expected = 10 * np.log10(0.5 / sigma**2)
    h = pf.harmonic(x, FS)
    assert h["SNR"] == pytest.approx(expected, abs=1.0)
    # no harmonics: SINAD is SNR
    assert h["SINAD"] == pytest.approx(expected, abs=1.0)


def test_thd_of_known_harmonic_amplitudes(rng):
    a2, a3, a5 = 0.05, 0.02, 0.01
    f0 = 37.7
    x = (
        np.sin(2 * np.pi * f0 * T)
        + a2 * np.sin(2 * np.pi * 2 * f0 * T + 0.3)
        + a3 * np.sin(2 * np.pi * 3 * f0 * T + 1.1)
        + a5 * np.sin(2 * np.pi * 5 * f0 * T)
        + 1e-4 * rng.normal(size=N)
    )
    h = pf.harmonic(x, FS)
    assert h["THD"] == pytest.approx(10 * np.log10(a2**2 + a3**2 + a5**2), abs=0.5)
    # SINAD counts the harmonics as distortion, SNR removes them
    noise = (1e-4) ** 2
    assert h["SINAD"] == pytest.approx(
        10 * np.log10(0.5 / (noise + (a2**2 + a3**2 + a5**2) / 2)), abs=0.5
    )
    assert h["SNR"] == pytest.approx(10 * np.log10(0.5 / noise), abs=1.0)


def test_harmonics_beyond_n_harmonics_are_noise(rng):
    f0 = 20.0
    x = np.sin(2 * np.pi * f0 * T) + 0.1 * np.sin(2 * np.pi * 7 * f0 * T)
    x += 1e-3 * rng.normal(size=N)
    assert pf.harmonic(x, FS)["THD"] < -60  # the 7th is not among harmonics 2..6
    assert pf.harmonic(x, FS, n_harmonics=7)["THD"] == pytest.approx(-20.0, abs=0.5)


def test_vectorised_rows_equal_single_calls(rng):
    x = np.stack(
        [
            np.sin(2 * np.pi * f * T)
            + 0.1 * np.sin(2 * np.pi * 2 * f * T)
            + s * rng.normal(size=N)
            for f, s in [(13.1, 0.01), (50.0, 0.1), (211.7, 0.03)]
        ]
    )
    batch = pf.harmonic(x, FS)
    for i in range(3):
        one = pf.harmonic(x[i], FS)
        for key in ("SINAD", "SNR", "THD"):
            assert batch[key][i] == pytest.approx(one[key], rel=1e-9)


def test_bad_n_harmonics():
    with pytest.raises(ValueError, match="n_harmonics must be >= 2"):
        pf.harmonic(np.ones(10), FS, n_harmonics=1)
