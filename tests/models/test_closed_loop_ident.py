"""The unstable ballbot and identification in closed loop, against independent references.

References: the closed-form unstable pole and its inverted-pendulum limit ``sqrt(g/l)``;
the equations of motion derived afresh by sympy from the Lagrangian; python-control's
``feedback`` for the closed loop; scipy's ``cont2discrete`` for a known unstable plant;
the EMPS benchmark's published mass and friction (real data).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal
from threadpoolctl import threadpool_limits

from pdmkit.errors import DataError, ModelError
from pdmkit.models.ident import (
    ClosedLoopModel,
    KnownController,
    closed_loop_frf,
    direct_identification,
    indirect_identification,
    joint_identification,
)
from pdmkit.models.rigs import BallbotRig, chirp_reference


@pytest.fixture(autouse=True)
def _one_blas_thread():
    """Small matrices: BLAS threads only slow them down (a lot on a busy machine)."""
    with threadpool_limits(1, user_api="blas"):
        yield


def test_unstable_pole_closed_form_and_the_pendulum_limit():
    bare = BallbotRig(drive_damping=0.0, rolling_damping=0.0, drive_coulomb=0.0)
    assert bare.linearize().poles.real.max() == pytest.approx(
        bare.unstable_pole(), rel=1e-10
    )
    # a ball that cannot move (huge inertia) under a point body: the inverted pendulum
    m, l = 80.0, 0.45
    pend = bare.with_params(
        ball_inertia=1e12, body_mass=m, com_height=l, body_inertia=m * l**2 * (1 + 1e-9)
    )
    assert pend.linearize().poles.real.max() == pytest.approx(math.sqrt(9.81 / l), rel=1e-6)


def test_linearisation_matches_a_sympy_lagrangian_derivation():
    sp = pytest.importorskip("sympy")
    rig = BallbotRig()
    t = sp.symbols("t")
    psi, th = sp.Function("psi")(t), sp.Function("theta")(t)
    mb, mB, r, l, Ib, Th, g = sp.symbols("m_b m_B r l I_b Theta g", positive=True)
    b, bpsi, tau = sp.symbols("b b_psi tau")
    x = r * psi  # rolling without slip
    vx = sp.diff(x + l * sp.sin(th), t)
    vz = sp.diff(l * sp.cos(th), t)
    # Theta is the body's inertia about the ball centre: I_B = Theta - m_B l^2
    T = (
        mb * sp.diff(x, t) ** 2
        + Ib * sp.diff(psi, t) ** 2
        + mB * (vx**2 + vz**2)
        + (Th - mB * l**2) * sp.diff(th, t) ** 2
    ) / 2
    V = mB * g * l * sp.cos(th)
    Lag = T - V
    rel = sp.diff(psi, t) - sp.diff(th, t)
    Q = [tau - b * rel - bpsi * sp.diff(psi, t), -tau + b * rel]
    eqs = [
        sp.diff(sp.diff(Lag, sp.diff(q, t)), t) - sp.diff(Lag, q) - Qi
        for q, Qi in zip((psi, th), Q, strict=True)
    ]
    acc = sp.solve(eqs, [sp.diff(psi, t, 2), sp.diff(th, t, 2)], dict=True)[0]
    q1, q2, w1, w2, u = sp.symbols("q1 q2 w1 w2 u")
    subs = {sp.diff(psi, t): w1, sp.diff(th, t): w2, psi: q1, th: q2, tau: u}
    f = [w1, w2] + [acc[sp.diff(q, t, 2)].subs(subs) for q in (psi, th)]
    f = [sp.sympify(e).subs(subs) for e in f]
    values = {
        mb: rig.ball_mass,
        mB: rig.body_mass,
        r: rig.ball_radius,
        l: rig.com_height,
        Ib: rig.ball_inertia,
        Th: rig.body_inertia,
        g: rig.gravity,
        b: rig.drive_damping,
        bpsi: rig.rolling_damping,
    }
    state = [q1, q2, w1, w2]
    at0 = dict.fromkeys([*state, u], 0)
    A = np.array([[float(sp.diff(e, s).subs(values).subs(at0)) for s in state] for e in f])
    B = np.array([[float(sp.diff(e, u).subs(values).subs(at0))] for e in f])
    lin = rig.linearize()
    np.testing.assert_allclose(lin.A, A, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(lin.B, B, rtol=1e-10, atol=1e-12)


def test_closed_loop_response_matches_python_control_feedback():
    control = pytest.importorskip("control")
    rig = BallbotRig()
    ctl = rig.controller()
    Ad, Bd = rig.discrete_plant()
    dt = 1 / rig.fs
    plant = control.ss(Ad, Bd, np.eye(4, 5), np.zeros((4, 1)), dt)
    delay = control.ss([[0.0]], [[1.0]], [[1.0]], [[0.0]], dt)  # z^-1
    gain = control.ss([], [], [], ctl.K[None, :], dt)
    loop = control.feedback(plant, delay * gain, sign=-1) * ctl.N
    f = np.array([0.3, 1.0, 3.0, 8.0])
    ref = np.array([loop(np.exp(2j * np.pi * fi * dt))[1, 0] for fi in f])
    np.testing.assert_allclose(rig.tilt_response(f, ctl), ref, rtol=1e-9)
    # and the stabilised loop is stable: every pole inside the unit circle
    assert np.max(np.abs(loop.poles())) < 1.0


def _unstable_loop(seed=0, n=6000, fs=50.0, a=3.0, noise=1e-3):
    """A ZOH-sampled 1/(s^2 - a^2) under a PD controller read one sample late."""
    (bz,), az, _ = signal.cont2discrete(([1.0], [1.0, 0.0, -(a**2)]), 1 / fs)
    kp, kd, N = 40.0, 8.0, 30.0
    taps = [[0.0, kp + kd * fs, -kd * fs]]  # u = N r - (kp y + kd dy/dt)[k - 1]
    rng = np.random.default_rng(seed)
    r = rng.normal(size=n)
    e = noise * rng.normal(size=n)
    y = np.zeros(n)
    u = np.zeros(n)
    x = np.zeros(2)  # direct-form state of the plant
    for k in range(n):
        y_true = (
            bz[1] * u[k - 1] + bz[2] * u[k - 2] - az[1] * x[0] - az[2] * x[1]
            if k > 1
            else 0.0
        )
        x = np.array([y_true, x[0]])
        y[k] = y_true + e[k]
        u[k] = N * r[k] - sum(taps[0][j] * y[k - j] for j in range(3) if k - j >= 0)
    return r, u, y, fs, KnownController(feedback=taps, feedforward=N), (bz, az)


def test_indirect_and_joint_recover_an_unstable_plant():
    r, u, y, fs, ctl, (bz, az) = _unstable_loop()
    assert np.max(np.abs(ctl.apply(r, y) - u)) < 1e-9  # the controller is the one used
    true_pole = 3.0
    f = np.linspace(0.2, 5.0, 25)
    _, G = signal.freqz(bz, az, worN=f, fs=fs)
    for model in (
        indirect_identification(r, y, fs, ctl),
        joint_identification(r, u, y, fs),
    ):
        assert isinstance(model, ClosedLoopModel)
        assert model.unstable_poles[0] == pytest.approx(true_pole, rel=0.02)
        err_db = np.abs(20 * np.log10(np.abs(model.frequency_response(f)[:, 0] / G)))
        assert np.median(err_db) < 0.3 and np.max(err_db) < 1.0
    direct = direct_identification(u, y, fs, order=2)  # white output noise: ARX biased
    assert direct.to_pandas().shape[1] == 4
    frf = closed_loop_frf(r, u, y, fs, nperseg=512, fmin=0.2, fmax=5.0)
    _, G2 = signal.freqz(bz, az, worN=frf.freq, fs=fs)
    assert np.median(np.abs(20 * np.log10(np.abs(frf.H / G2)))) < 0.5


def test_known_controller_checks():
    with pytest.raises(ModelError, match="feedforward is zero"):
        KnownController(feedback=[1.0], feedforward=0.0)
    r, _u, y, fs, ctl, _ = _unstable_loop(n=400)
    with pytest.raises(DataError, match="feeds back 1 outputs"):
        indirect_identification(r, np.c_[y, y], fs, ctl)


def test_ballbot_runs_in_closed_loop_and_reports_saturation():
    rig = BallbotRig()
    rec = rig.simulate(chirp_reference([1.5, 5.0], duration=20.48), seed=1)
    assert rec.states.shape == (2, 2048, 4)
    assert np.degrees(np.abs(rec.theta)).max() < 15  # stabilised
    assert rec.saturated[0] == 0.0 and rec.saturated[1] > 0.0  # 5 deg hits the limit
    with pytest.raises(ModelError, match="fell over"):
        rig.with_params(torque_limit=5.0).simulate(chirp_reference([5.0], duration=20.0))


@pytest.mark.real_data
def test_emps_indirect_identification_finds_the_published_mass(require_data):
    # EMPS, measured in closed loop: vir = kv (kp (qg - qm) - dqm/dt); the published
    # rigid-body model (Janot, Gautier & Brunot 2019) has M = 95.1 kg, Fv = 203.5 N s/m
    from pdmkit.ensembles import load_emps
    from pdmkit.models.frequency import FRF, fit_frf_params

    require_data("emps")
    e = load_emps()
    fs, kp, kv, gtau = e["fs"], e["kp"], e["kv"], e["gtau"]
    ctl = KnownController(feedback=[[kv * kp + kv * fs, -kv * fs]], feedforward=kv * kp)
    explained = 1 - np.var(e["vir"] - ctl.apply(e["qg"], e["qm"])) / np.var(e["vir"])
    assert explained > 0.99  # the file's gains are the controller that ran
    f = np.linspace(0.5, 20.0, 100)

    def rigid(omega, M, Fv):
        return gtau / (M * (1j * omega) ** 2 + Fv * 1j * omega)

    def mass_friction(model):
        fit = fit_frf_params(
            rigid, {"M": 50.0, "Fv": 100.0}, FRF(f, model.frequency_response(f)[:, 0])
        )
        return fit.params["M"], fit.params["Fv"]

    M, Fv = mass_friction(indirect_identification(e["qg"], e["qm"], fs, ctl))
    assert M == pytest.approx(95.1, rel=0.05) and Fv == pytest.approx(203.5, rel=0.10)
    # the direct estimate's viscous friction is far off: the feedback biases it
    _, Fv_direct = mass_friction(direct_identification(e["vir"], e["qm"], fs, nk=1))
    assert abs(Fv_direct / 203.5 - 1) > 0.3
