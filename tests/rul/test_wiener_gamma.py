"""Gamma-process degradation model and the indicator transform of the process models."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy import integrate, stats

from pdmkit.errors import DataError
from pdmkit.rul import GammaProcessDegradationModel, WienerDegradationModel


def gamma_units(rng, n, alpha, a, b, *, threshold, steps=400):
    """Unit paths with Gamma(alpha, rate beta) steps per unit time, beta ~ Gamma(a, b)."""
    rows = []
    for u in range(n):
        beta = rng.gamma(a, 1.0 / b)
        x = np.r_[0.0, np.cumsum(rng.gamma(alpha, 1.0 / beta, steps))]
        end = np.flatnonzero(x >= threshold)[0] + 1
        rows.append(
            pd.DataFrame({"unit": u, "time": np.arange(end, dtype=float), "hi": x[:end]})
        )
    return pd.concat(rows, ignore_index=True)


def test_known_rate_rul_is_the_gamma_survival_function():
    alpha, beta, w = 3.0, 40.0, 1.0
    # a prior concentrated on beta: shape a, rate a / beta with a huge
    model = GammaProcessDegradationModel(
        threshold=w, shape=alpha, prior={"shape": 1e9, "rate": 1e9 / beta}
    )
    train = pd.DataFrame({"unit": 0, "time": [0.0, 5.0, 20.0], "hi": [0, 0.3, 1.2]})
    p = model.fit(train).predict(
        pd.DataFrame({"unit": 1, "time": [0.0, 4.0], "hi": [0.0, 0.4]})
    )
    d = w - 0.4
    for q, value in zip(
        (0.05, 0.5, 0.95), (p.lower[0], p.estimate[0], p.upper[0]), strict=True
    ):
        # P(RUL <= s) = P(Gamma(alpha s, beta) >= d)
        assert stats.gamma.sf(d, alpha * value, scale=1 / beta) == pytest.approx(
            q, abs=1e-5
        )


def test_mixed_rul_cdf_matches_numerical_mixture_over_the_rate():
    alpha, a, b, w = 2.0, 6.0, 0.2, 2.0
    model = GammaProcessDegradationModel(
        threshold=w, shape=alpha, prior={"shape": a, "rate": b}
    )
    train = pd.DataFrame({"unit": 0, "time": [0.0, 5.0, 20.0], "hi": [0, 0.3, 2.5]})
    model.fit(train)
    x_now, elapsed, total = 0.5, 3.0, 0.5
    post = model._posterior(total, elapsed)
    assert post == pytest.approx((a + alpha * elapsed, b + total))
    for s in (0.5, 2.0, 8.0):
        ref, _ = integrate.quad(
            lambda beta, s=s: (
                stats.gamma.sf(w - x_now, alpha * s, scale=1 / beta)
                * stats.gamma.pdf(beta, post[0], scale=1 / post[1])
            ),
            0,
            np.inf,
            epsabs=1e-12,
        )
        got = model._rul_cdf(np.array([s]), np.array([w - x_now]), post)[0]
        assert got == pytest.approx(ref, abs=1e-7)


def test_rate_posterior_matches_a_grid_posterior():
    rng = np.random.default_rng(1)
    alpha, a, b = 2.5, 8.0, 0.4
    t = np.cumsum(rng.uniform(0.5, 2.0, 20))
    x = np.r_[0.0, np.cumsum(rng.gamma(alpha * np.diff(t), 1 / 25.0))]
    model = GammaProcessDegradationModel(
        threshold=float(x[-1]), shape=alpha, prior={"shape": a, "rate": b}
    )
    table = pd.DataFrame({"unit": "u", "time": t, "hi": x})
    shape_post, rate_post = model.fit(table).posterior(table)["u"]
    grid = np.linspace(1e-3, 120.0, 200001)
    logp = stats.gamma.logpdf(grid, a, scale=1 / b) + sum(
        stats.gamma.logpdf(dx, alpha * h, scale=1 / grid)
        for h, dx in zip(np.diff(t), np.diff(x), strict=True)
    )
    p = np.exp(logp - logp.max())
    p /= p.sum()
    mean = float(np.sum(p * grid))
    assert shape_post / rate_post == pytest.approx(mean, rel=1e-5)
    assert shape_post / rate_post**2 == pytest.approx(
        float(np.sum(p * (grid - mean) ** 2)), rel=1e-3
    )


def test_gamma_fit_recovers_parameters_and_intervals_are_calibrated():
    rng = np.random.default_rng(2)
    alpha, a, b, w = 4.0, 30.0, 0.15, 1.0  # mean growth alpha b / (a - 1) ~ 0.02
    train = gamma_units(rng, 150, alpha, a, b, threshold=w)
    model = GammaProcessDegradationModel(threshold=w).fit(train)
    assert model.shape_ == pytest.approx(alpha, rel=0.1)
    # the prior mean of beta, a / b, within 10 %
    assert model.rate_shape_ / model.rate_rate_ == pytest.approx(a / b, rel=0.1)
    full = gamma_units(rng, 300, alpha, a, b, threshold=w)
    parts, truth = [], []
    for _, part in full.groupby("unit"):
        life = part.time.iloc[-1]
        cut = int(rng.uniform(0.1, 0.9) * life)
        parts.append(part[part.time <= cut])
        truth.append(life - cut)
    p = model.predict(pd.concat(parts, ignore_index=True))
    truth = np.asarray(truth)
    # the failing sample is the first at or past the threshold: the continuous
    # passage time plus less than one step
    coverage = np.mean((p.lower <= truth) & (truth <= p.upper + 1))
    assert 0.80 <= coverage <= 0.98


def test_gamma_edge_cases():
    flat = pd.DataFrame(
        {"unit": np.repeat([1, 2], 3), "time": [0, 1, 2] * 2, "hi": [0, 1, 2, 0, 2, 4.0]}
    )
    with pytest.raises(DataError, match="no randomness"):
        GammaProcessDegradationModel(threshold=2.0).fit(flat)
    falling = flat.assign(hi=-flat.hi)
    with pytest.raises(DataError, match="net increase"):
        GammaProcessDegradationModel(threshold=-1.0).fit(falling)
    with pytest.raises(ValueError, match="prior"):
        GammaProcessDegradationModel(threshold=2.0, shape=1.0, prior={"mean": 1}).fit(flat)
    # a unit that has not grown (yet) keeps the prior's rate
    model = GammaProcessDegradationModel(
        threshold=4.0, shape=1.0, prior={"shape": 3.0, "rate": 2.0}
    ).fit(flat)
    post = model.posterior(pd.DataFrame({"unit": 9, "time": [0.0, 1.0], "hi": [1.0, 0.5]}))
    assert post[9] == pytest.approx((4.0, 2.0))


# ------------------------------------------------------------------ transform
@pytest.mark.parametrize(
    "model_class", [WienerDegradationModel, GammaProcessDegradationModel]
)
def test_auto_transform_undoes_a_level_distortion(model_class):
    """A Wiener path seen through a concave map of the level: "auto" finds a convex
    transform and predicts as well as the model on the undistorted path."""
    rng = np.random.default_rng(3)
    rows = []
    for u in range(40):
        mu = rng.normal(0.02, 0.003)
        x = np.r_[0.0, np.cumsum(rng.gamma(4.0, mu / 4.0, 200))]
        end = np.flatnonzero(x >= 1.0)[0] + 1
        rows.append(
            pd.DataFrame({"unit": u, "time": np.arange(end, dtype=float), "x": x[:end]})
        )
    table = pd.concat(rows, ignore_index=True)
    table["hi"] = np.log1p(table.x)  # concave: bends with the level
    train, test = table[table.unit < 20], table[table.unit >= 20]
    cuts = test[test.time <= test.groupby("unit").time.transform("max") // 2]
    life = test.groupby("unit").time.max()
    truth = life.to_numpy() - cuts.groupby("unit").time.max().to_numpy()
    plain = model_class(threshold=np.log(2.0)).fit(train).predict(cuts)
    auto = model_class(threshold=np.log(2.0), transform="auto").fit(train)
    ref = model_class(threshold=1.0, indicator="x").fit(train).predict(cuts)
    assert auto.transform_ > 0.3
    err_auto = np.mean(np.abs(auto.predict(cuts).estimate - truth))
    err_plain = np.mean(np.abs(plain.estimate - truth))
    err_ref = np.mean(np.abs(ref.estimate - truth))
    assert err_auto < err_plain and err_auto < 1.5 * err_ref
    # the threshold stays in the indicator's own units
    assert auto.threshold_ == pytest.approx(np.log(2.0))
    with pytest.raises(ValueError, match="transform"):
        model_class(transform="box-cox").fit(train)


@pytest.mark.parametrize("name", ["wiener", "gamma-process"])
def test_workflow_runs_the_process_models_on_tables(name, tmp_path):
    from pdmkit.experiments._rul import make_rul_model, run_rul

    _, est = make_rul_model(name, ["s1"])
    assert est.transform == "auto"
    rng = np.random.default_rng(4)

    def units(n, cut):
        rows = []
        for u in range(n):
            mu = rng.normal(0.02, 0.003)
            x = np.r_[0.0, np.cumsum(rng.gamma(4.0, mu / 4.0, 300))]
            life = int(np.flatnonzero(x >= 1.0)[0])
            stop = life - int(rng.integers(5, 20)) if cut else life
            rows.append(
                pd.DataFrame(
                    {
                        "unit": u,
                        "cycle": np.arange(stop + 1),
                        "s1": x[: stop + 1],
                        "rul_true_final": life - stop,
                    }
                )
            )
        return pd.concat(rows, ignore_index=True)

    out = run_rul((units(20, False), units(8, True)), name, tmp_path, n_trajectories=1)
    assert out["n_units"] == 8 and out["rmse"] < 8
