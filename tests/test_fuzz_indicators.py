"""Property tests of indicator invariants under scaling, shifting and repetition."""

from __future__ import annotations

import numpy as np
import scipy.stats
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from pdmkit.features import extract

PROPS = settings(max_examples=60, deadline=None)
FS = 1000.0

signals = arrays(
    np.float64,
    st.integers(16, 400),
    elements=st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False, width=64),
)
factors = st.one_of(st.floats(1e-3, 1e3), st.floats(-1e3, -1e-3))


def _stats(x):
    return extract(x, FS, groups=("stats",)).iloc[0]


def _spread(x):
    return np.std(x) > 1e-6 * max(1.0, np.max(np.abs(x)))


@PROPS
@given(x=signals, c=factors)
def test_scaling(x, c):
    assume(_spread(x))
    a, b = _stats(x), _stats(c * x)
    # RMS, Std and the peak-to-peak scale with |c|
    for name in ("stats/RMS", "stats/Std", "stats/PeakToPeak"):
        np.testing.assert_allclose(b[name], abs(c) * a[name], rtol=1e-9)
    # shape indicators do not change (kurtosis even for negative c)
    for name in ("stats/Kurtosis", "stats/CrestFactor", "stats/ShapeFactor"):
        np.testing.assert_allclose(b[name], a[name], rtol=1e-7)
    np.testing.assert_allclose(b["stats/Skewness"], np.sign(c) * a["stats/Skewness"],
                               rtol=1e-7, atol=1e-9)  # fmt: skip


@PROPS
@given(x=signals, shift=st.floats(-1e3, 1e3))
def test_shift(x, shift):
    assume(_spread(x))
    a, b = _stats(x), _stats(x + shift)
    scale = max(1.0, np.max(np.abs(x)), abs(shift))
    np.testing.assert_allclose(b["stats/Std"], a["stats/Std"], rtol=1e-6, atol=1e-9 * scale)
    np.testing.assert_allclose(b["stats/Mean"], a["stats/Mean"] + shift, atol=1e-9 * scale)
    np.testing.assert_allclose(b["stats/PeakToPeak"], a["stats/PeakToPeak"],
                               rtol=1e-9, atol=1e-9 * scale)  # fmt: skip
    assume(a["stats/Std"] > 1e-3 * scale)  # moments of a tiny spread lose digits
    np.testing.assert_allclose(b["stats/Kurtosis"], a["stats/Kurtosis"], rtol=1e-5)


@PROPS
@given(x=signals, k=st.integers(2, 4))
def test_repeating_the_record_keeps_the_statistics(x, k):
    assume(_spread(x))
    a, b = _stats(x), _stats(np.tile(x, k))
    for name in ("stats/Mean", "stats/RMS", "stats/PeakValue"):
        np.testing.assert_allclose(b[name], a[name], rtol=1e-9, atol=1e-9)
    # Std is the sample standard deviation (ddof=1, as MATLAB's std): the population
    # variance std**2 * (n - 1) / n is what repeating the record keeps
    n = len(x)
    np.testing.assert_allclose(
        b["stats/Std"] ** 2 * (k * n - 1) / (k * n),
        a["stats/Std"] ** 2 * (n - 1) / n,
        rtol=1e-9,
    )
    np.testing.assert_allclose(a["stats/Std"], np.std(x, ddof=1), rtol=1e-9)
    np.testing.assert_allclose(b["stats/Kurtosis"], a["stats/Kurtosis"], rtol=1e-6)


@PROPS
@given(x=signals)
def test_moments_match_scipy(x):
    assume(_spread(x))
    a = _stats(x)
    np.testing.assert_allclose(a["stats/Kurtosis"], scipy.stats.kurtosis(x, fisher=False),
                               rtol=1e-6)  # fmt: skip
    np.testing.assert_allclose(a["stats/Skewness"], scipy.stats.skew(x), rtol=1e-6,
                               atol=1e-9)  # fmt: skip
    np.testing.assert_allclose(a["stats/RMS"], np.sqrt(np.mean(x**2)), rtol=1e-12)
