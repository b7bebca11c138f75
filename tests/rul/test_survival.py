"""Reliability (Weibull and friends) and covariate (proportional hazards) models."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import scipy.integrate
import scipy.optimize
import scipy.stats

from pdmkit.errors import ConvergenceWarning, DataError
from pdmkit.rul import CovariateSurvivalModel, ReliabilitySurvivalModel


def _censored_weibull(rng, n=300, shape=2.5, scale=120.0):
    life = scale * rng.weibull(shape, n)
    stop = rng.uniform(30, 250, n)  # random right-censoring
    return np.minimum(life, stop), life <= stop


@pytest.mark.parametrize(
    ("name", "dist"),
    [
        ("weibull", scipy.stats.weibull_min),
        ("lognormal", scipy.stats.lognorm),
        ("loglogistic", scipy.stats.fisk),
    ],
)
def test_censored_mle_matches_scipy(rng, name, dist):
    t, failed = _censored_weibull(rng)
    model = ReliabilitySurvivalModel(name).fit_lifetimes(t, failed)
    data = scipy.stats.CensoredData(uncensored=t[failed], right=t[~failed])
    ref = dist.fit(data, floc=0)
    ours = list(model.params_.values())
    assert ours[0] == pytest.approx(ref[0], rel=2e-3)
    assert ours[1] == pytest.approx(ref[2], rel=2e-3)
    assert model.n_censored_ == int((~failed).sum())


def test_exponential_mle_is_total_time_over_failures(rng):
    t, failed = _censored_weibull(rng, shape=1.0)
    model = ReliabilitySurvivalModel("exponential").fit_lifetimes(t, failed)
    assert model.params_["scale"] == pytest.approx(t.sum() / failed.sum())


def test_conditional_median_matches_the_weibull_closed_form(rng):
    t, failed = _censored_weibull(rng)
    model = ReliabilitySurvivalModel().fit_lifetimes(t, failed)
    k, lam = model.params_["shape"], model.params_["scale"]
    ages = np.array([0.0, 50.0, 150.0])
    now = pd.DataFrame({"unit": [1, 2, 3], "time": ages})
    p = model.predict(now)
    assert np.allclose(p.estimate, lam * ((ages / lam) ** k + np.log(2)) ** (1 / k) - ages)
    # 90 % interval: conditional 5 % and 95 % quantiles
    low = lam * ((ages / lam) ** k - np.log(0.95)) ** (1 / k) - ages
    assert np.allclose(p.lower, low)


def test_table_lifetimes_and_failed_column():
    t = pd.DataFrame(
        {
            "unit": [1, 1, 2, 2, 3],
            "time": [1, 80, 1, 120, 70],
            "failed": [True, True, True, True, False],
        }
    )
    model = ReliabilitySurvivalModel("exponential").fit(t)
    assert model.params_["scale"] == pytest.approx((80 + 120 + 70) / 2)
    assert model.n_failed_ == 2 and model.n_censored_ == 1


def test_all_censored_is_an_error():
    with pytest.raises(DataError, match="censored"):
        ReliabilitySurvivalModel().fit_lifetimes([10.0, 20.0], failed=[False, False])
    with pytest.raises(DataError, match="positive"):
        ReliabilitySurvivalModel().fit_lifetimes([0.0, 20.0])


# ------------------------------------------------------------------ covariate model
def _ph_fleet(rng, n, *, shape=2.0, scale=100.0, gamma=0.8, step=5.0, censor=None):
    """Weibull PH with a covariate that drifts as a random walk, sampled every ``step``."""
    rows = []
    for u in range(n):
        z, t, cum = rng.normal(), 0.0, 0.0
        target = rng.exponential()
        while True:
            z += rng.normal(0, 0.3)
            h_end = ((t + step) / scale) ** shape
            inc = np.exp(gamma * z) * (h_end - (t / scale) ** shape)
            if cum + inc >= target:  # fails inside this interval
                need = (target - cum) / np.exp(gamma * z) + (t / scale) ** shape
                t_fail = scale * need ** (1 / shape)
                rows.append({"unit": u, "time": t_fail, "z": z, "failed": True})
                break
            cum += inc
            t += step
            if censor is not None and t >= censor[u]:
                rows.append({"unit": u, "time": t, "z": z, "failed": False})
                break
            rows.append({"unit": u, "time": t, "z": z, "failed": True})
    return pd.DataFrame(rows)


def test_covariate_gradient_matches_finite_differences(rng):
    table = _ph_fleet(rng, 20)
    model = CovariateSurvivalModel("z").fit(table)
    units = model._split(table)
    args = model._rows(units, model.mean_.to_numpy(), model.std_.to_numpy())
    t_prev, t_end, z, _, event = args

    def f(theta):
        return model._nll(theta, t_prev, t_end, z, event)[0]

    def g(theta):
        return model._nll(theta, t_prev, t_end, z, event)[1]

    theta = np.array([0.5, 4.0, 0.3])
    assert scipy.optimize.check_grad(f, g, theta) < 1e-4 * np.linalg.norm(g(theta))


def test_covariate_likelihood_matches_numerical_integration(rng):
    model = CovariateSurvivalModel("z").fit(_ph_fleet(rng, 30))
    table = pd.DataFrame(
        {
            "unit": [1, 1, 1, 2, 2],
            "time": [2.0, 5.0, 7.5, 3.0, 6.0],
            "z": [0.1, 0.7, 1.5, -0.4, 0.2],
            "failed": [True, True, True, False, False],
        }
    )
    units = model._split(table)
    mean, std = model.mean_.to_numpy(), model.std_.to_numpy()
    t_prev, t_end, z, _, event = model._rows(units, mean, std)
    k, lam, g = 1.7, 9.0, 0.6  # any parameters: compare the likelihood itself
    nll, _ = model._nll(np.array([np.log(k), np.log(lam), g]), t_prev, t_end, z, event)

    def hazard(s, zval):
        return k / lam * (s / lam) ** (k - 1) * np.exp(g * (zval - mean[0]) / std[0])

    loglik = 0.0
    for _, part in table.groupby("unit"):
        edges = np.r_[0.0, part["time"].to_numpy()]
        for a, b, zval in zip(edges[:-1], edges[1:], part["z"], strict=True):
            loglik -= scipy.integrate.quad(hazard, a, b, args=(zval,))[0]
        if part["failed"].iloc[-1]:
            loglik += np.log(hazard(edges[-1], part["z"].iloc[-1]))
    assert -nll == pytest.approx(loglik, rel=1e-8)


def test_covariate_model_recovers_the_generating_parameters(rng):
    censor = rng.uniform(60, 200, 400)
    table = _ph_fleet(rng, 400, censor=censor)
    model = CovariateSurvivalModel("z").fit(table)
    gamma = model.coef_["z"] / model.std_["z"]  # per raw unit of z
    scale_at_zero = model.scale_ * np.exp(gamma * model.mean_["z"] / model.shape_)
    assert model.shape_ == pytest.approx(2.0, rel=0.12)
    assert scale_at_zero == pytest.approx(100.0, rel=0.12)
    assert gamma == pytest.approx(0.8, rel=0.12)
    assert 0 < model.n_censored_ < 400


def test_covariate_rul_quantile_solves_the_conditional_survival(rng):
    model = CovariateSurvivalModel("z").fit(_ph_fleet(rng, 60))
    age, zval, q = 40.0, 1.2, 0.5
    r = float(model.rul_quantiles(age, [zval], q))
    eta = (zval - model.mean_["z"]) / model.std_["z"] * model.coef_["z"]

    def cond_surv(s):
        h0 = ((age + s) / model.scale_) ** model.shape_ - (
            age / model.scale_
        ) ** model.shape_
        return np.exp(-np.exp(eta) * h0) - (1 - q)

    assert r == pytest.approx(scipy.optimize.brentq(cond_surv, 0.0, 1e4), rel=1e-8)


def test_higher_covariate_means_shorter_rul(rng):
    model = CovariateSurvivalModel("z").fit(_ph_fleet(rng, 80))
    now = pd.DataFrame({"unit": [1, 2], "time": [30.0, 30.0], "z": [-1.0, 2.0]})
    p = model.predict(now)
    assert p.estimate[1] < p.estimate[0]


def test_constant_covariate_is_rejected(rng):
    table = _ph_fleet(rng, 10).assign(z=1.0)
    with pytest.raises(DataError, match="constant"):
        CovariateSurvivalModel("z").fit(table)


def test_separating_covariate_warns_and_penalizer_tames_it():
    rows = []
    for u, life in enumerate([40.0, 60.0, 80.0, 100.0]):
        t = np.arange(10.0, life + 1, 10.0)
        rows.append(pd.DataFrame({"unit": u, "time": t, "z": t / life}))  # 1 at failure
    table = pd.concat(rows, ignore_index=True)
    with pytest.warns(ConvergenceWarning, match="bound"):
        CovariateSurvivalModel("z").fit(table)
    model = CovariateSurvivalModel("z", penalizer=1.0).fit(table)
    assert abs(model.coef_["z"]) < 30 and np.isfinite(model.scale_)
