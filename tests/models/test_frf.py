"""Frequency-domain identification: FRF, amplitude dependence, TF fits, reduction."""

import numpy as np
import pytest
import scipy.signal as ss

from pdmkit.errors import DataError, ModelError
from pdmkit.models.frequency import (
    FRF,
    amplitude_dependence,
    balanced_truncation,
    fit_frf_params,
    fit_tf,
    frf_estimate,
    hankel_singular_values,
)


def _two_mode_tf(w1=28.9, w2=87.8, z1=0.02, z2=0.03):
    """Continuous two-mode TF (num, den) with resonances w1, w2 rad/s."""
    d1 = [1.0, 2 * z1 * w1, w1**2]
    d2 = [1.0, 2 * z2 * w2, w2**2]
    num = np.polyadd(np.polymul([w1**2], d2), np.polymul([0.5 * w2**2], d1))
    return num, np.polymul(d1, d2)


def test_h1_matches_freqz_and_coherence_reflects_noise():
    rng = np.random.default_rng(0)
    b, a = ss.butter(2, 0.2)
    u = rng.normal(size=2**15)
    y_clean = ss.lfilter(b, a, u)
    y = y_clean + 0.05 * rng.normal(size=u.size)
    frf = frf_estimate(u, y, fs=1.0, nperseg=512)
    _, H_true = ss.freqz(b, a, worN=frf.freq, fs=1.0)
    band = (frf.freq > 0.01) & (frf.freq < 0.15)
    assert np.max(np.abs(frf.H[band] - H_true[band]) / np.abs(H_true[band])) < 0.05
    # theory: gamma^2 = S_yy,clean / (S_yy,clean + S_nn) with white noise 0.05^2
    expected = np.abs(H_true) ** 2 / (np.abs(H_true) ** 2 + 0.05**2)
    assert np.max(np.abs(frf.coherence[band] - expected[band])) < 0.02
    stop = frf.freq > 0.4  # filter stop band: output is mostly noise
    assert frf.coherence[stop].mean() < 0.5


def test_frf_rejects_bad_input():
    with pytest.raises(DataError, match="same shape"):
        frf_estimate(np.ones(100), np.ones(99), fs=10.0)
    with pytest.raises(DataError, match="NaN"):
        frf_estimate(np.full(100, np.nan), np.ones(100), fs=10.0)
    with pytest.raises(DataError, match="nperseg"):
        frf_estimate(np.ones(100), np.ones(100), fs=10.0, nperseg=1000)


def _dead_zone(x, w):
    return np.sign(x) * np.maximum(np.abs(x) - w, 0.0)


def test_amplitude_dependence_linear_vs_dead_zone():
    rng = np.random.default_rng(3)
    amps = np.array([0.3, 1.0, 3.0])
    u = amps[:, None] * rng.normal(size=(3, 16384))
    b, a = [0.1, 0.05], [1.0, -1.2, 0.5]
    noise = 0.01 * rng.normal(size=u.shape)
    lin = amplitude_dependence(frf_estimate(u, ss.lfilter(b, a, u) + noise, 1.0))
    assert not lin.nonlinear
    assert np.all(lin.deviation_db < 0.5)
    # dead zone of width 0.3 before the linear block: the small amplitude loses most
    # of its gain, the large one little (describing function)
    y_nl = ss.lfilter(b, a, _dead_zone(u, 0.3)) + noise
    nl = amplitude_dependence(frf_estimate(u, y_nl, 1.0))
    assert nl.nonlinear
    assert nl.deviation_db[0] > 3.0 > nl.deviation_db[1]
    assert nl.p_value[0] < 1e-6
    assert list(nl.to_pandas().columns)[:2] == ["amplitude", "deviation_db"]


