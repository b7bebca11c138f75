"""Mass-beam rig of Khatkhate, Ray & Keller (2007, section 3)."""

import numpy as np
import pytest
from scipy.integrate import quad

from pdmkit.errors import ModelError
from pdmkit.models.rigs._massbeam import MassBeamRig


def test_resonances_of_khatkhate_section_3():
    """Section 3.1: 73.3 rad/s (system 1), 28.9 and 87.8 rad/s (system 2)."""
    w = MassBeamRig().resonances()
    # system 1 from table 1 alone (steel beam 800 x 25.4 x 12.7 mm, m3 = 2.2 kg)
    assert w[0] == pytest.approx(73.3, rel=0.005)
    # system 2 with the documented effective masses
    assert w[1] == pytest.approx(28.9, rel=0.002)
    assert w[2] == pytest.approx(87.8, rel=0.002)


def test_system1_stiffness_is_castigliano_formula():
    rig = MassBeamRig()
    # eq. (2) by direct numerical integration of the strain energy of eq. (1)
    L4, L5, EI = rig.L4, rig.L5, rig.E4I4
    U = quad(lambda z: (L5 - z) ** 2, 0, L4)[0] / (2 * EI)  # per F^2
    assert rig.stiffness1() == pytest.approx(1 / (2 * U), rel=1e-10)


def _unit_load_deflection(rig, x_force, x_obs):
    """Euler-Bernoulli deflection of the composite cantilever by Mohr's integral."""
    L1, L2 = rig.L1, rig.L2

    def inv_EI(x):
        if x < L1:
            return 1 / rig.E1I1
        if x < L1 + L2:
            return 0.0  # rigid mass m1
        return 1 / rig.E3I3

    upper = min(x_force, x_obs)
    pts = [p for p in (L1, L1 + L2) if p < upper]
    return quad(
        lambda x: (x_force - x) * (x_obs - x) * inv_EI(x), 0, upper, points=pts or None
    )[0]


@pytest.mark.parametrize("L2", [0.0, 0.12])
def test_flexibility_matrix_matches_beam_theory(L2):
    rig = MassBeamRig().with_params(L2=L2)
    x1 = rig.L1 + rig.L2 / 2  # centre of m1
    x2 = rig.L1 + rig.L2 + rig.L3  # tip of beam 2
    ref = np.array(
        [
            [_unit_load_deflection(rig, x1, x1), _unit_load_deflection(rig, x2, x1)],
            [_unit_load_deflection(rig, x1, x2), _unit_load_deflection(rig, x2, x2)],
        ]
    )
    assert np.allclose(rig.flexibility2(), ref, rtol=1e-8)


def test_state_space_and_receptance_consistent():
    rig = MassBeamRig()
    A, B, C, _D = rig.system2()
    # static gain -C A^-1 B equals the flexibility column of the tip force
    static = (-C @ np.linalg.solve(A, B)).ravel()
    assert np.allclose(static, rig.flexibility2()[:, 1], rtol=1e-10)
    w = np.array([20.0, 28.9, 60.0, 87.8, 110.0])
    H = np.abs(rig.frequency_response(w, damping=0.02))
    # lightly damped peaks at both resonances of system 2, and at 73 rad/s of system 1
    for row in H[1:]:
        assert row[1] > 5 * max(row[0], row[2]) and row[3] > 2 * max(row[2], row[4])
    H1 = np.abs(rig.frequency_response(np.array([60.0, 73.15, 85.0]), damping=0.02)[0])
    assert H1[1] > 5 * max(H1[0], H1[2])
    assert rig.to_pandas()["w_sys2_high"] == pytest.approx(87.8, rel=0.002)


def test_crack_softening_lowers_resonance_and_bad_params_rejected():
    rig = MassBeamRig()
    soft = rig.with_params(E1I1=0.9 * rig.E1I1)
    assert all(
        a < b for a, b in zip(soft.resonances()[1:], rig.resonances()[1:], strict=True)
    )
    with pytest.raises(ModelError, match="m3"):
        MassBeamRig(m3=-1.0)


