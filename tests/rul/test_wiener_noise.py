"""NoisyWienerDegradationModel: a Wiener process read through measurement noise.

References: the plain Wiener model (no noise), a dense Gaussian posterior of the
linear-Gaussian state-space model (independent of the Kalman filter), parameter
recovery and interval calibration on simulated units with known noise.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from pdmkit import load_model, save_model
from pdmkit.errors import DataError
from pdmkit.rul import NoisyWienerDegradationModel, WienerDegradationModel

DRIFT, DRIFT_SD, SIGMA, THRESHOLD = 0.02, 0.003, 0.01, 1.0


def _units(rng, n, tau, first=0, length=400):
    """Units whose level is a Wiener process (drift ~ N(0.02, 0.003^2), sigma 0.01)
    read with noise ``tau``; each fails at the first sample whose *level* reaches 1."""
    rows, lives = [], {}
    for u in range(first, first + n):
        mu = rng.normal(DRIFT, DRIFT_SD)
        level = np.r_[0.0, np.cumsum(rng.normal(mu, SIGMA, length))]
        end = int(np.flatnonzero(level >= THRESHOLD)[0])
        y = level[: end + 1] + rng.normal(0.0, tau, end + 1)
        rows.append(pd.DataFrame({"unit": u, "time": np.arange(end + 1.0), "hi": y}))
        lives[u] = end
    return pd.concat(rows, ignore_index=True), lives


def _cut(rng, table, lives):
    """Each unit's history up to a random 10-90 % of its life, and the true RULs."""
    parts, truth = [], []
    for u, part in table.groupby("unit", sort=False):
        k = int(rng.uniform(0.1, 0.9) * lives[u])
        parts.append(part.iloc[: k + 1])
        truth.append(lives[u] - k)
    return pd.concat(parts, ignore_index=True), np.array(truth, dtype=float)


@pytest.fixture(scope="module")
def noisy_data():
    rng = np.random.default_rng(11)
    train, _ = _units(rng, 60, 0.05)
    test, lives = _units(rng, 300, 0.05, first=1000)
    cut, truth = _cut(rng, test, lives)
    return train, cut, truth


def test_without_noise_it_is_the_wiener_model():
    rng = np.random.default_rng(2)
    train, lives = _units(rng, 20, 0.0)
    cut, _ = _cut(rng, train, lives)
    fixed = {"diffusion_var": SIGMA**2, "prior": {"mean": DRIFT, "var": DRIFT_SD**2}}
    plain = WienerDegradationModel(threshold=THRESHOLD, **fixed).fit(train)
    noisy = NoisyWienerDegradationModel(
        threshold=THRESHOLD, measurement_var=0.0, **fixed
    ).fit(train)
    a, b = plain.posterior(cut), noisy.posterior(cut)
    for unit in a:
        np.testing.assert_allclose(b[unit], a[unit], rtol=1e-9)
    pa, pb = plain.predict(cut), noisy.predict(cut)
    for key in ("estimate", "lower", "upper"):
        np.testing.assert_allclose(getattr(pb, key), getattr(pa, key), rtol=1e-6)


def _dense_posterior(t, y, m0, v0, sigma2, tau2):
    """Posterior mean / covariance of (level at t[-1], drift) of the linear-Gaussian
    model y = x0 + mu (t - t0) + cumulative diffusion + noise, by the normal equations
    with an exactly flat prior on x0 (independent of the Kalman recursion)."""
    n = len(t)
    dt = np.diff(t)
    # theta = (x0, mu, w_1 .. w_{n-1}); y_i = x0 + mu (t_i - t_0) + sum_{k <= i} w_k
    a = np.zeros((n, n + 1))
    a[:, 0] = 1.0
    a[:, 1] = t - t[0]
    a[1:, 2:] = np.tril(np.ones((n - 1, n - 1)))
    prior_precision = np.diag(np.r_[0.0, 1.0 / v0, 1.0 / (sigma2 * dt)])
    prior_mean = np.r_[0.0, m0, np.zeros(n - 1)]
    precision = prior_precision + a.T @ a / tau2
    cov = np.linalg.inv(precision)
    mean = cov @ (prior_precision @ prior_mean + a.T @ y / tau2)
    # level at the last time = x0 + mu (t_n - t_0) + sum w
    c = np.vstack(
        [np.r_[1.0, t[-1] - t[0], np.ones(n - 1)], np.r_[0.0, 1.0, np.zeros(n - 1)]]
    )
    return c @ mean, c @ cov @ c.T


