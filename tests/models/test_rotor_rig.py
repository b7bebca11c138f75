"""The rotor rig and the residual generators, against independent references.

The rig and the generators follow the rotor-diagnostics monograph.

References: the Ocvirk short-bearing solution (load-eccentricity relation, attitude
angle) and a direct numerical integration of the short-bearing Reynolds pressure;
Euler-Bernoulli beam flexibility in closed form; the Jeffcott rotor's critical speed
``sqrt(k / m)`` and its unbalance response; scipy's lfilter / cont2discrete; the F-16
ground vibration test (real data).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import optimize, signal
from threadpoolctl import threadpool_limits

from pdmkit.errors import DataError, ModelError, NotFittedError
from pdmkit.models.diagnosis import (
    ParityEquations,
    channel_to_channel,
    parity_residual,
    reconstruct_input,
)
from pdmkit.models.frequency import frf_estimate
from pdmkit.models.ident import arx
from pdmkit.models.rigs import ROTOR_FAULTS, RotorRig, short_bearing_coefficients

MU, R, L, C = 0.01, 0.02, 0.055, 150e-6


@pytest.fixture(autouse=True)
def _one_blas_thread():
    """Small matrices: BLAS threads only slow them down (a lot on a busy machine)."""
    with threadpool_limits(1, user_api="blas"):
        yield


THETA = np.linspace(0, 2 * np.pi, 2881)[:-1]


def reynolds_force(x, y, vx, vy, omega):
    """Short-bearing film force on the journal by integrating the pressure (pi-film).

    ``d/dz (h^3 dp/dz) = 12 mu ((omega / 2) dh/dtheta + dh/dt)``, ``h = c - x cos -
    y sin``; the pressure is set to zero where the solution is negative.
    """
    h = C - x * np.cos(THETA) - y * np.sin(THETA)
    g = 0.5 * omega * (x * np.sin(THETA) - y * np.cos(THETA)) - vx * np.cos(THETA)
    g = g - vy * np.sin(THETA)
    p = np.maximum(-MU * L**3 * g / h**3, 0.0)  # integrated over the length
    d = THETA[1] - THETA[0]
    return np.array([-np.sum(p * np.cos(THETA)), -np.sum(p * np.sin(THETA))]) * R * d


def test_short_bearing_matches_reynolds_integration_and_ocvirk():
    omega, load = 2 * np.pi * 30, 11.5
    eps, K, Cb = short_bearing_coefficients(
        load, omega, viscosity=MU, radius=R, length=L, clearance=C
    )
    # static equilibrium of the integrated film force against the weight (along +y)
    sol = optimize.fsolve(
        lambda p: reynolds_force(p[0] * 1e-6, p[1] * 1e-6, 0, 0, omega) - [0, load],
        [10.0, -1.0],
        xtol=1e-12,
    )
    x0, y0 = sol * 1e-6
    assert math.hypot(x0, y0) / C == pytest.approx(eps, rel=1e-4)
    # Ocvirk's attitude angle tan(phi) = pi sqrt(1 - eps^2) / (4 eps)
    phi = math.degrees(math.atan2(x0, -y0))
    assert phi == pytest.approx(
        math.degrees(math.atan(math.pi * math.sqrt(1 - eps**2) / (4 * eps))), rel=1e-4
    )
    # stiffness and damping: central differences of the integrated force
    dx, dv = 1e-9, 1e-6
    for j in range(2):
        e = np.eye(2)[j]
        k = -(
            reynolds_force(x0 + dx * e[0], y0 + dx * e[1], 0, 0, omega)
            - reynolds_force(x0 - dx * e[0], y0 - dx * e[1], 0, 0, omega)
        ) / (2 * dx)
        c = -(
            reynolds_force(x0, y0, dv * e[0], dv * e[1], omega)
            - reynolds_force(x0, y0, -dv * e[0], -dv * e[1], omega)
        ) / (2 * dv)
        np.testing.assert_allclose(K[:, j], k, rtol=2e-3, atol=1e-3 * np.abs(K).max())
        np.testing.assert_allclose(Cb[:, j], c, rtol=2e-3, atol=1e-3 * np.abs(Cb).max())


def test_shaft_flexibility_matches_beam_theory():
    rig = RotorRig(outboard="rigid")
    EI = rig.youngs_modulus * math.pi * rig.shaft_diameter**4 / 64
    Ltot = sum(rig.section_lengths)
    a = rig.node_positions[1:3]
    # simply supported beam: deflection at x_i under a unit load at x_j (x_i <= x_j)
    F = np.empty((2, 2))
    for i in range(2):
        for j in range(2):
            xi, xj = sorted((a[i], a[j]))
            b = Ltot - xj
            F[i, j] = b * xi * (Ltot**2 - b**2 - xi**2) / (6 * EI * Ltot)
    np.testing.assert_allclose(np.linalg.inv(rig.shaft_stiffness()[:2, :2]), F, rtol=1e-9)


def _jeffcott(m=1.0):
    # one disk at mid-span of a simply supported, massless shaft (the other nodes
    # carry a negligible mass)
    return RotorRig(
        outboard="rigid",
        section_lengths=(0.25, 0.1, 0.15),
        density=0.0,
        node_masses=(0.0, m, 1e-6, 0.0),
        shaft_damping=0.0,
        unbalance_masses=(0.0, 1e-3, 0.0, 0.0),
        force_noise=0.0,
        sensor_noise=0.0,
    )


def test_jeffcott_critical_speed_is_sqrt_k_over_m():
    rig = _jeffcott()
    EI = rig.youngs_modulus * math.pi * rig.shaft_diameter**4 / 64
    k = 48 * EI / 0.5**3
    f1 = rig.modes()["frequency_hz"].iloc[0]
    assert f1 == pytest.approx(math.sqrt(k / 1.0) / (2 * math.pi), rel=1e-5)


def test_unbalance_response_matches_the_jeffcott_formula():
    rig = _jeffcott().with_params(shaft_damping=2e-4, speed_hz=15.0)
    EI = rig.youngs_modulus * math.pi * rig.shaft_diameter**4 / 64
    k = 48 * EI / 0.5**3
    c = 2e-4 * k
    w = rig.omega
    expected = 1e-3 * rig.unbalance_radius * w**2 / abs(k - 1.0 * w**2 + 1j * c * w)
    rec = rig.simulate(4.0, fs=256.0, seed=0)
    x = rec.channel("ch1")[512:]  # after the start-up transient (tau = 2 m / c)
    amp = np.sqrt(2) * np.std(x)
    assert amp == pytest.approx(expected, rel=0.02)


def test_faults_change_the_physics_the_monograph_names():
    rig = RotorRig()
    healthy = rig.modes()
    loose = rig.modes("looseness")
    # looseness: lower vertical frequencies (seed sec. 2.6), the horizontal ones stay
    assert loose["frequency_hz"].min() > 0
    assert np.sum(loose["frequency_hz"] < 60) > np.sum(healthy["frequency_hz"] < 60)
    assert np.isclose(loose["frequency_hz"], healthy["frequency_hz"].iloc[-1]).any()
    # misalignment preloads the bearing: higher eccentricity, stiffer film
    eps0, K0, _ = rig.bearing_coefficients()
    eps1, K1, _ = rig.bearing_coefficients(preload=rig.bearing_load())
    assert eps1 > eps0 and K1[1, 1] > K0[1, 1]
    # the healthy rig at 30 Hz is stable (oil whirl below its threshold)
    assert (healthy["damping"] > 0).all()
    assert set(ROTOR_FAULTS) == {"unbalance", "misalignment", "rub", "looseness"}


def test_rub_raises_the_bending_frequency_and_the_record_has_the_monograph_rate():
    rig = RotorRig()
    before = rig.simulate(20.0, seed=3)
    rub = rig.simulate(20.0, fault="rub", onset=0.0, seed=3)
    assert rub.fs == 256.0 and rub.channels.shape == (5120, 4) and rub.onset == 0.0

    def peak(y):
        f, p = signal.welch(y, fs=256.0, nperseg=2048)
        band = (f > 18) & (f < 29)
        return f[band][np.argmax(p[band])]

    assert peak(rub.channel("ch2")) > peak(before.channel("ch2")) + 1.0


def test_rig_errors():
    with pytest.raises(ModelError, match="fault must be one of"):
        RotorRig().simulate(1.0, fault="crack")
    with pytest.raises(ModelError, match="outboard"):
        RotorRig(outboard="magnetic")
    with pytest.raises(DataError, match="duration"):
        RotorRig().simulate(0.0)
    with pytest.raises(DataError, match="channel"):
        RotorRig().simulate(0.5).channel("ch9")


# ------------------------------------------------------------------ residual generators
def _two_outputs(seed=0, n=8000, path=([0.5, 0.2], [1.0, -0.3])):
    rng = np.random.default_rng(seed)
    a = np.real(np.poly([0.97 * np.exp(0.5j), 0.97 * np.exp(-0.5j)]))
    y_in = signal.lfilter([1.0], a, rng.normal(size=n))
    # the path B/A with noise through 1/A: an ARX relation whose equation error is white
    y_out = signal.lfilter(*path, y_in) + signal.lfilter(
        [1.0], path[1], 0.01 * rng.normal(size=n)
    )
    return y_in, y_out


def test_channel_to_channel_recovers_the_path_and_parity_is_white():
    y_in, y_out = _two_outputs()
    m = channel_to_channel(y_in, y_out, fs=100.0)  # order by MDL
    f = np.linspace(1, 40, 50)
    _, H = signal.freqz([0.5, 0.2], [1.0, -0.3], worN=f, fs=100.0)
    np.testing.assert_allclose(m.frequency_response(f), H, rtol=0.02)
    r = parity_residual(m, y_in, y_out)
    # the equation error of the true path is the added white noise (std 0.01)
    assert np.std(r[50:]) == pytest.approx(0.01, rel=0.1)
    lags = [abs(np.corrcoef(r[50:-k], r[50 + k :])[0, 1]) for k in range(1, 6)]
    assert max(lags) < 2.58 / np.sqrt(r.size)  # white (Ljung's bound)


def test_parity_equations_flag_a_changed_path_only():
    y_in, y_out = _two_outputs(1)
    healthy = np.column_stack([y_in, y_out])
    pe = ParityEquations([(0, 1)], forgetting=0.99).fit(healthy, fs=100.0)
    same = pe.residuals(np.column_stack(_two_outputs(2)))
    changed = pe.residuals(np.column_stack(_two_outputs(2, path=([0.6, 0.2], [1.0, -0.3]))))
    assert np.percentile(same.ratio[500:, 0], 99) < 1.5
    assert np.median(changed.ratio[500:, 0]) > 3.0
    assert list(same.to_pandas().columns) == ["time", "ch1->ch2", "ch1->ch2 ratio"]
    with pytest.raises(NotFittedError):
        ParityEquations([(0, 1)]).residuals(healthy)
    with pytest.raises(DataError, match="pair"):
        ParityEquations([(0, 5)]).fit(healthy, fs=100.0)


def test_input_reconstruction_of_the_monograph_two_mass_rotor():
    # the monograph's sec. 2.5: m1 = m2 = 1 kg, k1 = k2 = k3 = (20 pi)^2 N/m, d = 0.001 k;
    # force on mass 1, its displacement measured; square and sinusoidal inputs
    k = (20 * np.pi) ** 2
    d = 0.001 * k
    K = np.array([[2 * k, -k], [-k, 2 * k]])
    D = np.array([[2 * d, -d], [-d, 2 * d]])
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-K, -D]])
    B = np.r_[0, 0, 1.0, 0][:, None]
    fs = 500.0
    sysd = signal.cont2discrete(
        (A, B, np.array([[1.0, 0, 0, 0]]), np.zeros((1, 1))), 1 / fs
    )
    t = np.arange(20000) / fs
    rng = np.random.default_rng(0)
    u_id = rng.normal(size=t.size)
    _, y_id, _ = signal.dlsim((*sysd[:4], 1 / fs), u_id)
    model = arx(u_id, y_id[:, 0] * 1e3, 4, 4, 1, fs=fs)  # millimetres
    for u_ref in (np.sign(np.sin(2 * np.pi * 0.5 * t)), np.sin(2 * np.pi * 3.0 * t)):
        _, y, _ = signal.dlsim((*sysd[:4], 1 / fs), u_ref)
        u_hat = reconstruct_input(model, y[:, 0] * 1e3)
        # the inverse starts from rest while the record's offset is removed: a start-up
        # transient rings through the lightly damped zeros (|z| = 0.995) for seconds
        err = u_hat[2000:-5] - u_ref[2000:-5]
        assert np.sqrt(np.mean(err**2)) < 1e-3 * np.sqrt(np.mean(u_ref**2))
    with pytest.raises(ModelError, match="ARX"):
        reconstruct_input(model.__class__("ar", fs, {"na": 1}), y[:, 0])


@pytest.mark.real_data
def test_channel_to_channel_on_the_f16_matches_the_transmissibility(require_data):
    # F-16 ground vibration test: the ARX between two accelerometers against the
    # nonparametric transmissibility H1(force -> acc3) / H1(force -> acc2)
    from pdmkit.ensembles import read_mat

    d = read_mat(require_data("f16_gvt") / "F16Data_FullMSine_Level1.mat")
    fs = float(np.squeeze(d["Fs"]))
    force = np.asarray(d["Force"], float).ravel()
    acc = np.asarray(d["Acceleration"], float)
    q = 4  # 400 -> 100 Hz, the band of the modes (2-15 Hz)
    force, a2, a3 = (signal.decimate(x, q, ftype="fir") for x in (force, acc[1], acc[2]))
    m = channel_to_channel(a2, a3, fs=fs / q, orders=range(10, 31, 4))
    h2 = frf_estimate(force, a2, fs / q, nperseg=2048, fmin=3.0, fmax=12.0)
    h3 = frf_estimate(force, a3, fs / q, nperseg=2048, fmin=3.0, fmax=12.0)
    ok = (h2.coherence > 0.9) & (h3.coherence > 0.9)
    trans = h3.H[ok] / h2.H[ok]
    err_db = np.abs(20 * np.log10(np.abs(m.frequency_response(h2.freq[ok]) / trans)))
    assert ok.sum() > 100
    assert np.median(err_db) < 1.5