def test_identified_frf_recovers_physical_resonances_khatkhate_section_4():
    """Khatkhate et al., section 4: FRF measured on the rig, rational z-domain fit
    (invfreqz, 2 ms sampling), poles compared with the physical model's resonances."""
    import scipy.signal as ss

    from pdmkit.models.frequency import balanced_truncation, fit_tf, frf_estimate

    rig = MassBeamRig()
    A, B, C, D = rig.system2()
    # light proportional damping (2 %), as frequency_response(damping=...) uses
    K = -A[1::2, 0::2]
    lam, V = np.linalg.eig(K)
    A = A.copy()
    A[1::2, 1::2] = -(V @ np.diag(0.04 * np.sqrt(lam.real)) @ np.linalg.inv(V)).real
    dt = 0.002
    Ad, Bd, Cd, Dd, _ = ss.cont2discrete((A, B, C[1:], D[1:]), dt, method="zoh")
    rng = np.random.default_rng(0)
    force = rng.normal(size=2**16)
    _, y, _ = ss.dlsim((Ad, Bd, Cd, Dd, dt), force)
    y = y[:, 0] + 0.01 * np.std(y) * rng.normal(size=force.size)
    frf = frf_estimate(force, y, 1 / dt, nperseg=4096, fmin=1.0, fmax=25.0)
    fit = fit_tf(frf.freq, frf.H, nb=4, na=4, domain="z", fs=1 / dt, weight=frf.coherence)
    wn = np.sort(np.abs(np.log(fit.poles.astype(complex)) / dt))[::2]
    assert np.allclose(wn, rig.resonances()[1:], rtol=0.01)
    # balanced reduction of the physical model to one mode keeps the dominant one
    red = balanced_truncation((A, B, C[1:], D[1:]), order=2)
    assert np.abs(red.poles[0]) == pytest.approx(rig.resonances()[1], rel=0.02)


# ---------------------------------------------------------------- beam FE, fatigue
def test_fe_cantilever_matches_euler_bernoulli_closed_form():
    """Uniform cantilever: w_k = (beta_k L)^2 sqrt(EI / (rho A L^4)) with beta_k L =
    1.87510, 4.69409, 7.85476 (roots of 1 + cos x cosh x = 0)."""
    from scipy.optimize import brentq

    from pdmkit.models.rigs import beam_fe_modes

    EI, rA, L = 200e9 * 25.4e-3 * 12.7e-3**3 / 12, 7850 * 25.4e-3 * 12.7e-3, 0.8
    roots = [
        brentq(lambda x: 1 + np.cos(x) * np.cosh(x), a, b)
        for a, b in [(1, 3), (4, 6), (7, 9)]
    ]
    ref = np.array(roots) ** 2 * np.sqrt(EI / (rA * L**4))
    assert np.allclose(beam_fe_modes([(EI, rA, L)], n_modes=3), ref, rtol=1e-4)


def test_fe_cantilever_with_tip_mass_matches_frequency_equation():
    """Cantilever with a tip mass M (mass ratio mu = M / (rho A L)): the exact frequency
    equation 1 + cos x cosh x + mu x (cos x sinh x - sin x cosh x) = 0, w = x^2
    sqrt(EI / (rho A L^4)) (Blevins, Formulas for natural frequency, table 8-8)."""
    from scipy.optimize import brentq

    from pdmkit.models.rigs import beam_fe_modes

    EI, rA, L, M = 1.0, 1.0, 1.0, 0.7
    mu = M / (rA * L)

    def eq(x):
        return (
            1
            + np.cos(x) * np.cosh(x)
            + mu * x * (np.cos(x) * np.sinh(x) - np.sin(x) * np.cosh(x))
        )

    x1 = brentq(eq, 0.5, 2.0)
    x2 = brentq(eq, 3.0, 5.0)
    fe = beam_fe_modes([(EI, rA, L)], {0: M}, n_modes=2)
    assert np.allclose(fe, [x1**2, x2**2], rtol=1e-4)
    # two segments in series are the same beam cut in two
    two = beam_fe_modes(
        [(EI, rA, L / 2), (EI, rA, L / 2)], {1: M}, n_elements=12, n_modes=2
    )
    assert np.allclose(two, fe, rtol=1e-4)