def test_fit_tf_s_recovers_poles_from_noisy_frf():
    num, den = _two_mode_tf()
    w = np.linspace(5, 130, 300)
    _, H = ss.freqs(num, den, worN=w)
    rng = np.random.default_rng(1)
    Hn = H * (1 + 0.01 * (rng.normal(size=w.size) + 1j * rng.normal(size=w.size)))
    fit = fit_tf(w / (2 * np.pi), Hn, nb=2, na=4)
    true_p = np.sort_complex(np.roots(den))
    got_p = np.sort_complex(fit.poles)
    assert np.allclose(np.abs(got_p), np.abs(true_p), rtol=2e-3)
    # damping of a 2 % mode within 10 % of its value
    assert np.allclose(-got_p.real / np.abs(got_p), -true_p.real / np.abs(true_p), rtol=0.1)
    # invfreqs-like: the fitted model's response agrees with scipy.signal.freqs of the
    # true system (relative error far below the resonance-to-antiresonance range)
    wt = np.linspace(5, 130, 1000)
    _, Ht = ss.freqs(num, den, worN=wt)
    Hm = fit.frequency_response(wt / (2 * np.pi))
    assert np.median(np.abs(Hm - Ht) / np.abs(Ht)) < 0.01
    assert fit.fit_percent > 95
    assert fit.to_pandas()["wn_rad_s"].round(0).tolist().count(29.0) == 2


def test_fit_tf_z_matches_discretised_system():
    dt = 0.002  # Khatkhate, Ray & Keller (2007): identification sampled at 2 ms
    num, den = _two_mode_tf()
    bz, az, _ = ss.cont2discrete((num, den), dt, method="zoh")
    bz = np.squeeze(bz)
    f = np.linspace(0.5, 20, 176)  # Khatkhate et al.: 176 points up to ~18-20 Hz
    _, H = ss.freqz(bz, az, worN=f, fs=1 / dt)
    rng = np.random.default_rng(2)
    Hn = H * (1 + 0.005 * (rng.normal(size=f.size) + 1j * rng.normal(size=f.size)))
    fit = fit_tf(f, Hn, nb=4, na=4, domain="z", fs=1 / dt)
    got = np.sort_complex(fit.poles)
    true = np.sort_complex(np.roots(az))
    assert np.allclose(got, true, atol=2e-4)
    s_poles = np.log(got.astype(complex)) / dt
    assert np.allclose(np.sort(np.abs(s_poles))[::2], [28.9, 87.8], rtol=2e-3)
    ctl = fit.to_control()
    assert ctl.dt == dt


def test_fit_tf_reflects_unstable_poles():
    # data from a non-causal/unstable description: 1/(s - 2): magnitude of 1/(s + 2)
    w = np.linspace(0.1, 20, 100)
    H = 1.0 / (1j * w - 2.0)
    fit = fit_tf(w / (2 * np.pi), H, nb=0, na=1, stable=True)
    assert fit.reflected == 1
    assert np.all(fit.poles.real < 0)
    assert np.allclose(fit.poles, [-2.0], rtol=1e-6)
    free = fit_tf(w / (2 * np.pi), H, nb=0, na=1, stable=False)
    assert np.allclose(free.poles, [2.0], rtol=1e-6)


def test_fit_tf_errors():
    with pytest.raises(ModelError, match="fs"):
        fit_tf([1, 2, 3], [1, 1, 1], 0, 1, domain="z")
    with pytest.raises(DataError, match="frequencies cannot"):
        fit_tf([1.0], [1.0], 4, 4)


def test_grey_box_fit_recovers_msd_from_measured_frf():
    """The S-Mobile paper's loop: measure an FRF with coherence, fit physical parameters."""
    m, c, k = 1.0, 4.0, 2500.0  # wn = 50 rad/s (8 Hz), zeta = 0.04
    fs = 500.0
    bz, az, _ = ss.cont2discrete(([1.0], [m, c, k]), 1 / fs, method="bilinear")
    rng = np.random.default_rng(4)
    u = rng.normal(size=60000)
    y = ss.lfilter(np.squeeze(bz), az, u)
    y = y + 0.05 * np.std(y) * rng.normal(size=y.size)
    frf = frf_estimate(u, y, fs, nperseg=2048, fmin=1.0, fmax=30.0)

    def msd(omega, m, c, k):
        # bilinear map of the continuous model: what the sampled system really is
        s = 2 * fs * np.tan(omega / (2 * fs))
        return 1.0 / (m * (1j * s) ** 2 + c * (1j * s) + k)

    fit = fit_frf_params(msd, {"c": 1.0, "k": 1000.0}, frf, fixed={"m": m})
    assert fit.params["k"] == pytest.approx(k, rel=0.01)
    assert fit.params["c"] == pytest.approx(c, rel=0.1)
    nm = fit_frf_params(
        msd, {"c": 1.0, "k": 1500.0}, frf, fixed={"m": m}, method="nelder-mead"
    )
    assert nm.params["k"] == pytest.approx(k, rel=0.01)
    assert fit.rms_db < 1.0
    assert set(fit.to_pandas().index) == {"c", "k", "rms_db", "rms_deg"}


