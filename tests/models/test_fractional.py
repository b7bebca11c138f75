"""Fractional-order models: GL simulation, Oustaloup, fitting, diagnosis.

The models, the simplex fit and the diagnosis follow the fractional-calculus paper."""

import numpy as np
import pytest
import scipy.signal as ss
from scipy.special import erfcx
from sklearn.exceptions import NotFittedError

from pdmkit.errors import DataError, ModelError
from pdmkit.models.frequency import (
    FractionalConditionClassifier,
    FractionalTF,
    fit_fractional_frf,
    fit_fractional_simplex,
    fit_fractional_tf,
    gl_simulate,
    gl_weights,
    model_distance,
    oustaloup,
)


def test_gl_weights_are_signed_binomials():
    from scipy.special import binom

    k = np.arange(12)
    assert np.allclose(gl_weights(0.7, 12), (-1.0) ** k * binom(0.7, k))


def test_gl_alpha_one_is_first_order_ode():
    dt = 1e-3
    t = np.arange(0, 4, dt)
    u = np.sin(3 * t)
    y = gl_simulate(u, dt, [0.5, 2.0], [1.0, 0.0])  # 0.5 y' + 2 y = u
    _, y_ref, _ = ss.lsim(([1.0], [0.5, 2.0]), u, t)
    assert np.max(np.abs(y - y_ref)) < 2e-3 * np.max(np.abs(y_ref)) + 1e-3


def test_gl_step_response_matches_mittag_leffler_half_order():
    """Step response of 1/(s^0.5 + 1) is 1 - E_{1/2}(-t^{1/2}) = 1 - erfcx(sqrt(t))."""
    dt = 1e-3
    t = np.arange(0, 5, dt)
    y = FractionalTF((1.0, 1.0), (0.5, 0.0)).simulate(np.ones_like(t), dt)
    ref = 1 - erfcx(np.sqrt(t))
    late = t > 0.1
    assert np.max(np.abs(y[late] - ref[late])) < 5e-3
    # the short-memory principle changes little with a long enough memory
    y_mem = FractionalTF((1.0, 1.0), (0.5, 0.0)).simulate(np.ones_like(t), dt, memory=3000)
    assert np.max(np.abs(y_mem[late] - ref[late])) < 0.03


def test_oustaloup_matches_fractional_operator_in_band():
    alpha, wb, wh = 0.6, 1e-3, 1e3
    z, p, k = oustaloup(alpha, wb, wh, order=6)
    w = np.logspace(-1, 1, 50)  # two decades inside the band
    _, H = ss.freqs_zpk(z, p, k, worN=w)
    ref = (1j * w) ** alpha
    assert np.max(np.abs(20 * np.log10(np.abs(H / ref)))) < 0.05  # dB
    assert np.max(np.abs(np.degrees(np.angle(H / ref)))) < 1.0
    with pytest.raises(ModelError, match="wb < wh"):
        oustaloup(0.5, 10.0, 1.0)


def test_frequency_fit_recovers_orders_from_noisy_frf():
    true = FractionalTF.seed004(a=0.02, alpha=1.7, b=0.3, beta=0.6, c=1.0)
    f = np.logspace(-2, 2, 120)
    H = true.frequency_response(2 * np.pi * f)
    rng = np.random.default_rng(0)
    Hn = H * (1 + 0.03 * (rng.normal(size=f.size) + 1j * rng.normal(size=f.size)))
    fit = fit_fractional_frf(f, Hn)
    assert abs(fit.alpha - 1.7) < 0.05
    assert abs(fit.beta - 0.6) < 0.05
    assert fit.c == pytest.approx(1.0, rel=0.05)
    assert set(fit.to_pandas().index) >= {"a", "alpha", "b", "beta", "c", "error"}


@pytest.mark.parametrize("domain", ["frequency", "time"])
def test_io_fit_recovers_orders_from_noisy_records(domain):
    g = FractionalTF.seed004(a=0.05, alpha=1.5, b=0.2, beta=0.5, c=1.0)
    rng = np.random.default_rng(2)
    u = rng.normal(size=4000)
    y = g.simulate(u, dt=0.01)
    y = y + 0.05 * np.std(y) * rng.normal(size=y.size)
    fit = fit_fractional_tf(u, y, fs=100.0, domain=domain)
    assert abs(fit.alpha - 1.5) < 0.05
    assert abs(fit.beta - 0.5) < 0.05
    assert fit.domain == domain
    if domain == "time":  # output error down to the noise level (5 % of std)
        assert fit.error < 0.07 * np.std(y)