def test_kalman_posterior_equals_dense_gaussian_conditioning():
    rng = np.random.default_rng(5)
    t = np.cumsum(rng.uniform(0.5, 2.0, 40))  # uneven sampling
    y = 0.3 + 0.05 * (t - t[0]) + rng.normal(0, 0.1, t.size)
    m0, v0, s2, t2 = 0.04, 1e-4, 2e-3, 0.01
    model = NoisyWienerDegradationModel(
        threshold=10.0,
        diffusion_var=s2,
        measurement_var=t2,
        prior={"mean": m0, "var": v0},
    )
    table = pd.DataFrame({"unit": 1, "time": t, "hi": y})
    with pytest.warns(UserWarning, match="reaches threshold"):
        model.fit(table)
    x, pxx, m, pmm, pxm = (float(v[0]) for v in model._filter(model._split(table)))
    mean, cov = _dense_posterior(t, y, m0, v0, s2, t2)
    np.testing.assert_allclose([x, m], mean, rtol=1e-6)
    np.testing.assert_allclose([[pxx, pxm], [pxm, pmm]], cov, rtol=1e-5, atol=1e-12)
    assert model.posterior(table)[1] == pytest.approx((mean[1], cov[1, 1]), rel=1e-5)


def test_restricted_likelihood_recovers_diffusion_and_noise():
    rng = np.random.default_rng(7)
    train, _ = _units(rng, 300, 0.05)
    model = NoisyWienerDegradationModel(threshold=THRESHOLD).fit(train)
    assert model.measurement_var_ == pytest.approx(0.05**2, rel=0.1)
    assert model.diffusion_var_ == pytest.approx(SIGMA**2, rel=0.15)
    assert model.drift_mean_ == pytest.approx(DRIFT, rel=0.05)
    assert np.sqrt(model.drift_var_) == pytest.approx(DRIFT_SD, rel=0.3)
    # the plain model reads the noise as diffusion: about sigma^2 + 2 tau^2 per step
    plain = WienerDegradationModel(threshold=THRESHOLD).fit(train)
    assert plain.diffusion_var_ == pytest.approx(SIGMA**2 + 2 * 0.05**2, rel=0.15)


def test_intervals_are_calibrated_and_beat_the_plain_model_on_noisy_data(noisy_data):
    train, cut, truth = noisy_data
    noisy = NoisyWienerDegradationModel(threshold=THRESHOLD).fit(train).predict(cut)
    inside = (noisy.lower <= truth) & (truth <= noisy.upper)
    assert 0.80 <= inside.mean() <= 0.98
    # the median is calibrated too: about half of the true RULs lie below it
    assert 0.4 <= np.mean(truth <= noisy.estimate) <= 0.6
    plain = WienerDegradationModel(threshold=THRESHOLD).fit(train).predict(cut)
    rmse = {
        name: float(np.sqrt(np.mean((p.estimate - truth) ** 2)))
        for name, p in (("noisy", noisy), ("plain", plain))
    }
    width = {
        name: float(np.mean(p.upper - p.lower))
        for name, p in (("noisy", noisy), ("plain", plain))
    }
    assert rmse["noisy"] < 0.75 * rmse["plain"]
    assert width["noisy"] < 0.5 * width["plain"]


def test_trajectory_and_sequential_updates_equal_one_pass(noisy_data):
    train, cut, _ = noisy_data
    model = NoisyWienerDegradationModel(threshold=THRESHOLD).fit(train)
    units = cut["unit"].unique()[:3]
    some = cut[cut["unit"].isin(units)]
    path = model.predict_trajectory(some, every=7).to_pandas()
    for _, row in path.sample(6, random_state=0).iterrows():
        upto = some[(some["unit"] == row["unit"]) & (some["time"] <= row["time"])]
        alone = model.predict(upto)
        assert alone.estimate[0] == pytest.approx(row["rul"], rel=1e-9)
    one = some[some["unit"] == units[0]]
    for part in np.array_split(np.arange(len(one)), 4):
        model.update(one.iloc[part])
    assert model.predict().estimate[0] == pytest.approx(
        model.predict(one).estimate[0], rel=1e-9
    )


def test_saved_model_predicts_the_same(noisy_data, tmp_path):
    train, cut, _ = noisy_data
    model = NoisyWienerDegradationModel(threshold=THRESHOLD).fit(train)
    loaded = load_model(save_model(model, tmp_path / "noisy.pdmkit"))
    some = cut[cut["unit"].isin(cut["unit"].unique()[:5])]
    np.testing.assert_array_equal(
        loaded.predict(some).estimate, model.predict(some).estimate
    )


def test_bad_settings_and_data_are_named():
    t = np.arange(10.0)
    flat = pd.DataFrame({"unit": np.repeat([1, 2], 10), "time": np.tile(t, 2), "hi": 1.0})
    with pytest.raises(DataError, match="constant"):
        NoisyWienerDegradationModel(threshold=0.5).fit(flat)
    line = flat.assign(hi=np.tile(0.1 * t, 2))
    with pytest.raises(DataError, match="no diffusion, no noise"):
        NoisyWienerDegradationModel(threshold=0.5).fit(line)
    with pytest.raises(ValueError, match="measurement_var"):
        NoisyWienerDegradationModel(threshold=0.5, measurement_var="big").fit(line)
    with pytest.raises(ValueError, match="measurement_var"):
        NoisyWienerDegradationModel(threshold=0.5, measurement_var=-1.0).fit(line)
    short = line[line["time"] < 2]
    with pytest.raises(DataError, match="3 or more samples"):
        NoisyWienerDegradationModel(threshold=0.05).fit(short)