def test_grey_box_coherence_weighting_ignores_corrupted_band():
    f = np.linspace(0.5, 20, 200)
    s = 2j * np.pi * f
    H = 1.0 / (s**2 + 2 * s + 400.0)
    coh = np.ones_like(f)
    bad = f > 12
    H = np.where(bad, 10 * H, H)  # garbage where the coherence is low
    coh[bad] = 0.2
    model = lambda omega, c, k: 1.0 / ((1j * omega) ** 2 + c * 1j * omega + k)  # noqa: E731
    fit = fit_frf_params(model, {"c": 1.0, "k": 300.0}, FRF(f, H, coh), coherence_min=0.7)
    assert fit.params["k"] == pytest.approx(400.0, rel=1e-4)


def _three_mode_ss():
    """Modal state space: two strong modes and a weak one, plus a fast weak pole."""
    blocks, bs, cs = [], [], []
    for wn, z, gain in [(28.9, 0.05, 1.0), (87.8, 0.05, 1.0), (200.0, 0.1, 0.01)]:
        blocks.append(np.array([[0.0, 1.0], [-(wn**2), -2 * z * wn]]))
        bs.append([[0.0], [wn**2 * gain]])
        cs.append([1.0, 0.0])
    A = np.zeros((6, 6))
    for i, blk in enumerate(blocks):
        A[2 * i : 2 * i + 2, 2 * i : 2 * i + 2] = blk
    B = np.vstack(bs)
    C = np.array([np.concatenate(cs)])
    return A, B, C, np.zeros((1, 1))


def test_balanced_truncation_keeps_dominant_poles_and_error_bound():
    A, B, C, D = _three_mode_ss()
    red = balanced_truncation((A, B, C, D), order=4)
    wn = np.sort(np.abs(red.poles))
    assert np.allclose(wn, [28.9, 28.9, 87.8, 87.8], rtol=0.01)
    # H-infinity error on a dense grid: between sigma_5 and 2 * (sigma_5 + sigma_6)
    f = np.linspace(0, 100, 20001)
    w = 2 * np.pi * f
    s = 1j * w
    H_full = sum(  # closed form of the modal model
        g * wn**2 / (s**2 + 2 * z * wn * s + wn**2)
        for wn, z, g in [(28.9, 0.05, 1.0), (87.8, 0.05, 1.0), (200.0, 0.1, 0.01)]
    )
    err = np.max(np.abs(H_full - red.frequency_response(f)[0, 0]))
    assert err <= red.error_bound * (1 + 1e-9)
    assert err >= red.hsv[4] * (1 - 1e-3)
    assert red.error_bound == pytest.approx(2 * red.hsv[4:].sum())
    assert red.to_pandas()["kept"].sum() == 4
    by_tol = balanced_truncation((A, B, C, D), tol=red.error_bound * 1.01)
    assert by_tol.order == 4


def test_hankel_singular_values_match_hankel_matrix_of_markov_parameters():
    """Discrete HSVs are the singular values of the infinite Hankel matrix."""
    rng = np.random.default_rng(5)
    Q, _ = np.linalg.qr(rng.normal(size=(4, 4)))
    A = Q @ np.diag([0.9, -0.7, 0.5, 0.2]) @ Q.T
    B = rng.normal(size=(4, 1))
    C = rng.normal(size=(1, 4))
    markov = [(C @ np.linalg.matrix_power(A, k) @ B).item() for k in range(400)]
    n = 200
    hank = np.array([[markov[i + j] for j in range(n)] for i in range(n)])
    ref = np.linalg.svd(hank, compute_uv=False)[:4]
    got = hankel_singular_values((A, B, C, np.zeros((1, 1)), 1.0))
    assert np.allclose(got, ref, rtol=1e-8)


def test_balanced_truncation_errors_and_control_input():
    control = pytest.importorskip("control")
    with pytest.raises(ModelError, match="stable"):
        balanced_truncation((np.array([[1.0]]), [[1.0]], [[1.0]], [[0.0]]), order=1)
    sys = control.ss(control.tf([1.0], [1.0, 3.0, 2.0]))
    red = balanced_truncation(sys, order=1)
    assert red.order == 1 and red.poles.real[0] < 0
    with pytest.raises(ModelError, match="order"):
        balanced_truncation(sys, order=5)