def test_fractional_beats_integer_model_like_the_paper_table_1():
    """Data from a fractional system: FOM error below IOM (alpha=2, beta=1) on train and
    test ETFEs, as the paper's table 1 reports for its gearbox (e.g. 1.84 vs 3.23)."""
    g = FractionalTF.seed004(a=0.01, alpha=1.6, b=0.2, beta=0.7, c=1.0)
    f = np.logspace(-1, 1.5, 80)
    H = g.frequency_response(2 * np.pi * f)
    rng = np.random.default_rng(5)

    def etfe():
        return H * (1 + 0.05 * (rng.normal(size=f.size) + 1j * rng.normal(size=f.size)))

    train = np.mean([etfe() for _ in range(20)], axis=0)
    fom = fit_fractional_frf(f, train)
    iom = fit_fractional_frf(f, train, fixed_orders={"alpha": 2.0, "beta": 1.0})
    assert iom.alpha == 2.0 and iom.beta == 1.0
    test = np.array([etfe() for _ in range(10)])
    e_fom = model_distance(test, fom.model, f, relative=True).mean()
    e_iom = model_distance(test, iom.model, f, relative=True).mean()
    assert e_fom < 0.5 * e_iom
    assert fom.error < iom.error


def test_condition_classifier_knn_on_model_distances():
    f = np.logspace(-1, 1, 40)
    rng = np.random.default_rng(1)
    conds = {
        "healthy": (0.05, 1.5, 0.2, 0.5, 1.0),
        "worn": (0.05, 1.65, 0.2, 0.5, 1.0),
        "broken": (0.05, 1.5, 0.4, 0.5, 1.0),
        "loose": (0.05, 1.5, 0.2, 0.5, 1.3),
    }
    H, y = [], []
    for lab, p in conds.items():
        G = FractionalTF.seed004(*p).frequency_response(2 * np.pi * f)
        for _ in range(30):
            H.append(
                G * (1 + 0.05 * (rng.normal(size=f.size) + 1j * rng.normal(size=f.size)))
            )
            y.append(lab)
    H, y = np.array(H), np.array(y)
    idx = rng.permutation(len(y))
    tr, te = idx[:80], idx[80:]
    clf = FractionalConditionClassifier(f, n_neighbors=3).fit(H[tr], y[tr])
    assert clf.score(H[te], y[te]) > 0.9
    assert clf.transform(H[:3]).shape == (3, 4)
    with pytest.raises(NotFittedError):
        FractionalConditionClassifier(f).transform(H)
    with pytest.raises(DataError, match="n_members"):
        FractionalConditionClassifier(f).fit(H[:, :5], y)


def test_fit_errors():
    with pytest.raises(DataError, match="usable"):
        fit_fractional_frf([1.0, 2.0], [1.0, 1.0])
    with pytest.raises(ModelError, match="fixed_orders"):
        fit_fractional_frf(np.arange(1, 20.0), np.ones(19), fixed_orders={"gamma": 1})
    with pytest.raises(ModelError, match="domain"):
        fit_fractional_tf(np.ones(100), np.ones(100), 10.0, domain="laplace")


# ------------------------------------------------ the fractional-calculus paper's simplex
W_SEED = np.linspace(100.0, 1000.0, 80)  # the paper's band: 100-1000 rad/s
F_SEED = W_SEED / (2 * np.pi)


def _seed_frf(a, alpha, b, beta, c, w=W_SEED):
    """Eq. 8 written out by hand (not through FractionalTF)."""
    jw = 1j * w
    return 1.0 / (a * np.exp(alpha * np.log(jw)) + b * np.exp(beta * np.log(jw)) + c)


def test_simplex_recovers_the_paper_model_from_noisy_records():
    true = (2e-4, 1.7, 0.05, 0.6, 20.0)
    rng = np.random.default_rng(0)
    H0 = _seed_frf(*true)
    H = H0 * (
        1
        + 0.03
        * (rng.normal(size=(20, W_SEED.size)) + 1j * rng.normal(size=(20, W_SEED.size)))
    )
    fit = fit_fractional_simplex(F_SEED, H)
    assert fit.method == "simplex"
    assert fit.alpha == pytest.approx(1.7, abs=0.05)
    assert fit.beta == pytest.approx(0.6, abs=0.1)
    # the reported error is the paper's f_e, the mean |G_EETF - G| over the records
    G = _seed_frf(fit.a, fit.alpha, fit.b, fit.beta, fit.c)
    assert fit.error == pytest.approx(np.mean(np.abs(H - G)), rel=1e-9)
    # the fractional model holds the integer one: it can only fit as well or better
    iom = fit_fractional_simplex(F_SEED, H, fixed_orders={"alpha": 2.0, "beta": 1.0})
    assert (iom.alpha, iom.beta) == (2.0, 1.0)
    assert fit.error <= iom.error
    sq = fit_fractional_simplex(F_SEED, H, loss="squared")
    assert sq.error == pytest.approx(
        np.mean(np.abs(H - sq.model.frequency_response(W_SEED)) ** 2), rel=1e-9
    )


