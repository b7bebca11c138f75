"""Hammerstein-Wiener models (Voronin's thesis, sections 5.2.1 and 8.2.1)."""

import numpy as np
import pytest
import scipy.signal as ss

from pdmkit.errors import DataError, ModelError, NotFittedError
from pdmkit.models.ident import (
    DeadZone,
    HammersteinWiener,
    PiecewiseLinear,
    Polynomial,
    Saturation,
)


def _steps(rng, n_steps=300, hold=8, amp=1.0):
    return np.repeat(rng.uniform(-amp, amp, n_steps), hold)


def _dead_zone(x, lo, hi):  # independent reference implementation
    return np.piecewise(x, [x < lo, x > hi], [lambda v: v - lo, lambda v: v - hi, 0.0])


def test_recovers_dead_zone_width_within_10_percent_with_noise():
    rng = np.random.default_rng(0)
    u = _steps(rng)
    b, a = [0.2, 0.1], [1.0, -1.1, 0.35]  # stable, resonant-free second order
    y = ss.lfilter(np.r_[0.0, b], a, _dead_zone(u, -0.2, 0.3))
    y = y + 0.02 * np.std(y) * rng.normal(size=y.size)
    hw = HammersteinWiener("deadzone", nb=2, nf=2, nk=1).fit(u, y)
    width = hw.input_params_["upper"] - hw.input_params_["lower"]
    assert width == pytest.approx(0.5, rel=0.1)
    assert hw.input_params_["lower"] == pytest.approx(-0.2, abs=0.05)
    # linear block: poles of a
    assert np.allclose(np.sort_complex(hw.poles_), np.sort_complex(np.roots(a)), atol=0.03)
    assert hw.fit_percent_ > 90
    # generalises to a fresh input
    u2 = _steps(np.random.default_rng(9))
    y2 = ss.lfilter(np.r_[0.0, b], a, _dead_zone(u2, -0.2, 0.3))
    assert np.std(hw.predict(u2) - y2) < 0.05 * np.std(y2)


def test_output_saturation_and_multiple_records():
    rng = np.random.default_rng(1)
    U = np.array([_steps(rng, 150, 10, 2.0) for _ in range(3)])
    lin = ss.lfilter([0.0, 0.5], [1.0, -0.5], U, axis=-1)
    Y = np.clip(lin, -0.8, 1.2) + 0.005 * rng.normal(size=U.shape)
    hw = HammersteinWiener(None, "saturation", nb=1, nf=1).fit(U, Y)
    assert hw.output_params_["lower"] == pytest.approx(-0.8, abs=0.02)
    assert hw.output_params_["upper"] == pytest.approx(1.2, abs=0.02)
    assert hw.f_[0] == pytest.approx(-0.5, abs=0.02)
    assert hw.predict(U).shape == U.shape
    s = hw.to_pandas()
    assert {"out_lower", "out_upper", "b0", "f1", "fit_percent"} <= set(s.index)


def test_polynomial_and_piecewise_inputs():
    rng = np.random.default_rng(2)
    u = _steps(rng, 300, 6)
    w = u + 0.5 * u**2 - 0.3 * u**3
    y = ss.lfilter([0.0, 0.4], [1.0, -0.6], w)
    hw = HammersteinWiener(Polynomial(3), nb=1, nf=1).fit(u, y)
    assert hw.input_params_["c2"] == pytest.approx(0.5, abs=0.02)
    assert hw.input_params_["c3"] == pytest.approx(-0.3, abs=0.02)
    pwl = HammersteinWiener(PiecewiseLinear(7), nb=1, nf=1).fit(u, y)
    assert pwl.fit_percent_ > 90


def test_nonlinearity_blocks_and_errors():
    x = np.linspace(-2, 2, 9)
    assert np.allclose(DeadZone()(x, [-0.5, 0.5]), _dead_zone(x, -0.5, 0.5))
    assert np.allclose(Saturation()(x, [-1, 1]), np.clip(x, -1, 1))
    with pytest.raises(ModelError, match="input_nl"):
        HammersteinWiener("wavelet").fit(np.zeros(50), np.zeros(50))
    with pytest.raises(DataError, match="same shape"):
        HammersteinWiener().fit(np.zeros(50), np.zeros(40))
    with pytest.raises(NotFittedError):
        HammersteinWiener().predict(np.zeros(50))


def test_screened_starts_reach_the_cost_of_running_every_start_to_the_end():
    rng = np.random.default_rng(3)
    u = _steps(rng)
    y = ss.lfilter([0.0, 0.2, 0.1], [1.0, -1.1, 0.35], _dead_zone(u, -0.2, 0.3))
    y = np.clip(y, -0.6, 0.5) + 0.01 * rng.normal(size=y.size)
    kw = {"nb": 2, "nf": 2, "nk": 1}
    screened = HammersteinWiener("deadzone", "saturation", **kw).fit(u, y)
    every = HammersteinWiener("deadzone", "saturation", screen_nfev=300, **kw).fit(u, y)
    assert screened.cost_ <= every.cost_ * 1.02
    assert screened.output_params_["upper"] == pytest.approx(0.5, abs=0.02)
