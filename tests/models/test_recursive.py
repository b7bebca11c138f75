"""Recursive AR/ARX estimation follows a pole that moves, with the memory 1/(1-lambda)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from pdmkit.errors import DataError, ModelError, NotFittedError
from pdmkit.models.ident import RecursiveARX, smooth_tracks, track_poles

FS = 1000.0


def a_poly(modes, fs=FS):
    """Denominator with the poles exp(s T) of the chosen (frequency Hz, damping) modes."""
    s = []
    for fn, zeta in modes:
        wn = 2 * np.pi * fn
        p = -zeta * wn + 1j * wn * np.sqrt(1 - zeta**2)
        s += [p, p.conjugate()]
    return np.real(np.poly(np.exp(np.array(s) / fs)))


def stepped_record(seed, t0=4000, n=7000):
    a1 = a_poly([(50.0, 0.02), (120.0, 0.03)])
    a2 = a_poly([(52.5, 0.02), (120.0, 0.03)])  # first mode +5 %
    e = np.random.default_rng(seed).normal(size=n)
    y1, zf = signal.lfilter([1.0], a1, e[:t0], zi=np.zeros(4))
    y2, _ = signal.lfilter([1.0], a2, e[t0:], zi=zf)
    return np.r_[y1, y2], t0


def test_frequency_step_followed_within_three_time_constants():
    # the RLS estimate of one record wanders by about +-0.5 Hz (memory of 500
    # samples); the mean over records shows the response to the 2.5 Hz step itself
    lam, t0 = 0.998, 6000
    tau = 1.0 / (1.0 - lam)
    tracks = []
    for seed in range(8):
        y, _ = stepped_record(seed, t0=t0, n=t0 + int(4 * tau))
        est = RecursiveARX(na=4, forgetting=lam, fs=FS).fit(y)
        tracks.append(est.tracks_.natural_frequencies_hz)
        # the second mode keeps its own track (no swapping with the first)
        assert np.all(np.abs(tracks[-1][1000:, 1] - 120.0) < 5.0)
    assert est.time_constant == pytest.approx(tau)
    f = np.mean(tracks, axis=0)[:, 0]
    assert f[t0 - 200 : t0].mean() == pytest.approx(50.0, abs=0.3)
    # exponential forgetting: after 3 tau, e**-3 = 5 % of the step is left
    k3 = t0 + int(3 * tau)
    assert f[k3 - 50 : k3 + 50].mean() == pytest.approx(52.5, abs=0.4)
    # and not instantly: after a tenth of the memory it has covered under half
    assert f[t0 + int(0.1 * tau)] < 51.25
    # the moving mode's damping is unchanged
    zeta = np.mean([est.tracks_.damping[1000:t0, 0].mean()])
    assert zeta == pytest.approx(0.02, rel=0.5)


def test_median_then_savgol_reduce_track_noise():
    y, t0 = stepped_record(5)
    tr = RecursiveARX(na=4, forgetting=0.995, fs=FS).fit(y).tracks_
    sm = tr.smooth()  # Table 15 of the seed: median 50, SG order 2 over 151
    raw = tr.natural_frequencies_hz[1000:t0, 0]
    smooth = sm.natural_frequencies_hz[1000:t0, 0]
    # sample-to-sample jitter of the track drops by far; its level stays
    assert np.std(np.diff(smooth)) < 0.3 * np.std(np.diff(raw))
    assert abs(smooth.mean() - raw.mean()) < 0.1
    assert list(sm.to_pandas().columns[:3]) == ["time", "f1_hz", "zeta1"]


def test_rls_with_forgetting_one_equals_batch_least_squares():
    rng = np.random.default_rng(0)
    u = rng.normal(size=3000)
    y = signal.lfilter([0, 1.0, 0.5], [1, -1.2, 0.5], u) + 0.1 * rng.normal(size=3000)
    est = RecursiveARX(na=2, nb=2, nk=1, forgetting=1.0, delta=1e8).fit(y, u)
    # independent reference: numpy least squares on the regression matrix
    phi = np.column_stack(
        [-np.r_[0, y[:-1]], -np.r_[0, 0, y[:-2]], np.r_[0, u[:-1]], np.r_[0, 0, u[:-2]]]
    )
    ref = np.linalg.lstsq(phi, y, rcond=None)[0]
    np.testing.assert_allclose(est.theta_[-1], ref, rtol=1e-6)


def test_track_poles_undoes_shuffles():
    rng = np.random.default_rng(1)
    t = np.linspace(0, 1, 50)
    true = np.stack([0.5 + 0.1 * t, 0.8 + 0.1 * t, -0.3 + 0.0 * t], axis=1).astype(complex)
    shuffled = np.array([row[rng.permutation(3)] for row in true])
    shuffled[0] = true[0]
    np.testing.assert_allclose(track_poles(shuffled), true)


def test_smooth_tracks_removes_impulses_keeps_steps():
    x = np.r_[np.zeros(300), np.ones(300)]
    x[100] = 50.0
    y = smooth_tracks(x, median=11, savgol=31)
    assert abs(y[100]) < 1e-9
    assert y[:250].max() < 1e-9 and np.all(np.abs(y[350:] - 1) < 1e-9)


def test_errors():
    with pytest.raises(ModelError, match="forgetting"):
        RecursiveARX(2, forgetting=1.5).fit(np.ones(100))
    with pytest.raises(DataError, match="needs an input"):
        RecursiveARX(2, nb=1).fit(np.ones(100))
    with pytest.raises(NotFittedError):
        RecursiveARX(2).modes()
