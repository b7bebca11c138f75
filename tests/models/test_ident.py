"""Linear identification recovers known systems (built from chosen continuous poles)."""

from __future__ import annotations

import control
import numpy as np
import pytest
from scipy import signal

from pdmkit.errors import DataError, ModelError
from pdmkit.models.ident import (
    IdentifiedModel,
    ar,
    armax,
    arx,
    bj,
    fit_percent,
    identify,
    n4sid,
    oe,
    select_order,
)

FS = 1000.0
MODES = [(50.0, 0.02), (120.0, 0.05)]  # (natural frequency Hz, damping ratio)


def two_mode_system(modes=MODES, fs=FS):
    """ZOH discretisation (scipy.signal.cont2discrete) of a sum of two resonances."""
    num_c, den_c = np.zeros(1), np.ones(1)
    for fn, zeta in modes:
        wn = 2 * np.pi * fn
        d = np.array([1.0, 2 * zeta * wn, wn**2])
        num_c = np.polyadd(np.polymul(num_c, d), wn**2 * den_c)
        den_c = np.polymul(den_c, d)
    num_d, den_d, _ = signal.cont2discrete((num_c, den_c), 1 / fs, method="zoh")
    return np.ravel(num_d), np.ravel(den_d), (num_c, den_c)


def add_noise(y0, snr_db, rng, colour=None):
    v = rng.normal(size=y0.size)
    if colour is not None:
        v = signal.lfilter([1.0], colour, v)
    return y0 + v * np.std(y0) / np.std(v) * 10 ** (-snr_db / 20)


def assert_modes(model, modes=MODES, f_tol=0.01, z_tol=0.10):
    fn, zeta = model.natural_frequencies_hz, model.damping
    for f_true, z_true in modes:
        i = int(np.argmin(np.abs(fn - f_true)))
        assert abs(fn[i] - f_true) / f_true < f_tol, (fn, f_true)
        assert abs(zeta[i] - z_true) / z_true < z_tol, (zeta, z_true)


@pytest.fixture(scope="module")
def system():
    return two_mode_system()


def test_modes_of_the_reference_system(system):
    # the test system itself: poles of the ZOH model map back to the chosen modes
    _, den, _ = system
    m = IdentifiedModel("arx", FS, {"na": 4}, A=den, B=np.r_[0.0, 1.0])
    np.testing.assert_allclose(m.natural_frequencies_hz, [50, 120], rtol=1e-9)
    np.testing.assert_allclose(m.damping, [0.02, 0.05], rtol=1e-9)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_ar_recovers_modes_at_20db(seed):
    rng = np.random.default_rng(seed)
    _, den, _ = two_mode_system()
    y = signal.lfilter([1.0], den, rng.normal(size=200_000))
    y = add_noise(y, 20, rng)
    # measurement noise makes the process ARMA; a long AR absorbs the MA part
    assert_modes(ar(y, 40, fs=FS))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_arx_recovers_modes_at_20db_equation_error(seed, system):
    num, den, _ = system
    rng = np.random.default_rng(seed)
    u = rng.normal(size=20000)
    y = add_noise(signal.lfilter(num, den, u), 20, rng, colour=den)
    m = arx(u, y, na=4, nb=4, nk=1, fs=FS)
    assert_modes(m)
    assert m.residual_test(u, y)["white"]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_oe_recovers_modes_at_20db_white_output_noise(seed, system):
    num, den, _ = system
    rng = np.random.default_rng(seed)
    u = rng.normal(size=20000)
    y0 = signal.lfilter(num, den, u)
    y = add_noise(y0, 20, rng)
    m = oe(u, y, nb=4, nf=4, nk=1, fs=FS)
    assert_modes(m)
    # white output noise of 20 dB: the simulation fit is 100 (1 - 0.1) = 90 %
    assert m.fit_percent == pytest.approx(90.0, abs=1.0)
    # ARX on the same data is biased (the reason OE exists)
    biased = arx(u, y, na=4, nb=4, nk=1, fs=FS)
    with pytest.raises(AssertionError):
        assert_modes(biased)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1])
def test_n4sid_recovers_modes_at_20db(seed, system):
    num, den, _ = system
    rng = np.random.default_rng(seed)
    u = rng.normal(size=20000)
    y = add_noise(signal.lfilter(num, den, u), 20, rng)
    m = n4sid(u, y, 4, fs=FS)
    assert_modes(m)
    # one-step predictions with the fitted Kalman gain beat the simulation
    assert m.compare(u, y, 1) >= m.compare(u, y, None) - 0.5


