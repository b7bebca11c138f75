"""Symbolic-dynamics anomaly measure (Khatkhate, Ray & Keller 2007, section 6; Ray 2004)."""

import numpy as np
import pytest
import scipy.signal as ss

from pdmkit.errors import ModelError, NotFittedError
from pdmkit.models.diagnosis._symbolic import (
    SymbolicAnomaly,
    max_entropy_partition,
    state_probabilities,
    symbolize,
)


def _oscillator(zeta, seed, n=40000, fs=200.0, wn=2 * np.pi * 11.0):
    """Beam-like mode driven near resonance (Khatkhate et al.: 11.39 Hz sine) plus noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs
    force = np.sin(2 * np.pi * 11.39 * t) + 0.5 * rng.normal(size=n)
    bz, az = ss.bilinear([wn**2], [1.0, 2 * zeta * wn, wn**2], fs=fs)
    x = ss.lfilter(bz, az, force)
    return x + 0.02 * np.std(x) * rng.normal(size=n)


def test_partition_is_maximum_entropy_on_nominal_data():
    x = np.random.default_rng(0).standard_cauchy(100000)
    b = max_entropy_partition(x, 8)
    p = np.bincount(symbolize(x, b), minlength=8) / x.size
    assert np.allclose(p, 1 / 8, atol=1e-3)
    # entropy of the symbol distribution is the maximum log2(8) bits
    assert -np.sum(p * np.log2(p)) == pytest.approx(3.0, abs=1e-4)


def test_state_probabilities_of_a_markov_chain():
    """Stationary word probabilities of a two-state Markov chain (closed form)."""
    rng = np.random.default_rng(1)
    P = np.array([[0.9, 0.1], [0.3, 0.7]])
    s = np.zeros(200000, dtype=int)
    r = rng.random(s.size)
    for i in range(1, s.size):
        s[i] = int(r[i] > P[s[i - 1], 0])
    pi = np.array([0.75, 0.25])  # solves pi P = pi
    p2 = state_probabilities(s, 2, depth=2)
    expected = (pi[:, None] * P).ravel()  # P(ab) = pi_a P_ab
    assert np.allclose(p2, expected, atol=0.01)


@pytest.mark.parametrize("metric", ["l2", "angle"])
@pytest.mark.parametrize("wavelet", [None, (4.0, 8.0)])
def test_anomaly_zero_for_nominal_and_monotone_in_damping_change(metric, wavelet):
    det = SymbolicAnomaly(n_symbols=8, depth=1, metric=metric, wavelet_scales=wavelet)
    det.fit(_oscillator(0.02, seed=0))
    noise_level = det.score(_oscillator(0.02, seed=1))[0]
    changes = [0.02 * (1 + k) for k in (0.25, 0.5, 1.0, 2.0, 4.0)]
    scores = [det.score(_oscillator(z, seed=2 + i))[0] for i, z in enumerate(changes)]
    assert np.all(np.diff(scores) > 0), scores
    assert noise_level < 0.5 * scores[0]
    assert det.score(np.vstack([_oscillator(0.02, 5), _oscillator(0.1, 6)])).shape == (2,)


def test_errors():
    with pytest.raises(NotFittedError):
        SymbolicAnomaly().score(np.zeros(10))
    with pytest.raises(ModelError, match="metric"):
        SymbolicAnomaly(metric="kl").fit(np.arange(10.0))
    with pytest.raises(ModelError, match="n_symbols"):
        max_entropy_partition(np.arange(10.0), 1)


def _logistic(n, r=3.9, x0=0.1234):
    x = np.empty(n)
    x[0] = x0
    for i in range(1, n):
        x[i] = r * x[i - 1] * (1 - x[i - 1])
    return x


def test_uniform_partition_is_equal_widths():
    from pdmkit.models.diagnosis import uniform_partition

    x = np.random.default_rng(0).normal(size=1000)
    b = uniform_partition(x, 5)
    assert np.allclose(b, np.linspace(x.min(), x.max(), 6)[1:-1])
    with pytest.raises(ModelError, match="n_symbols"):
        uniform_partition(x, 1)


def test_sfnn_finds_the_generating_partition_of_the_logistic_map():
    """For a unimodal map the critical point (0.5) is the generating partition (kneading
    theory: Collet & Eckmann 1980); the maximum-entropy partition (the median, 0.59 at
    r = 3.9) is not. SFNN (Kennel & Buhl 2003) must move there and count fewer false
    neighbours."""
    from pdmkit.models.diagnosis import sfnn_fraction, sfnn_partition

    x = _logistic(6000)
    opts = dict(dim=1, delay=1, word_length=9, r_tol=0.2)
    b = sfnn_partition(x, 2, grid=24, **opts)
    assert abs(b[0] - 0.5) < 0.03
    assert abs(np.median(x) - 0.5) > 0.05
    assert sfnn_fraction(x, b, **opts) < 0.2 * sfnn_fraction(x, [np.median(x)], **opts)


def test_symbolic_anomaly_partitions():
    from pdmkit.models.diagnosis import sfnn_fraction, uniform_partition

    x0 = _oscillator(0.02, seed=0, n=20000)
    dets = {
        p: SymbolicAnomaly(6, 1, partition=p, sfnn_options={"r_tol": 0.1, "n_points": 800})
        for p in ("uniform", "max_entropy", "sfnn")
    }
    for p, d in dets.items():
        d.fit(x0)
        assert (
            d.score(_oscillator(0.06, seed=1, n=20000))[0]
            > 3 * d.score(_oscillator(0.02, seed=2, n=20000))[0]
        ), p
    assert np.allclose(dets["uniform"].boundaries_, uniform_partition(x0, 6))
    f = {
        p: sfnn_fraction(x0, d.boundaries_, r_tol=0.1, n_points=800)
        for p, d in dets.items()
    }
    assert f["sfnn"] <= min(f["uniform"], f["max_entropy"])
    with pytest.raises(ModelError, match="partition"):
        SymbolicAnomaly(partition="kmeans").fit(x0)