def test_distributed_mass_moves_system2_modes():
    """With the beams' mass (FE) and table 1's masses the upper mode lands near the
    paper's 87.8 rad/s; lumping the beams away (rho -> 0) gives the eq.-8 model back."""
    rig = MassBeamRig()
    fe = rig.distributed_resonances()
    assert fe[1] == pytest.approx(87.8, rel=0.02)
    light = rig.with_params(m1=1.0, m2=0.615)
    near_massless = light.distributed_resonances(rho1=0.1, rho3=0.1)  # 26 mg of beam
    assert np.allclose(near_massless, light.resonances()[1:], rtol=1e-3)


def test_linear_record_amplitude_matches_the_frf():
    """Without the crack's breathing, noise and drift, the steady sine amplitude is
    F0 / |k - m w^2 + j c w| (single-degree-of-freedom closed form)."""
    rig = MassBeamRig()
    k = 0.97 * rig.stiffness1()
    x = rig.vibration_record(
        k,
        breathing=False,
        duration=20.0,
        force_noise=0,
        force_drift=0,
        sensor_noise=0,
        rng=0,
    )
    w = 2 * np.pi * 11.39
    c = 2 * 0.01 * np.sqrt(rig.stiffness1() * rig.m3)
    ref = 8.5 / abs(k - rig.m3 * w**2 + 1j * c * w)
    assert np.max(np.abs(x)) == pytest.approx(ref, rel=0.01)


def test_breathing_crack_oscillates_at_the_bilinear_frequency():
    """Free vibration of a bilinear oscillator: half a cycle at each stiffness, so its
    period is pi / w1 + pi / w2 (Chati, Rand & Mukherjee 1997)."""
    from pdmkit.models.rigs._massbeam import _bilinear_rk4

    m, k1, k2, fs = 2.0, 8000.0, 12000.0, 2000.0
    force = np.zeros((1, 4000))
    force[0, :2] = 2000.0  # a short kick, then free vibration
    x = _bilinear_rk4(force, np.array([k1]), np.array([k2]), m, 0.0, fs, substeps=4)[0]
    up = np.nonzero((x[:-1] <= 0) & (x[1:] > 0))[0]
    period = np.mean(np.diff(up)) / fs
    ref = np.pi / np.sqrt(k1 / m) + np.pi / np.sqrt(k2 / m)
    assert period == pytest.approx(ref, rel=0.01)
    assert x[x > 0].max() > -x[x < 0].min()  # the softer side swings further


def test_fatigue_run_softens_to_failure_at_the_set_life():
    run = MassBeamRig().fatigue_run(n_files=6, file_minutes=5.0, record_seconds=4.0, rng=1)
    loss = run.stiffness_loss
    assert np.all(np.diff(loss) > 0) and loss[0] > 0
    assert np.all(np.diff(run.amplitude) > 0)  # the resonance moves toward 11.39 Hz
    assert run.curve["time_min"].iloc[-1] == pytest.approx(40.0)
    assert run.curve["stiffness_loss"].iloc[-1] > 0.3  # broken at the end
    # the crack accelerates: the last 10 % of life grows it more than the first half
    c = run.curve
    first = np.interp(20.0, c["time_min"], c["crack_mm"]) - c["crack_mm"].iloc[0]
    last = c["crack_mm"].iloc[-1] - np.interp(36.0, c["time_min"], c["crack_mm"])
    assert last > first
    assert run.records.shape == (6, 2000)
    assert list(run.to_pandas().columns)[:3] == ["time_min", "crack_mm", "stiffness"]
    with pytest.raises(ModelError, match="life_minutes"):
        MassBeamRig().fatigue_run(n_files=30)
