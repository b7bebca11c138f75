"""Linear and exponential degradation models with Bayesian updating."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from pdmkit.errors import DataError, NotFittedError
from pdmkit.rul import ExponentialDegradationModel, LinearDegradationModel

NOISE = 0.05


def _linear_fleet(rng, n, *, cut=None, noise=NOISE):
    """Units h = a + b t + noise, failing when a + b t reaches 1 (T = (1 - a) / b)."""
    a = rng.normal(0.0, 0.05, n)
    b = rng.normal(0.01, 0.0015, n)
    life = (1.0 - a) / b
    rows, rul = [], []
    for u in range(n):
        end = np.floor(life[u]) if cut is None else np.floor(cut[u] * life[u])
        t = np.arange(0.0, end + 1)
        rows.append(
            pd.DataFrame(
                {"unit": u, "time": t, "hi": a[u] + b[u] * t + rng.normal(0, noise, t.size)}
            )
        )
        rul.append(life[u] - t[-1])
    return pd.concat(rows, ignore_index=True), np.array(rul)


def _exp_fleet(rng, n, *, cut=None, noise=0.1):
    """Units h = exp(a + b t + noise), failing when exp(a + b t) reaches 1."""
    a = rng.normal(np.log(0.05), 0.2, n)
    b = rng.normal(0.03, 0.003, n)
    life = -a / b
    rows, rul = [], []
    for u in range(n):
        end = np.floor(life[u]) if cut is None else np.floor(cut[u] * life[u])
        t = np.arange(0.0, end + 1)
        h = np.exp(a[u] + b[u] * t + rng.normal(0, noise, t.size))
        rows.append(pd.DataFrame({"unit": u, "time": t, "hi": h}))
        rul.append(life[u] - t[-1])
    return pd.concat(rows, ignore_index=True), np.array(rul)


def test_linear_intervals_are_calibrated(rng):
    train, _ = _linear_fleet(rng, 40)
    cut = rng.uniform(0.1, 0.9, 300)
    test, rul = _linear_fleet(rng, 300, cut=cut)
    model = LinearDegradationModel(threshold=1.0, level=0.9).fit(train)
    assert model.noise_var_ == pytest.approx(NOISE**2, rel=0.1)
    p = model.predict(test)
    coverage = np.mean((rul >= p.lower) & (rul <= p.upper))
    assert 0.80 <= coverage <= 0.98, coverage
    # and the estimates are useful: median error well inside the interval widths
    assert np.median(np.abs(p.estimate - rul)) < 0.3 * np.median(p.upper - p.lower)


def test_exponential_intervals_are_calibrated(rng):
    train, _ = _exp_fleet(rng, 40)
    cut = rng.uniform(0.1, 0.9, 300)
    test, rul = _exp_fleet(rng, 300, cut=cut)
    model = ExponentialDegradationModel(threshold=1.0, offset=0.0).fit(train)
    assert model.prior_mean_ == pytest.approx([np.log(0.05), 0.03], rel=0.05)
    p = model.predict(test)
    coverage = np.mean((rul >= p.lower) & (rul <= p.upper))
    assert 0.80 <= coverage <= 0.98, coverage


def test_exponential_offset_is_found_by_profile_likelihood(rng):
    train, _ = _exp_fleet(rng, 30, noise=0.05)
    train["hi"] += 3.0  # h = 3 + exp(...)
    model = ExponentialDegradationModel(threshold=4.0).fit(train)
    assert model.offset_ == pytest.approx(3.0, abs=0.02)
    assert model.prior_mean_[1] == pytest.approx(0.03, rel=0.05)


def test_posterior_matches_an_independent_least_squares_solution(rng):
    train, _ = _linear_fleet(rng, 20)
    model = LinearDegradationModel(threshold=1.0).fit(train)
    test, _ = _linear_fleet(rng, 1, cut=[0.5])
    mean, cov = model.posterior(test)[0]
    # MAP of a Gaussian prior + Gaussian likelihood = stacked weighted least squares
    t, y = test["time"].to_numpy(), test["hi"].to_numpy()
    X = np.column_stack([np.ones_like(t), t]) / np.sqrt(model.noise_var_)
    L = np.linalg.cholesky(np.linalg.inv(model.prior_cov_))  # prior precision = L L^T
    A = np.vstack([X, L.T])
    rhs = np.concatenate([y / np.sqrt(model.noise_var_), L.T @ model.prior_mean_])
    ref, *_ = np.linalg.lstsq(A, rhs, rcond=None)
    assert np.allclose(mean, ref, rtol=1e-8)
    assert np.allclose(cov, np.linalg.inv(A.T @ A), rtol=1e-8)


def test_sequential_updates_equal_the_batch_posterior(rng):
    train, _ = _linear_fleet(rng, 20)
    model = LinearDegradationModel(threshold=1.0).fit(train)
    test, _ = _linear_fleet(rng, 1, cut=[0.7])
    for rows in np.array_split(np.arange(len(test)), 4):
        model.update(test.iloc[rows])
    mean, cov = model.posterior(test)[0]
    p_state, v_state, last = model.states_[0]
    assert last == test["time"].iloc[-1]
    assert np.allclose(np.linalg.solve(p_state, v_state), mean)
    assert np.allclose(np.linalg.inv(p_state), cov)
    a, b = model.predict(), model.predict(test)
    assert np.allclose(a.estimate, b.estimate) and np.allclose(a.upper, b.upper)


def test_update_rejects_old_rows(rng):
    train, _ = _linear_fleet(rng, 10)
    model = LinearDegradationModel(threshold=1.0).fit(train)
    new = pd.DataFrame({"unit": "x", "time": [0.0, 1.0], "hi": [0.0, 0.01]})
    model.update(new)
    with pytest.raises(DataError, match="only new rows"):
        model.update(new)


def test_tight_prior_gives_the_deterministic_crossing_time():
    prior = {"mean": [0.2, 0.02], "cov": [[1e-12, 0.0], [0.0, 1e-16]]}
    model = LinearDegradationModel(threshold=1.0, prior=prior, noise_var=0.01)
    t = pd.DataFrame({"unit": 1, "time": [0.0, 5.0, 10.0], "hi": [0.2, 0.3, 0.4]})
    with pytest.warns(UserWarning, match="reaches threshold"):
        model.fit(t)
    p = model.predict(t)
    # 0.2 + 0.02 t = 1 at t = 40: 30 after t = 10
    assert p.estimate[0] == pytest.approx(30.0, abs=1e-3)
    assert p.upper[0] - p.lower[0] < 1e-2


def test_decreasing_direction_mirrors_increasing(rng):
    train, _ = _linear_fleet(rng, 20)
    test, _ = _linear_fleet(rng, 5, cut=np.full(5, 0.5))
    up = LinearDegradationModel(threshold=1.0).fit(train).predict(test)
    mirrored_train = train.assign(hi=-train["hi"])
    mirrored_test = test.assign(hi=-test["hi"])
    down = LinearDegradationModel(threshold=-1.0, direction="decreasing").fit(
        mirrored_train
    )
    assert np.allclose(down.predict(mirrored_test).estimate, up.estimate)


def test_already_past_threshold_gives_zero_rul(rng):
    train, _ = _linear_fleet(rng, 20)
    model = LinearDegradationModel(threshold=1.0).fit(train)
    t = np.arange(0.0, 120.0)
    late = pd.DataFrame({"unit": 1, "time": t, "hi": 0.012 * t})  # 1.43 at the end
    p = model.predict(late)
    assert p.estimate[0] == 0.0 and p.lower[0] == 0.0


def test_threshold_never_crossed_gives_inf_and_p_fail(rng):
    train, _ = _linear_fleet(rng, 20)
    model = LinearDegradationModel(threshold=1.0).fit(train)
    t = np.arange(0.0, 200.0)
    healing = pd.DataFrame({"unit": 1, "time": t, "hi": 0.5 - 0.002 * t})
    p = model.predict(healing)
    assert np.isinf(p.estimate[0]) and np.isinf(p.upper[0])
    assert p.extra["p_fail"][0] < 0.5


def test_threshold_no_training_unit_reaches_warns(rng):
    train, _ = _linear_fleet(rng, 10)
    with pytest.warns(UserWarning, match="reaches threshold"):
        LinearDegradationModel(threshold=50.0).fit(train)


def test_default_threshold_is_the_fitted_paths_at_failure_and_needs_failures(rng):
    train, _ = _linear_fleet(rng, 10)
    model = LinearDegradationModel().fit(train)
    # the mean of each unit's least-squares line at its last time
    ends = [
        np.polyval(np.polyfit(g["time"], g["hi"], 1), g["time"].iloc[-1])
        for _, g in train.groupby("unit")
    ]
    assert model.threshold_ == pytest.approx(np.mean(ends))
    assert model.threshold_ == pytest.approx(1.0, abs=0.02)  # the true threshold
    train["failed"] = train["unit"] != 3
    with pytest.raises(DataError, match="censored"):
        LinearDegradationModel().fit(train)
    # with a threshold, censored training units are fine
    LinearDegradationModel(threshold=1.0).fit(train)


def test_constant_indicator_is_rejected():
    t = pd.DataFrame(
        {"unit": np.repeat([1, 2], 5), "time": np.tile(np.arange(5), 2), "hi": 0.3}
    )
    with pytest.raises(DataError, match="constant"):
        LinearDegradationModel(threshold=1.0).fit(t)


def test_prior_needs_two_units_unless_given():
    t = pd.DataFrame({"unit": 1, "time": np.arange(5.0), "hi": [0, 0.1, 0.25, 0.3, 0.4]})
    with pytest.raises(DataError, match="at least 2"):
        LinearDegradationModel(threshold=0.4).fit(t)
    prior = {"mean": [0.0, 0.1], "cov": [[0.01, 0.0], [0.0, 0.001]]}
    assert LinearDegradationModel(threshold=0.4, prior=prior).fit(t).n_units_ == 1


def test_bad_parameters_and_unfitted_use():
    t = pd.DataFrame({"unit": 1, "time": [0.0, 1.0], "hi": [0.0, 0.1]})
    with pytest.raises(NotFittedError):
        LinearDegradationModel().predict(t)
    with pytest.raises(ValueError, match="direction"):
        LinearDegradationModel(direction="up").fit(t)
    with pytest.raises(ValueError, match="level"):
        LinearDegradationModel(level=90).fit(t)
    with pytest.raises(ValueError, match="prior"):
        LinearDegradationModel(prior={"mean": [0, 1]}, threshold=0.1).fit(t)


def test_trajectory_predictions_shrink_towards_failure(rng):
    train, _ = _linear_fleet(rng, 20, noise=0.02)
    test, _ = _linear_fleet(rng, 1, cut=[0.9], noise=0.02)
    path = (
        LinearDegradationModel(threshold=1.0).fit(train).predict_trajectory(test, every=10)
    )
    last = test["time"].iloc[-1]
    assert path.time.tolist() == [*np.arange(0.0, last, 10.0), last]
    assert np.all(np.diff(path.estimate[2:]) < 0)