def test_simplex_on_a_pure_fractional_integrator_has_phase_minus_alpha_90():
    """1 / (a s^alpha) has the phase -alpha * 90 degrees at every frequency; data written
    from that closed form give back alpha and the phase."""
    alpha = 0.7
    H = W_SEED**-alpha * np.exp(-1j * alpha * np.pi / 2) / 3.0
    fit = fit_fractional_simplex(F_SEED, H)
    G = fit.model.frequency_response(W_SEED)
    assert np.max(np.abs(np.degrees(np.angle(G)) + alpha * 90)) < 0.5
    assert np.max(np.abs(G / H - 1)) < 0.01


def test_gl_second_order_matches_scipy_lsim():
    """Integer orders: 1 / (a s^2 + b s + c) by Grunwald-Letnikov against scipy."""
    a, b, c = 0.01, 0.08, 1.0
    dt = 2e-4
    t = np.arange(0, 3, dt)
    u = np.sin(7 * t) + 0.5 * np.sign(np.sin(2 * t))
    y = gl_simulate(u, dt, [a, b, c], [2.0, 1.0, 0.0])
    _, ref, _ = ss.lsim(([1.0], [a, b, c]), u, t)
    assert np.max(np.abs(y - ref)) < 0.02 * np.max(np.abs(ref))


def test_condition_classifier_follows_the_sklearn_contract():
    from sklearn.base import clone
    from sklearn.model_selection import cross_val_score

    f = np.logspace(-1, 1, 25)
    rng = np.random.default_rng(3)
    H, y = [], []
    for lab, alpha in [("ok", 1.2), ("worn", 1.6), ("broken", 1.9)]:
        G = FractionalTF.seed004(0.1, alpha, 0.5, 0.5, 1.0).frequency_response(
            2 * np.pi * f
        )
        for _ in range(12):
            H.append(G * (1 + 0.03 * rng.normal(size=f.size)))
            y.append(lab)
    H, y = np.array(H), np.array(y)
    clf = FractionalConditionClassifier(f, fit_method="simplex")
    assert clone(clf).get_params()["fit_method"] == "simplex"
    with pytest.raises(NotFittedError):
        clf.predict(H)
    assert clf.fit(H, y) is clf
    assert all(m.method == "simplex" for m in clf.models_.values())
    scores = cross_val_score(FractionalConditionClassifier(f), H, y, cv=3)
    assert scores.mean() > 0.9
    with pytest.raises(ModelError, match="fit_method"):
        FractionalConditionClassifier(f, fit_method="bfgs").fit(H, y)


@pytest.mark.real_data
def test_simplex_on_the_silverbox_finds_its_integer_orders(require_data):
    """The Silverbox is an electronic mass-spring-damper (Wigren & Schoukens 2013): its
    FRF is 1/(m s^2 + d s + k) plus a weak cubic stiffness. The paper's fit must find
    alpha ~ 2, beta ~ 1, gain nothing over the integer model, and put the resonance
    (c / a)^(1/alpha) at the peak of the H1 estimate."""
    from pdmkit.ensembles import load_silverbox
    from pdmkit.models.frequency import frf_estimate

    require_data("silverbox")
    sb = load_silverbox()
    u, y, fs = sb["V1"][40650:], sb["V2"][40650:], sb["fs"]
    frf = frf_estimate(u - u.mean(), y - y.mean(), fs, nperseg=2048, fmin=5, fmax=150)
    ok = frf.coherence > 0.9
    fom = fit_fractional_simplex(frf.freq[ok], frf.H[ok])
    iom = fit_fractional_simplex(
        frf.freq[ok], frf.H[ok], fixed_orders={"alpha": 2, "beta": 1}
    )
    assert fom.alpha == pytest.approx(2.0, abs=0.05)
    assert fom.beta == pytest.approx(1.0, abs=0.2)
    assert 0.9 < fom.error / iom.error <= 1.0
    peak = frf.freq[ok][np.argmax(np.abs(frf.H[ok]))]
    # undamped natural frequency (c / a)^(1 / alpha), just above the damped peak
    w_n = (fom.c / fom.a) ** (1 / fom.alpha) / (2 * np.pi)
    assert w_n == pytest.approx(peak, abs=fs / 2048 + 1.5)
