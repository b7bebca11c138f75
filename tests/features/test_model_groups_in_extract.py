"""The model-based indicator groups (ar, frf, hw, fractional) through `extract`."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

import pdmkit.features as pf
from pdmkit.errors import DataError

FS = 1000.0


def _resonators(freqs, zeta=0.02, n=8000, seed=0):
    """Members driven by one white-noise input through resonances at ``freqs`` Hz."""
    rng = np.random.default_rng(seed)
    u = rng.normal(size=n)
    rows = []
    for fn in freqs:
        wn = 2 * np.pi * fn
        s = -zeta * wn + 1j * wn * np.sqrt(1 - zeta**2)
        a = np.real(np.poly([np.exp(s / FS), np.exp(np.conj(s) / FS)]))  # exact poles
        rows.append(signal.lfilter([0.0, 1.0], a, u) + 1e-3 * rng.normal(size=n))
    return u, np.array(rows)


def test_ar_group_finds_each_members_resonance():
    _, x = _resonators([50.0, 120.0])
    table = pf.extract(x, FS, groups=("stats", "ar"), ar_order=2)
    assert {"stats/RMS", "ar/Freq1", "ar/Damp1", "ar/Fit"} <= set(table.columns)
    np.testing.assert_allclose(table["ar/Freq1"], [50.0, 120.0], rtol=0.02)


def test_frf_group_needs_its_input_and_finds_the_peak():
    u, x = _resonators([50.0, 120.0])
    with pytest.raises(DataError, match="frf_input"):
        pf.extract(x, FS, groups=("frf",))
    table = pf.extract(x, FS, groups=("frf",), frf_input=u, frf_nperseg=1024)
    # H1 peak within one frequency bin (fs / nperseg ~ 1 Hz) of the resonance
    np.testing.assert_allclose(table["frf/PeakFreq"], [50.0, 120.0], atol=1.5)


def test_model_group_options_are_checked_by_group():
    u, x = _resonators([50.0])
    with pytest.raises(ValueError, match="frf"):
        pf.extract(x, FS, groups=("stats",), frf_input=u)  # option of an unused group
    assert {"ar", "frf", "hw", "fractional"} <= set(pf.GROUPS)


def test_ensemble_input_named_by_signal():
    from pdmkit.ensembles import Ensemble

    rng = np.random.default_rng(1)
    forces, accels = [], []
    for fn in (40.0, 40.0, 90.0, 90.0):
        u, x = _resonators([fn], seed=int(rng.integers(1 << 30)))
        forces.append(u)
        accels.append(x[0])
    ens = Ensemble(
        {"Force": np.array(forces), "Accel": np.array(accels)},
        fs=FS,
        conditions={"state": ["a", "a", "b", "b"]},
    )
    table = pf.extract_ensemble(
        ens, signals=["Accel"], groups=("frf",), frf_input="Force", frf_nperseg=1024
    )
    np.testing.assert_allclose(table["Accel/frf/PeakFreq"], [40, 40, 90, 90], atol=1.5)
    # each member's own force is its input: a swapped input ruins the coherence
    swapped = Ensemble({"Force": np.array(forces)[::-1], "Accel": np.array(accels)}, fs=FS)
    bad = pf.extract_ensemble(
        swapped, signals=["Accel"], groups=("frf",), frf_input="Force", frf_nperseg=1024
    )
    assert (bad["Accel/frf/MeanCoherence"] < 0.2).all()
    assert (table["Accel/frf/MeanCoherence"] > 0.9).all()
    with pytest.raises(DataError, match="names no signal"):
        pf.extract_ensemble(ens, groups=("frf",), frf_input="Forse")
