"""Model-based indicator groups frf / hw / fractional."""

import numpy as np
import pytest
import scipy.signal as ss

from pdmkit.errors import ConvergenceWarning, DataError
from pdmkit.features._model_features import (
    FRACTIONAL_FEATURES,
    FRF_FEATURES,
    _model_feature_rows,
    fractional_features,
    frf_features,
    hw_feature_names,
    hw_features,
    model_feature_names,
    resolve_model_options,
)
from pdmkit.models.frequency import FractionalTF


def test_frf_features_find_resonance_of_known_systems():
    fs = 200.0
    rng = np.random.default_rng(0)
    u = rng.normal(size=(3, 16384))
    wns, zeta = [30.0, 45.0, 60.0], 0.05
    y = np.array(
        [
            ss.lfilter(*ss.bilinear([w**2], [1, 2 * zeta * w, w**2], fs=fs), u[i])
            for i, w in enumerate(wns)
        ]
    )
    t = frf_features(u, y, fs, nperseg=2048, fmax=30.0)
    assert list(t.columns) == [f"frf/{n}" for n in FRF_FEATURES]
    # bilinear warping: the digital resonance sits at 2 fs atan(w / (2 fs))
    warped = 2 * fs * np.arctan(np.array(wns) / (2 * fs))
    assert np.allclose(t["frf/Wn"], warped, rtol=0.01)
    assert np.allclose(t["frf/Zeta"], zeta, rtol=0.15)
    assert np.allclose(t["frf/PeakFreq"], warped / (2 * np.pi), atol=fs / 2048)
    assert np.all(t["frf/MeanCoherence"] > 0.95)


def test_hw_features_track_saturation_per_member():
    u = np.sign(np.sin(np.linspace(0, 12, 600)))
    lin = ss.lfilter([0, 0.2], [1, -0.9], u)
    y = np.array([np.clip(lin, -lim, lim) for lim in (1.0, 1.5)])
    t = hw_features(u, y, 100.0, nb=1, nf=1)
    assert list(t.columns) == [f"hw/{n}" for n in hw_feature_names(nb=1, nf=1)]
    assert np.allclose(t["hw/OutUpper"], [1.0, 1.5], atol=0.01)
    assert np.allclose(t["hw/F1"], -0.9, atol=0.01)


def test_fractional_features_recover_orders():
    rng = np.random.default_rng(3)
    u = rng.normal(size=(2, 4000))
    y = np.array(
        [
            FractionalTF.seed004(0.05, a, 0.2, 0.5, 1.0).simulate(u[i], 0.01)
            for i, a in enumerate((1.3, 1.7))
        ]
    )
    t = fractional_features(u, y, 100.0)
    assert list(t.columns) == [f"fractional/{n}" for n in FRACTIONAL_FEATURES]
    assert np.allclose(t["fractional/Alpha"], [1.3, 1.7], atol=0.05)


def test_failed_member_gives_nan_and_warning():
    rng = np.random.default_rng(4)
    u = np.vstack([rng.normal(size=2000), np.zeros(2000)])  # member 1: no excitation
    y = np.vstack([ss.lfilter([0.5], [1, -0.5], u[0]), rng.normal(size=2000)])
    with pytest.warns(ConvergenceWarning, match="row"):
        t = fractional_features(u, y, 100.0)
    assert t.iloc[1].isna().all() and t.iloc[0].notna().all()


def test_extract_hooks():
    y = np.random.default_rng(5).normal(size=(2, 600))
    u = np.sign(np.sin(np.linspace(0, 12, 600)))
    s = resolve_model_options("hw", 2, 600, hw_input=u, hw_nb=1, hw_nf=1)
    rows = _model_feature_rows("hw", y, 100.0, s, slice(0, 2))
    assert list(rows) == model_feature_names("hw", s)
    assert all(v.shape == (2,) for v in rows.values())
    with pytest.raises(DataError, match="hw_input"):
        resolve_model_options("hw", 2, 600)
    with pytest.raises(DataError, match="shape"):
        resolve_model_options("frf", 2, 600, frf_input=np.zeros((3, 600)))
    with pytest.raises(DataError, match="unknown options"):
        resolve_model_options("frf", 2, 600, frf_input=u, frf_bogus=1)