def test_armax_and_bj_recover_modes(system):
    num, den, _ = system
    rng = np.random.default_rng(7)
    u = rng.normal(size=20000)
    y0 = signal.lfilter(num, den, u)
    y = add_noise(y0, 20, rng, colour=[1.0, -0.7])
    assert_modes(bj(u, y, nb=4, nc=0, nd=1, nf=4, nk=1, fs=FS))
    e = rng.normal(size=u.size)
    v = signal.lfilter([1.0, 0.5], den, e)
    y2 = y0 + v * 0.1 * np.std(y0) / np.std(v)
    assert_modes(armax(u, y2, na=4, nb=4, nc=1, nk=1, fs=FS))


def test_n4sid_mimo_matches_the_true_frequency_response():
    # two inputs, two outputs, 4 states: a random stable system from python-control
    sysd = control.ss(
        np.array(
            [[0.9, 0.2, 0, 0], [-0.2, 0.9, 0, 0], [0, 0, 0.5, 0.4], [0, 0, -0.4, 0.5]]
        ),
        np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [0.5, -1.0]]),
        np.array([[1.0, 0.0, 1.0, 0.0], [0.0, 1.0, 0.0, 1.0]]),
        np.zeros((2, 2)),
        1 / FS,
    )
    rng = np.random.default_rng(3)
    u = rng.normal(size=(6000, 2))
    resp = control.forced_response(sysd, U=u.T)
    y = resp.outputs.T + 0.001 * rng.normal(size=(6000, 2))
    m = n4sid(u, y, 4, fs=FS, noise_model=False)
    np.testing.assert_allclose(
        np.sort_complex(m.poles), np.sort_complex(np.linalg.eigvals(sysd.A)), atol=2e-3
    )
    f = np.array([10.0, 60.0, 200.0])
    ref = np.stack([sysd(np.exp(2j * np.pi * fi / FS)) for fi in f])
    np.testing.assert_allclose(m.frequency_response(f), ref, rtol=0.02, atol=0.02)
    assert m.simulate(u).shape == (6000, 2)


@pytest.mark.filterwarnings("ignore::scipy.signal.BadCoefficients")  # dlti of num[0]=0
def test_frequency_response_and_continuous_conversion_against_references(system):
    num, den, (num_c, den_c) = system
    rng = np.random.default_rng(5)
    u = rng.normal(size=5000)
    y = signal.lfilter(num, den, u)
    m = arx(u, y, na=4, nb=4, nk=1, fs=FS)
    f = np.array([5.0, 50.0, 90.0, 120.0, 300.0])
    _, h_ref = signal.dfreqresp(signal.dlti(num, den, dt=1 / FS), w=2 * np.pi * f / FS)
    np.testing.assert_allclose(m.frequency_response(f), h_ref, rtol=1e-3)
    # ZOH inverse: the continuous model has the chosen poles and the true response
    cont = m.to_continuous()
    np.testing.assert_allclose(
        np.sort_complex(cont.poles), np.sort_complex(np.roots(den_c)), rtol=1e-4
    )
    w = 2 * np.pi * f
    _, h_c = signal.freqresp(cont, w)
    _, h_true = signal.freqresp(signal.lti(num_c, den_c), w)
    np.testing.assert_allclose(h_c, h_true, rtol=1e-3)
    # and sampling it again with python-control gives back the discrete model
    resampled = control.sample_system(control.ss(cont.A, cont.B, cont.C, cont.D), 1 / FS)
    back = np.array([resampled(np.exp(2j * np.pi * fi / FS)) for fi in f]).ravel()
    np.testing.assert_allclose(back, m.frequency_response(f), rtol=1e-9)


def test_predict_k_steps_matches_closed_form_for_ar1():
    rng = np.random.default_rng(0)
    y = signal.lfilter([1.0], [1.0, -0.8], rng.normal(size=500))
    m = IdentifiedModel("ar", 1.0, {"na": 1}, A=np.array([1.0, -0.8]))
    for k in (1, 3):
        pred = m.predict(None, y, k)
        np.testing.assert_allclose(pred[k:], 0.8**k * y[:-k], atol=1e-12)


def test_one_step_errors_are_the_innovations_of_the_true_armax():
    rng = np.random.default_rng(1)
    u, e = rng.normal(size=(2, 3000))
    A, B, C = np.array([1, -1.2, 0.5]), np.array([0, 1.0, 0.3]), np.array([1, 0.4])
    y = signal.lfilter(B, A, u) + signal.lfilter(C, A, e)
    m = IdentifiedModel("armax", 1.0, {"na": 2, "nb": 2, "nc": 1, "nk": 1}, A=A, B=B, C=C)
    np.testing.assert_allclose(m.prediction_errors(u, y), e, atol=1e-10)
    np.testing.assert_allclose(m.predict(u, y, None), signal.lfilter(B, A, u))


