"""Motor + gearbox rig of the fractional-calculus paper: paths, records and their ETFE."""

import numpy as np
import pytest
import scipy.signal as ss

from pdmkit.errors import DataError, ModelError
from pdmkit.models.rigs import MOTOR_CONDITIONS, MotorGearboxRig

W = np.linspace(100.0, 1000.0, 60)


def test_integer_order_elements_match_scipy_transfer_functions():
    """With integer orders the stage and the motor are rational: scipy.signal.freqs."""
    rig = MotorGearboxRig(mesh_order=1.0, gamma=1.0)
    s = 1j * W
    w0, z = rig.stage_w[1], rig.stage_zeta
    c = 2 * z / w0  # c_k = 2 zeta w^-mu with mu = 1
    _, ref = ss.freqs([c, 1.0], [1 / w0**2, c, 1.0], worN=W)
    assert np.allclose(rig.stage(s, 1), ref, rtol=1e-12)
    _, ref_m = ss.freqs([-rig.Ke], np.polymul([rig.J, rig.b], [rig.L, rig.R]), worN=W)
    assert np.allclose(rig.motor_admittance(s), ref_m, rtol=1e-12)


def test_fractional_stage_matches_grunwald_letnikov_simulation():
    """The stage's frequency response (s^0.5 evaluated on j omega) against a
    time-domain Grunwald-Letnikov simulation of the same fractional equation."""
    from pdmkit.models.frequency import gl_simulate

    rig = MotorGearboxRig(mesh_order=0.5)
    w0 = rig.stage_w[2]
    c = 2 * rig.stage_zeta * w0**-0.5
    dt = 2e-5
    t = np.arange(0, 0.4, dt)
    for w in (0.6 * w0, w0, 1.5 * w0):
        u = np.sin(w * t)
        y = gl_simulate(u, dt, [1 / w0**2, c, 1.0], [2.0, 0.5, 0.0], [c, 1.0], [0.5, 0.0])
        late = t > 0.2  # transient (and the slow fractional memory) has settled
        # amplitude and phase of the steady state by projection on sin / cos
        X = np.column_stack([np.sin(w * t[late]), np.cos(w * t[late])])
        (a, b), *_ = np.linalg.lstsq(X, y[late], rcond=None)
        G = rig.stage(np.array([1j * w]), 2)[0]
        assert abs(complex(a, b)) == pytest.approx(abs(G), rel=0.02)
        assert np.angle(complex(a, b)) == pytest.approx(np.angle(G), abs=0.03)


def test_paths_follow_the_paper_transmission_description():
    """Gear 4 reaches the accelerometer directly and the current through all stages;
    the normal source the other way round: their EETFs differ by prod S_k^2."""
    rig = MotorGearboxRig()
    s = 1j * W
    C0, A0 = rig.paths(W, 0)
    C3, A3 = rig.paths(W, 3)
    prod = np.prod([rig.stage(s, k) for k in range(3)], axis=0)
    assert np.allclose(A3, rig.housing(s))
    assert np.allclose(C0, rig.motor_admittance(s))
    assert np.allclose((C3 / A3) / (C0 / A0), prod**2, rtol=1e-10)
    G = {c: rig.eetf(W, c) for c in MOTOR_CONDITIONS}
    names = list(G)
    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            assert np.max(np.abs(G[a] / G[b] - 1)) > 0.2, (a, b)


@pytest.mark.parametrize("condition", ["normal", "gear3"])
def test_record_etfe_estimates_the_rig_transfer_function(condition):
    """H1 of a noise-free record (no speed or stiffness spread) equals C_p / A_p."""
    rig = MotorGearboxRig()
    rec = rig.simulate(
        condition, duration=8.0, rng=1, stiffness_spread=0.0, noise=0.0, speed_spread=0.0
    )
    f, H = rec.etfe(method="h1", moving_average=1)
    G = rig.eetf(2 * np.pi * f, condition)
    err = np.abs(H / G - 1)
    assert np.median(err) < 0.05
    assert rec.to_pandas().shape == (rec.current.size, 3)
    assert rec.condition == condition


def test_records_vary_and_inputs_are_checked():
    rig = MotorGearboxRig()
    a = rig.simulate("gear2", duration=1.0, rng=0)
    b = rig.simulate("gear2", duration=1.0, rng=1)
    assert a.speed_hz != b.speed_hz and not np.allclose(a.current, b.current)
    with pytest.raises(DataError, match="condition"):
        rig.simulate("gear9")
    with pytest.raises(ModelError, match="stage_zeta"):
        MotorGearboxRig(stage_zeta=-1.0)
    with pytest.raises(ModelError, match="method"):
        a.etfe(method="welch")
    with pytest.raises(DataError, match="segment"):
        a.etfe(segment=5.0)
    assert rig.to_pandas()["teeth"] == [18, 9, 27, 36]
