"""Mass-beam rig of seed 002 section 3 (Khatkhate, Ray & Keller 2007)."""

import numpy as np
import pytest
from scipy.integrate import quad

from pdmkit.errors import ModelError
from pdmkit.models.rigs._massbeam import MassBeamRig


def test_resonances_of_seed_002_section_3():
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


def test_identified_frf_recovers_physical_resonances_seed_002_section_4():
    """Seed 002 section 4: FRF measured on the rig, rational z-domain fit (invfreqz,
    2 ms sampling), poles compared with the physical model's resonances."""
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
