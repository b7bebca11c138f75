"""Wiener-process degradation model against closed forms and scipy.stats."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy import integrate, stats
from sklearn.base import clone

from pdmkit.errors import DataError, NotFittedError
from pdmkit.rul import WienerDegradationModel
from pdmkit.rul._wiener import wiener_first_passage_cdf


def first_passage_reference(t, d, mu, s2):
    """P(T <= t) for drift ``mu`` of either sign, from scipy's inverse Gaussian.

    For ``mu < 0`` the density is the one of ``|mu|`` times ``exp(2 mu d / s2)``.
    """
    if mu == 0:
        return 2 * stats.norm.sf(d / np.sqrt(s2 * t))  # reflection principle
    ig = stats.invgauss(s2 / (d * abs(mu)), scale=d**2 / s2)
    return np.exp(2 * min(mu, 0.0) * d / s2) * ig.cdf(t)


def wiener_units(rng, n, mu0, sd0, sigma, *, threshold, dt=1.0, t_max=200.0):
    """Unit paths observed every ``dt`` up to the first sample at or past threshold."""
    rows, drifts = [], []
    steps = int(t_max / dt)
    for u in range(n):
        mu = rng.normal(mu0, sd0)
        x = np.r_[0.0, np.cumsum(rng.normal(mu * dt, sigma * np.sqrt(dt), steps))]
        t = dt * np.arange(steps + 1)
        hit = np.flatnonzero(x >= threshold)
        end = hit[0] + 1 if hit.size else steps + 1
        rows.append(pd.DataFrame({"unit": u, "time": t[:end], "hi": x[:end]}))
        drifts.append(mu)
    return pd.concat(rows, ignore_index=True), np.array(drifts)


@pytest.mark.parametrize(
    ("d", "mu", "s2"), [(1.0, 0.05, 0.01), (3.0, 0.5, 0.2), (0.2, 2.0, 1.0)]
)
def test_known_drift_first_passage_is_inverse_gaussian(d, mu, s2):
    ig = stats.invgauss(s2 / (d * mu), scale=d**2 / s2)
    t = ig.ppf(np.linspace(0.001, 0.999, 60))
    got = wiener_first_passage_cdf(t, d, mu, 0.0, s2)
    np.testing.assert_allclose(got, ig.cdf(t), atol=1e-10)


@pytest.mark.parametrize(("m", "v"), [(0.05, 0.02**2), (0.01, 0.01**2), (-0.01, 0.02**2)])
def test_mixed_first_passage_matches_numerical_mixture(m, v):
    d, s2 = 1.0, 0.01
    for t in (5.0, 20.0, 60.0, 400.0):
        ref, _ = integrate.quad(
            lambda mu, t=t: (
                first_passage_reference(t, d, mu, s2) * stats.norm.pdf(mu, m, np.sqrt(v))
            ),
            m - 10 * np.sqrt(v),
            m + 10 * np.sqrt(v),
            epsabs=1e-11,
            limit=200,
        )
        assert wiener_first_passage_cdf(t, d, m, v, s2) == pytest.approx(ref, abs=1e-7)


def test_predicted_quantiles_are_inverse_gaussian_quantiles_for_a_known_drift():
    mu, s2, w = 0.4, 0.3, 10.0
    model = WienerDegradationModel(
        threshold=w, diffusion_var=s2, prior={"mean": mu, "var": 1e-14}, level=0.9
    )
    train = pd.DataFrame({"unit": 0, "time": [0.0, 30.0], "hi": [0.0, 12.0]})
    test = pd.DataFrame(
        {"unit": [1, 1, 2, 2, 2], "time": [0, 4.0, 0, 1, 2.5], "hi": [0, 3, 1, 2, 8.5]}
    )
    p = model.fit(train).predict(test)
    for i, x_now in enumerate([3.0, 8.5]):
        d = w - x_now
        ig = stats.invgauss(s2 / (d * mu), scale=d**2 / s2)
        np.testing.assert_allclose(
            [p.lower[i], p.estimate[i], p.upper[i]],
            ig.ppf([0.05, 0.5, 0.95]),
            rtol=1e-6,
        )
        assert p.to_pandas()["p_fail"][i] == pytest.approx(1.0)


def test_drift_posterior_matches_a_grid_posterior_of_the_increments():
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.2, 3.0, 25))
    x = np.r_[0.0, np.cumsum(rng.normal(0.3 * np.diff(t), 0.5 * np.sqrt(np.diff(t))))]
    m0, v0, s2 = 0.2, 0.05**2, 0.25
    model = WienerDegradationModel(
        threshold=100.0, diffusion_var=s2, prior={"mean": m0, "var": v0}
    )
    table = pd.DataFrame({"unit": "a", "time": t, "hi": x})
    with pytest.warns(UserWarning, match="reaches threshold"):
        model.fit(table)
    mean, var = model.posterior(table)["a"]
    grid = np.linspace(-0.5, 1.0, 30001)
    dt, dx = np.diff(t), np.diff(x)
    logp = stats.norm.logpdf(grid, m0, np.sqrt(v0)) + sum(
        stats.norm.logpdf(step, grid * h, np.sqrt(s2 * h))
        for h, step in zip(dt, dx, strict=True)
    )
    w = np.exp(logp - logp.max())
    w /= w.sum()
    grid_mean = float(np.sum(w * grid))
    grid_var = float(np.sum(w * (grid - grid_mean) ** 2))
    assert mean == pytest.approx(grid_mean, abs=1e-7)
    assert var == pytest.approx(grid_var, rel=1e-4)


def test_update_equals_batch_prediction():
    rng = np.random.default_rng(4)
    train, _ = wiener_units(rng, 10, 0.02, 0.004, 0.02, threshold=1.0)
    model = WienerDegradationModel(threshold=1.0).fit(train)
    unit = train[train.unit == 3].assign(unit="new").iloc[:30]
    for part in np.array_split(np.arange(30), 4):
        model.update(unit.iloc[part])
    online, batch = model.predict(), model.predict(unit)
    np.testing.assert_allclose(online.estimate, batch.estimate)
    np.testing.assert_allclose(online.upper, batch.upper)
    with pytest.raises(DataError, match="not after the last time"):
        model.update(unit.iloc[:2])


def test_fit_recovers_the_prior_and_the_diffusion():
    rng = np.random.default_rng(5)
    n, mu0, sd0, sigma = 300, 0.02, 0.004, 0.03
    train, _ = wiener_units(rng, n, mu0, sd0, sigma, threshold=1.0)
    model = WienerDegradationModel(threshold=1.0).fit(train)
    assert model.drift_mean_ == pytest.approx(mu0, abs=4 * sd0 / np.sqrt(n) + 5e-4)
    assert np.sqrt(model.drift_var_) == pytest.approx(sd0, rel=0.25)
    dof = int((model.unit_params_["n"] - 2).sum())
    assert model.diffusion_var_ == pytest.approx(sigma**2, rel=4 * np.sqrt(2 / dof))
    # each unit's drift is its total increment over its elapsed time
    first = train.groupby("unit").first()
    last = train.groupby("unit").last()
    np.testing.assert_allclose(
        model.unit_params_["drift"],
        (last.hi - first.hi) / (last.time - first.time),
    )


def test_intervals_are_calibrated_on_wiener_paths():
    rng = np.random.default_rng(6)
    w, mu0, sd0, sigma, dt = 1.0, 0.02, 0.004, 0.03, 0.25
    train, _ = wiener_units(rng, 40, mu0, sd0, sigma, threshold=w, dt=dt)
    model = WienerDegradationModel(threshold=w).fit(train)
    full, _ = wiener_units(rng, 300, mu0, sd0, sigma, threshold=w, dt=dt)
    parts, truth = [], []
    for _, part in full.groupby("unit"):
        life = part.time.iloc[-1]
        cut = rng.uniform(0.1, 0.9) * life
        parts.append(part[part.time <= cut])
        truth.append(life - parts[-1].time.iloc[-1])
    p = model.predict(pd.concat(parts, ignore_index=True))
    truth = np.asarray(truth)
    coverage = np.mean((p.lower <= truth) & (truth <= p.upper))
    assert 0.80 <= coverage <= 0.98
    # the median is a median: about half the true RULs fall below it
    assert 0.4 <= np.mean(truth <= p.estimate) <= 0.6


def test_threshold_defaults_to_the_mean_failing_value():
    rng = np.random.default_rng(7)
    train, _ = wiener_units(rng, 12, 0.02, 0.004, 0.02, threshold=1.0)
    model = WienerDegradationModel().fit(train)
    assert model.threshold_ == pytest.approx(train.groupby("unit").hi.last().mean())


def test_decreasing_direction_mirrors_increasing():
    rng = np.random.default_rng(8)
    train, _ = wiener_units(rng, 12, 0.02, 0.004, 0.02, threshold=1.0)
    up = WienerDegradationModel(threshold=1.0).fit(train)
    down = WienerDegradationModel(threshold=-1.0, direction="decreasing").fit(
        train.assign(hi=-train.hi)
    )
    test = train[train.unit < 3].groupby("unit").head(20)
    np.testing.assert_allclose(
        up.predict(test).estimate, down.predict(test.assign(hi=-test.hi)).estimate
    )


# ------------------------------------------------------------------ edge cases
def test_one_sample_unit_is_predicted_from_the_prior():
    mu, s2, w = 0.5, 0.2, 6.0
    model = WienerDegradationModel(
        threshold=w, diffusion_var=s2, prior={"mean": mu, "var": 1e-14}
    )
    model.fit(pd.DataFrame({"unit": 0, "time": [0.0, 5.0, 9.0], "hi": [0, 3, 7.0]}))
    p = model.predict(pd.DataFrame({"unit": ["new"], "time": [2.0], "hi": [1.0]}))
    ig = stats.invgauss(s2 / (5.0 * mu), scale=5.0**2 / s2)
    assert p.estimate[0] == pytest.approx(ig.median(), rel=1e-6)
    assert p.to_pandas()["drift"][0] == pytest.approx(mu)


def test_unit_past_the_threshold_has_rul_zero():
    rng = np.random.default_rng(9)
    train, _ = wiener_units(rng, 10, 0.02, 0.004, 0.02, threshold=1.0)
    model = WienerDegradationModel(threshold=1.0).fit(train)
    p = model.predict(pd.DataFrame({"unit": 1, "time": [0.0, 5.0], "hi": [0.0, 1.2]}))
    assert p.estimate[0] == 0 and p.lower[0] == 0 and p.upper[0] == 0


def test_negative_drift_gives_inf_and_p_fail_below_one():
    model = WienerDegradationModel(
        threshold=1.0,
        diffusion_var=0.01,
        prior={"mean": -0.05, "var": 1e-6},
        horizon=1e7,
    )
    train = pd.DataFrame({"unit": 0, "time": [0.0, 1.0, 2.0], "hi": [0.0, 1.0, 1.5]})
    with pytest.warns(UserWarning, match="not positive"):
        model.fit(train)
    p = model.predict(pd.DataFrame({"unit": 1, "time": [0.0], "hi": [0.0]}))
    # P(ever crossing) = E[exp(2 mu d / s2)] for mu < 0: about exp(-10)
    assert p.to_pandas()["p_fail"][0] == pytest.approx(
        np.exp(-10 + 2 * 1e-6 / 1e-4), rel=1e-3
    )
    assert np.isinf(p.estimate[0]) and np.isinf(p.upper[0])


def test_constant_indicator_and_too_little_data_raise():
    const = pd.DataFrame({"unit": np.repeat([1, 2], 3), "time": [0, 1, 2] * 2, "hi": 1.0})
    with pytest.raises(DataError, match="constant"):
        WienerDegradationModel(threshold=2.0).fit(const)
    singles = pd.DataFrame({"unit": [1, 2, 3], "time": [0.0, 0, 0], "hi": [0.0, 1, 2]})
    with pytest.raises(DataError, match="diffusion variance"):
        WienerDegradationModel(threshold=2.0).fit(singles)
    one = pd.DataFrame({"unit": 1, "time": [0.0, 1, 2], "hi": [0.0, 1.5, 2]})
    with pytest.raises(DataError, match="needs at least 2"):
        WienerDegradationModel(threshold=2.0).fit(one)
    line = pd.DataFrame(
        {"unit": np.repeat([1, 2], 3), "time": [0, 1, 2] * 2, "hi": [0, 1, 2, 0, 2, 4.0]}
    )
    with pytest.raises(DataError, match="no diffusion"):
        WienerDegradationModel(threshold=2.0).fit(line)


def test_censored_units_need_a_threshold_and_unreached_threshold_warns():
    rng = np.random.default_rng(10)
    train, _ = wiener_units(rng, 6, 0.02, 0.004, 0.02, threshold=1.0)
    censored = train.assign(failed=train.unit != 2)
    with pytest.raises(DataError, match="censored"):
        WienerDegradationModel().fit(censored)
    WienerDegradationModel(threshold=1.0).fit(censored)  # fine with a threshold
    with pytest.warns(UserWarning, match="reaches threshold"):
        WienerDegradationModel(threshold=50.0).fit(train)


def test_sklearn_contract_and_bad_arguments():
    model = WienerDegradationModel(threshold=1.0, level=0.8)
    assert clone(model).get_params()["level"] == 0.8
    with pytest.raises(NotFittedError):
        model.predict(pd.DataFrame({"unit": [1], "time": [0.0], "hi": [0.0]}))
    train = pd.DataFrame(
        {
            "unit": np.repeat([1, 2], 3),
            "time": [0, 1, 2] * 2,
            "hi": [0, 1, 1.5, 0, 0.5, 1.2],
        }
    )
    with pytest.raises(ValueError, match="direction"):
        WienerDegradationModel(direction="up").fit(train)
    with pytest.raises(ValueError, match="prior"):
        WienerDegradationModel(threshold=1.0, prior={"mean": 1.0}).fit(train)
    with pytest.raises(ValueError, match="diffusion_var"):
        WienerDegradationModel(threshold=1.0, diffusion_var=-1.0).fit(train)
