"""Feature group "ar": resonances and damping of known AR processes, vectorised."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from pdmkit.errors import DataError
from pdmkit.features._ar import ar_feature_names, ar_features

FS = 2000.0


def resonant_noise(modes, n, rng, fs=FS):
    s = []
    for fn, zeta in modes:
        p = 2 * np.pi * fn * (-zeta + 1j * np.sqrt(1 - zeta**2))
        s += [p, p.conjugate()]
    a = np.real(np.poly(np.exp(np.array(s) / fs)))
    return signal.lfilter([1.0], a, rng.normal(size=n))


def test_members_with_different_resonances():
    rng = np.random.default_rng(0)
    truth = [[(100.0, 0.01), (300.0, 0.03)], [(110.0, 0.01), (300.0, 0.06)]]
    x = np.stack([resonant_noise(m, 40000, rng) for m in truth])
    table = ar_features(x, FS, order=4)
    assert list(table.columns) == [f"ar/{n}" for n in ar_feature_names(4)]
    for row, modes in enumerate(truth):
        for k, (fn, zeta) in enumerate(modes, start=1):
            assert table.loc[row, f"ar/Freq{k}"] == pytest.approx(fn, rel=0.01)
            assert table.loc[row, f"ar/Damp{k}"] == pytest.approx(zeta, rel=0.15)
    # an exact AR(4) explains all but the driving noise: innovations std 1
    np.testing.assert_allclose(table["ar/ResidualStd"], 1.0, rtol=0.02)
    assert (table["ar/Fit"] > 50).all()


def test_matches_numpy_least_squares_per_member():
    # independent reference: np.linalg.lstsq on the regression matrix of each member
    rng = np.random.default_rng(1)
    x = rng.normal(size=(3, 500)).cumsum(axis=1) * 0.1 + rng.normal(size=(3, 500))
    p = 3
    table = ar_features(x, FS, order=p)
    for r in range(3):
        y = x[r] - x[r].mean()
        phi = -np.column_stack([y[p - i : y.size - i] for i in range(1, p + 1)])
        a = np.linalg.lstsq(phi, y[p:], rcond=None)[0]
        e = y[p:] - phi @ a
        assert table.loc[r, "ar/ResidualStd"] == pytest.approx(e.std(), rel=1e-6)
        z = np.roots(np.r_[1.0, a])
        pairs = z[z.imag > 1e-12]
        if pairs.size:
            fn = np.abs(np.log(pairs) * FS).min() / (2 * np.pi)
            assert table.loc[r, "ar/Freq1"] == pytest.approx(fn, rel=1e-6)


def test_fewer_pairs_than_slots_gives_nan_and_axis():
    rng = np.random.default_rng(2)
    y = resonant_noise([(200.0, 0.02)], 5000, rng)
    t = ar_features(np.stack([y, y]).T, FS, order=4, axis=0)
    assert len(t) == 2
    assert t["ar/Freq1"].notna().all()
    assert t["ar/Freq1"].iloc[0] == pytest.approx(200.0, rel=0.01)


def test_errors_name_the_rows():
    x = np.zeros((3, 100))
    x[1, 7] = np.nan
    with pytest.raises(DataError, match="row 1"):
        ar_features(x, FS)
    with pytest.raises(DataError, match="AR\\(40\\)"):
        ar_features(np.ones(100), FS, order=40)
    with pytest.raises(ValueError, match="order"):
        ar_features(np.ones(100), FS, order=0)
