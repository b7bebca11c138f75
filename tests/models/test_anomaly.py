"""PCA, RBF-network and MLP anomaly measures.

The methods Khatkhate, Ray & Keller (2007, figure 7) set beside symbolic dynamics, after
Chin, Ray & Rajagopalan (2005).
"""

import numpy as np
import pytest
import scipy.signal as ss

from pdmkit.errors import DataError, ModelError, NotFittedError
from pdmkit.models.diagnosis import MLPAnomaly, PCAAnomaly, RBFAnomaly


def _ar2(r, theta, n, seed):
    """AR(2) with poles r e^{+-j theta}, unit innovations; returns (x, innovation std /
    process std), the best one-step prediction error relative to the signal."""
    a = [1.0, -2 * r * np.cos(theta), r**2]
    rng = np.random.default_rng(seed)
    x = ss.lfilter([1.0], a, rng.normal(size=n + 2000))[2000:]
    return x, 1.0 / np.std(x)


def test_pca_nominal_matrix_is_sklearn_pca():
    """P0 = sum lambda_i v_i v_i^T over the kept components, as sklearn's PCA finds them
    on the same (standardised) delay windows."""
    from sklearn.decomposition import PCA

    x, _ = _ar2(0.95, 0.4, 20000, 0)
    m = PCAAnomaly(window=8, variance=0.9).fit(x)
    z = (x - x.mean()) / x.std()
    W = np.lib.stride_tricks.sliding_window_view(z, 8)
    pca = PCA(n_components=m.n_components_).fit(W)
    ref = (pca.components_.T * pca.explained_variance_) @ pca.components_
    assert np.allclose(m.P0_, ref, rtol=1e-6, atol=1e-9)
    assert pca.explained_variance_ratio_.sum() >= 0.9
    assert m.to_pandas()["n_components"] == m.n_components_


@pytest.mark.parametrize("cls", [RBFAnomaly, MLPAnomaly])
def test_networks_learn_the_optimal_predictor_of_a_linear_process(cls):
    """On an AR(2) process the best one-step predictor leaves the innovations; a
    trained network's error comes close to that closed-form floor."""
    x, floor = _ar2(0.9, 0.5, 30000, 1)
    kw = {"max_iter": 80} if cls is MLPAnomaly else {"n_centers": 60}
    m = cls(n_lags=4, **kw).fit(x)
    assert m.rms0_ == pytest.approx(floor, rel=0.15)
    same, _ = _ar2(0.9, 0.5, 30000, 2)
    assert m.score(same)[0] < 0.1


@pytest.mark.parametrize("cls", [PCAAnomaly, RBFAnomaly, MLPAnomaly])
def test_measures_grow_with_the_change_of_the_process(cls):
    """Moving the AR poles further from the nominal ones raises every measure."""
    kw = {"max_iter": 80} if cls is MLPAnomaly else {}
    nominal, _ = _ar2(0.9, 0.5, 20000, 3)
    m = cls(**kw).fit(nominal)
    noise_level = m.score(_ar2(0.9, 0.5, 20000, 4)[0])[0]
    changed = [m.score(_ar2(0.9, 0.5 + d, 20000, 5)[0])[0] for d in (0.1, 0.3)]
    assert noise_level < changed[0] < changed[1]
    assert m.score(np.vstack([nominal[:5000], nominal[5000:10000]])).shape == (2,)


def test_errors():
    with pytest.raises(NotFittedError):
        PCAAnomaly().score(np.zeros(100))
    with pytest.raises(NotFittedError):
        RBFAnomaly().prediction_error(np.zeros(100))
    with pytest.raises(ModelError, match="variance"):
        PCAAnomaly(variance=1.5).fit(np.arange(200.0))
    with pytest.raises(ModelError, match="n_lags"):
        MLPAnomaly(n_lags=0).fit(np.arange(500.0))
    with pytest.raises(DataError, match="NaN"):
        PCAAnomaly().fit(np.r_[np.arange(199.0), np.nan])
    with pytest.raises(DataError, match="at least"):
        RBFAnomaly().fit(np.arange(20.0))
