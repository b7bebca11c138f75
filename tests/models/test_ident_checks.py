"""Identification that checks itself (issue 15), model layer.

Every test here failed on the code before the change: the order search stopped at the
edge of 1..10, cancelled/real/Nyquist poles were listed as modes, N4SID crashed on a
long noisy record (``LinAlgError: SVD did not converge``) or returned unstable poles,
the fractional fit degenerated (alpha = beta, a = -b huge), and there was no phase
alignment nor band-limited FRF comparison.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy import signal, special

from pdmkit.errors import ConvergenceWarning
from pdmkit.models.frequency import fit_fractional_tf
from pdmkit.models.ident import IdentifiedModel, identify, n4sid


def zoh_modes(modes, fs):
    """ZOH discretisation (scipy.signal.cont2discrete) of a sum of resonances."""
    num_c, den_c = np.zeros(1), np.ones(1)
    for fn, zeta in modes:
        wn = 2 * np.pi * fn
        d = np.array([1.0, 2 * zeta * wn, wn**2])
        num_c = np.polyadd(np.polymul(num_c, d), wn**2 * den_c)
        den_c = np.polymul(den_c, d)
    num_d, den_d, _ = signal.cont2discrete((num_c, den_c), 1 / fs, method="zoh")
    return np.ravel(num_d), np.ravel(den_d)


def z_pole(fn, zeta, fs):
    wn = 2 * np.pi * fn
    return np.exp((-zeta * wn + 1j * wn * np.sqrt(1 - zeta**2)) / fs)


# ------------------------------------------------------------------ order search edge
def test_order_search_extends_past_the_edge_and_says_so():
    # six modes: the true ARX order is 12, beyond the default range 1..10
    fs = 1000.0
    modes = [(40, 0.02), (90, 0.03), (150, 0.02), (210, 0.03), (280, 0.02), (350, 0.03)]
    num, den = zoh_modes(modes, fs)
    rng = np.random.default_rng(0)
    u = rng.normal(size=6000)
    y = signal.lfilter(num, den, u) + signal.lfilter([0.05], den, rng.normal(size=6000))
    m = identify(u, y, fs, "arx", None, "bic")
    search = m.info["order_search"]
    assert search["extended"] and not search["at_edge"]
    assert search["searched"][1] > 10
    assert m.orders["na"] == 12  # the generating order (BIC is consistent)
    assert "edge" in search["note"] and "extended" in search["note"]
    fn = m.modes()[0]["natural_frequency_hz"].to_numpy()
    for f_true, _ in modes:
        assert np.min(np.abs(fn - f_true)) / f_true < 0.01


def test_order_search_inside_the_range_is_not_extended():
    fs = 100.0
    num, den = zoh_modes([(10.0, 0.05)], fs)
    rng = np.random.default_rng(1)
    u = rng.normal(size=3000)
    y = signal.lfilter(num, den, u) + signal.lfilter([0.01], den, rng.normal(size=3000))
    m = identify(u, y, fs, "arx", None, "bic")
    assert m.orders["na"] == 2
    assert m.info["order_search"]["extended"] is False
    assert m.info["order_search"]["searched"] == [1, 10]


# ------------------------------------------------------------------ modes table
def test_physical_modes_drops_cancelled_real_and_nyquist_poles():
    from pdmkit.models.ident import physical_modes

    fs = 100.0
    p5, p20, p30 = z_pole(5.0, 0.05, fs), z_pole(20.0, 0.02, fs), z_pole(30.0, 0.01, fs)
    poles = [p5, p5.conjugate(), p20, p20.conjugate(), p30, p30.conjugate(), 0.9, -0.5]
    # a zero 1e-5 (relative) from the 20 Hz pole: cancelled; 1e-2 from 30 Hz: not
    zeros = [p20 * (1 + 1e-5), p20.conjugate() * (1 + 1e-5), p30 * 1.01, 0.3]
    modes, dropped = physical_modes(poles, zeros, fs)
    np.testing.assert_allclose(modes["natural_frequency_hz"], [5.0, 30.0], rtol=1e-9)
    np.testing.assert_allclose(modes["damping"], [0.05, 0.01], rtol=1e-9)
    reasons = dict(
        zip(dropped["natural_frequency_hz"].round(3), dropped["reason"], strict=True)
    )
    assert reasons[20.0] == "cancelled by a zero"
    assert (
        reasons[round(-np.log(0.9) * fs / (2 * np.pi), 3)] == "real pole (no oscillation)"
    )
    nyq = [r for f, r in reasons.items() if f >= 49]
    assert nyq == ["at or above Nyquist"]
    # a band leaves the 30 Hz mode out, with its reason
    modes_b, dropped_b = physical_modes(poles, zeros, fs, band=(2.0, 15.0))
    assert modes_b["natural_frequency_hz"].round(6).tolist() == [5.0]
    assert "outside the band" in dropped_b["reason"].tolist()


def test_identified_model_modes_leave_out_a_cancelled_pair():
    # G = B/A with a pole pair at 20 Hz that the numerator cancels: the input-output
    # dynamics show only the 8 Hz mode
    fs = 200.0
    p8, p20 = z_pole(8.0, 0.03, fs), z_pole(20.0, 0.02, fs)
    a = np.real(np.poly([p8, p8.conjugate(), p20, p20.conjugate()]))
    b = np.r_[
        0.0, 0.01 * np.real(np.poly([p20 * (1 + 2e-4), p20.conjugate() * (1 + 2e-4)]))
    ]
    m = IdentifiedModel("arx", fs, {"na": 4, "nb": 3, "nk": 1}, A=a, B=b)
    modes, dropped = m.modes()
    assert modes["natural_frequency_hz"].round(6).tolist() == [8.0]
    assert dropped["reason"].tolist() == ["cancelled by a zero"]
    assert abs(dropped["natural_frequency_hz"][0] - 20.0) < 1e-6
    # the old listing (every pole a mode) had both
    np.testing.assert_allclose(m.natural_frequencies_hz, [8.0, 20.0], rtol=1e-9)


# ------------------------------------------------------------------ N4SID
def test_n4sid_order_search_on_a_long_noisy_record():
    # two modes, 20 dB SNR, 20000 samples: crashed with "SVD did not converge"
    fs = 1000.0
    modes = [(50.0, 0.02), (120.0, 0.05)]
    num, den = zoh_modes(modes, fs)
    rng = np.random.default_rng(1)
    u = rng.normal(size=20000)
    y0 = signal.lfilter(num, den, u)
    v = rng.normal(size=y0.size)
    y = y0 + v * np.std(y0) / np.std(v) * 0.1
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        m = identify(u, y, fs, "n4sid", None, "bic")
    # the order that crashed: its unstable poles are reflected, and it says so
    with pytest.warns(ConvergenceWarning, match="reflected into it"):
        m9 = n4sid(u, y, 9, fs=fs, noise_model=False)
    assert m9.info["stabilised_poles"] > 0
    assert m.is_stable and m9.is_stable
    assert np.isfinite(m9.fit_percent) and m9.fit_percent > 85
    assert m.fit_percent > 85  # 20 dB: the noise-free output is 99 % of the power
    fn, zeta = m.natural_frequencies_hz, m.damping
    for f_true, z_true in modes:
        i = int(np.argmin(np.abs(fn - f_true)))
        assert abs(fn[i] - f_true) / f_true < 0.01
        assert abs(zeta[i] - z_true) / z_true < 0.15


def test_n4sid_reflects_unstable_poles_and_says_so():
    from pdmkit.models.ident import stabilise_matrix

    A = np.array([[1.2, 0.3, 0.0], [0.0, 0.5, 0.0], [0.0, 0.0, -1.1]])
    As, moved = stabilise_matrix(A)
    ev = np.sort_complex(np.linalg.eigvals(As))
    ref = np.sort_complex(np.array([1 / 1.2, 0.5, -1 / 1.1]))
    np.testing.assert_allclose(ev, ref, atol=1e-3)
    assert moved == 2 and np.isrealobj(As)
    # a complex pair outside the circle stays a (reflected) pair
    r, th = 1.05, 0.4
    R = r * np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    ev2 = np.linalg.eigvals(stabilise_matrix(R)[0])
    np.testing.assert_allclose(np.abs(ev2), 1 / r, rtol=1e-3)
    np.testing.assert_allclose(np.sort(np.abs(np.angle(ev2))), [th, th], rtol=1e-9)


# ------------------------------------------------------------------ fractional
def gl_reference(u, dt, den, orders, gain):
    """Grünwald-Letnikov simulation of gain / sum(den_i s^orders_i), from rest.

    Independent of pdmkit: weights (-1)^k binom(q, k) from scipy.special.binom.
    """
    n = u.size
    k = np.arange(n)
    W = np.zeros(n)
    for a, q in zip(den, orders, strict=True):
        W += a * dt**-q * (-1.0) ** k * special.binom(q, k)
    y = np.zeros(n)
    for i in range(n):
        acc = W[1 : i + 1] @ y[i - 1 :: -1] if i else 0.0
        y[i] = (gain * u[i] - acc) / W[0]
    return y


def test_fractional_fit_recovers_distinct_exponents():
    # G(s) = 20 / (s^1.6 + 3 s^0.7 + 1), swept sine at 100 Hz: the fit used to end at
    # alpha = beta (on the bound) with huge coefficients of opposite signs
    fs, n = 100.0, 3000
    t = np.arange(n) / fs
    u = signal.chirp(t, 1.0, t[-1], 20.0)
    y = gl_reference(u, 1 / fs, [1.0, 3.0, 1.0], [1.6, 0.7, 0.0], 20.0)
    fit = fit_fractional_tf(u, y, fs, domain="time")
    assert abs(fit.alpha - 1.6) < 0.02 and abs(fit.beta - 0.7) < 0.02
    assert fit.alpha > fit.beta + 0.05
    assert fit.a >= 0 and fit.b >= 0
    # the model form is 1 / (a s^alpha + b s^beta + c): a, b, c are the generating
    # coefficients divided by the gain 20
    np.testing.assert_allclose([fit.a, fit.b, fit.c], [0.05, 0.15, 0.05], rtol=0.03)
    assert fit.fit_percent > 99


def test_fractional_fit_keeps_the_orders_apart_unless_told():
    fs, n = 100.0, 2000
    t = np.arange(n) / fs
    u = signal.chirp(t, 1.0, t[-1], 20.0)
    y = gl_reference(u, 1 / fs, [1.0, 3.0, 1.0], [1.6, 0.7, 0.0], 20.0)
    fit = fit_fractional_tf(u, y, fs, domain="frequency", min_gap=0.3)
    assert fit.alpha >= fit.beta + 0.3 - 1e-9
    assert min(fit.a, fit.b) >= 0


# ------------------------------------------------------------------ FRF comparison
def test_align_phase_puts_the_model_on_the_data_branch():
    from pdmkit.models.frequency import align_phase

    f = np.linspace(1, 10, 50)
    data = -200.0 - 10 * f  # an unwrapped phase on the branch below -180
    model_wrapped = np.degrees(np.angle(np.exp(1j * np.radians(data + 2.0))))
    out = align_phase(model_wrapped, data)
    np.testing.assert_allclose(out, data + 2.0, atol=1e-9)


def test_frf_comparison_coherence_and_phase_over_a_band():
    from pdmkit.models.frequency import frf_comparison

    fs = 100.0
    num, den = zoh_modes([(8.0, 0.02), (15.0, 0.03)], fs)
    rng = np.random.default_rng(3)
    u = rng.normal(size=30000)
    y = signal.lfilter(num, den, u) + 0.02 * rng.normal(size=30000)

    def G(f):
        return signal.freqz(num, den, worN=f, fs=fs)[1]

    c = frf_comparison(u, y, fs, G, band=(5.0, 20.0))
    assert c["freq"][0] >= 5.0 and c["freq"][-1] <= 20.0
    # coherence as scipy.signal.coherence computes it (same Welch segments)
    f_ref, coh_ref = signal.coherence(u, y, fs=fs, nperseg=c["nperseg"])
    keep = (f_ref >= 5.0) & (f_ref <= 20.0)
    np.testing.assert_allclose(c["coherence"], coh_ref[keep], atol=1e-9)
    # the true model and the data agree in phase on one branch (not 360 k apart)
    good = c["coherence"] > 0.9
    assert np.max(np.abs(c["phase_model_deg"] - c["phase_data_deg"])[good]) < 10


@pytest.mark.parametrize("q", [5, 20])
def test_decimate_record_is_anti_aliased(q):
    from pdmkit.experiments._identify import decimate_record

    fs = 1000.0
    t = np.arange(20000) / fs
    slow = np.sin(2 * np.pi * 3.0 * t)
    fast = np.sin(2 * np.pi * (fs / q + 1.0) * t)  # aliases onto 1 Hz if not filtered
    xd = decimate_record(slow + fast, q)
    ref = slow[::q]
    assert xd.size == ref.size
    assert np.max(np.abs(xd - ref)[100:-100]) < 0.02


def test_ar_prediction_fit_leaves_out_the_start_up_transient():
    # an AR(20) of a band-limited resonance (as a sensor's anti-alias filter leaves
    # it, the DaISy robot arm's acceleration): the one-step predictor started from a
    # zero past made the fit of the whole record -650 %
    fs = 1.0
    p = z_pole(0.06, 0.005, fs)
    a = np.real(np.poly([p, p.conjugate()]))
    rng = np.random.default_rng(6)
    y = signal.lfilter([1.0], a, rng.normal(size=1024))
    y = 5.0 + signal.filtfilt(*signal.butter(8, 0.3), y)
    m = identify(None, y, fs, "ar", 20)
    # reference: the least-squares predictor -sum a_k y(t - k), from sample 20 on
    yc = y - m.y_offset
    pred = -signal.lfilter(np.r_[0.0, m.A[1:]], [1.0], yc) + m.y_offset
    ref = 100 * (
        1 - np.linalg.norm(y[20:] - pred[20:]) / np.linalg.norm(y[20:] - y[20:].mean())
    )
    assert m.fit_percent == pytest.approx(ref, rel=1e-9)
    assert m.fit_percent > 90


def test_the_order_search_shows_a_bar_on_a_terminal(monkeypatch) -> None:
    """A long identify said nothing while it searched (issue 15): a bar on a terminal,
    none in a pipe."""
    import io
    import sys

    from pdmkit.models.ident import select_order

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    rng = np.random.default_rng(0)
    y = signal.lfilter([1.0], [1, -1.5, 0.7], rng.normal(size=400))
    monkeypatch.setattr(sys, "stderr", Terminal())
    select_order(None, y, "ar", orders=range(1, 5))
    assert "ar orders" in sys.stderr.getvalue()
    pipe = io.StringIO()
    monkeypatch.setattr(sys, "stderr", pipe)
    select_order(None, y, "ar", orders=range(1, 5))
    assert pipe.getvalue() == ""