def test_residual_tests_flag_an_undermodelled_system(system):
    num, den, _ = system
    rng = np.random.default_rng(2)
    u = rng.normal(size=8000)
    y = add_noise(signal.lfilter(num, den, u), 20, rng, colour=den)
    good = arx(u, y, 4, 4, 1, fs=FS).residual_test(u, y)
    bad = arx(u, y, 2, 2, 1, fs=FS).residual_test(u, y)
    # 51 cross-correlation lags against a 99 % band: a few may stray by chance
    assert good["white"] and good["inputs"]["u"]["xcorr_outside"] <= 0.1
    assert not bad["white"] and bad["inputs"]["u"]["xcorr_outside"] > 0.2


@pytest.mark.slow
@pytest.mark.parametrize("criterion", ["bic", "mdl"])
def test_order_selection_picks_true_order_in_90_percent(criterion, system):
    num, den, _ = system
    hits = 0
    for seed in range(20):
        rng = np.random.default_rng(100 + seed)
        u = rng.normal(size=3000)
        y = add_noise(signal.lfilter(num, den, u), 20, rng, colour=den)
        sel = select_order(u, y, "arx", range(1, 9), criterion, fs=FS)
        hits += sel.best_order["na"] == 4
    assert hits >= 18, hits


def test_ar_order_selection_picks_true_order():
    _, den, _ = two_mode_system()
    hits = 0
    for seed in range(20):
        rng = np.random.default_rng(seed)
        y = signal.lfilter([1.0], den, rng.normal(size=3000))
        hits += select_order(None, y, "ar", range(1, 9), "bic").best_order["na"] == 4
    assert hits >= 18, hits


def test_identify_dispatch_and_selection(system):
    num, den, _ = system
    rng = np.random.default_rng(9)
    u = rng.normal(size=4000)
    y = add_noise(signal.lfilter(num, den, u), 30, rng, colour=den)
    m = identify(u, y, FS, "arx", criterion="bic", max_order=6)
    assert m.orders["na"] == 4
    assert set(m.info["selection"].to_pandas()["na"]) == set(range(1, 7))
    m2 = identify(u, y, FS, "arx", order={"na": 4, "nb": 4, "nk": 1})
    assert m2.orders == {"na": 4, "nb": 4, "nk": 1}
    d = m2.to_dict()
    assert {"structure", "order", "poles", "natural_frequencies_hz", "damping"} <= set(d)
    assert len(m2.to_pandas()) == 2


def test_fit_percent_formula():
    y = np.array([1.0, 2.0, 3.0, 4.0])
    yh = np.array([1.0, 2.0, 3.0, 5.0])
    expected = 100 * (1 - 1.0 / np.sqrt(5.0))  # ||y - yh|| = 1, ||y - mean|| = sqrt(5)
    assert fit_percent(y, yh) == pytest.approx(expected)


def test_errors_name_the_input():
    u = np.ones(100)
    y = np.r_[np.zeros(50), np.nan, np.zeros(49)]
    with pytest.raises(DataError, match="sample 50"):
        arx(u, y, 2, 2)
    with pytest.raises(DataError, match="u has 99 samples"):
        arx(u[:99], np.zeros(100), 2, 2)
    with pytest.raises(ModelError, match="structure must be one of"):
        identify(u, u, 1.0, "narx", order=2)
    with pytest.raises(ModelError, match="do not belong"):
        identify(u, u, 1.0, "oe", order={"na": 2})
    with pytest.raises(ModelError, match="no input"):
        ar(np.random.default_rng(0).normal(size=200), 2).simulate(u)


def test_plot_returns_axes(system):
    num, den, _ = system
    m = IdentifiedModel("arx", FS, {"na": 4}, A=den, B=num)
    ax = m.plot()
    assert ax.get_xlabel() == "Re z"
    import matplotlib.pyplot as plt

    plt.close("all")


def test_n4sid_takes_one_output_as_a_column_or_a_vector():
    """A (n, 1) output is the same output as (n,): same model, same fit (helper report)."""
    from scipy import signal as _signal

    from pdmkit.models.ident import n4sid

    rng = np.random.default_rng(0)
    u = rng.normal(size=2000)
    y = _signal.lfilter([0, 0.2], [1, -1.5, 0.7], u) + 0.01 * rng.normal(size=2000)
    flat = n4sid(u, y, 2, fs=10.0)
    column = n4sid(u, y[:, None], 2, fs=10.0)
    assert np.allclose(np.sort_complex(flat.poles), np.sort_complex(column.poles))
    assert flat.fit_percent == pytest.approx(column.fit_percent) and flat.fit_percent > 95
