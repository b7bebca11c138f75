"""Physical behaviour of the pneumatic piston twin (Voronin's thesis, chapters 3, 4 and 8).

References are independent of the code under test: closed forms (outflow function,
critical ratio, static equilibria) re-derived here, and scipy root finders / optimisers.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import optimize

from pdmkit.errors import ModelError
from pdmkit.models import (
    PneumaticParams,
    initial_state,
    orifice_mass_flow,
    outflow_function,
    piston_rhs,
    simulate_piston,
    stack_params,
)

KAPPA = 1.4
R_GAS = 287.1
T0 = 293.15


def textbook_psi(r, kappa=KAPPA):
    """Outflow function written out from Beater / ISO 6358 (no laminar blend)."""
    r = np.asarray(r, dtype=float)
    beta = (2 / (kappa + 1)) ** (kappa / (kappa - 1))
    rr = np.maximum(r, beta)
    return np.sqrt(kappa / (kappa - 1) * (rr ** (2 / kappa) - rr ** ((kappa + 1) / kappa)))


def series(c1, c2):
    return c1 * c2 / math.sqrt(c1**2 + c2**2)


@pytest.fixture(scope="module")
def healthy():
    """A 4 s recording (two full up/down cycles) of the default piston."""
    return simulate_piston(PneumaticParams(), t_end=4.0, sensors=False)


# ------------------------------------------------------------------ outflow function
def test_critical_ratio_is_the_maximum_of_the_subsonic_law() -> None:
    # the textbook subsonic bracket peaks at the critical ratio (2/(k+1))^(k/(k-1))
    f = lambda r: -(r ** (2 / KAPPA) - r ** ((KAPPA + 1) / KAPPA))  # noqa: E731
    res = optimize.minimize_scalar(
        f, bounds=(0.1, 0.99), method="bounded", options={"xatol": 1e-10}
    )
    assert res.x == pytest.approx(0.528, abs=5e-4)
    psi_max = math.sqrt(KAPPA / (KAPPA - 1) * -res.fun)
    assert psi_max == pytest.approx(0.484, abs=5e-4)  # seed eq. 4.15
    assert outflow_function(0.3) == pytest.approx(psi_max, rel=1e-6)


def test_outflow_function_choked_below_0528_and_textbook_above() -> None:
    choked = np.linspace(0.01, 0.527, 50)
    psi = outflow_function(choked)
    assert np.ptp(psi) < 1e-12  # independent of the downstream pressure
    sub = np.linspace(0.53, 0.985, 50)
    assert np.allclose(outflow_function(sub), textbook_psi(sub), rtol=1e-9)
    # the laminar blend: zero at equal pressures, monotone, continuous at the blend point
    near = np.linspace(0.985, 1.0, 200)
    vals = outflow_function(near)
    assert vals[-1] == 0.0 and np.all(np.diff(vals) < 0)
    assert outflow_function(0.99 + 1e-9) == pytest.approx(textbook_psi(0.99), rel=1e-6)


def test_orifice_mass_flow_choked_and_reversible() -> None:
    c, p_up = 2e-6, 6e5
    expected = c * p_up * math.sqrt(2 / (R_GAS * T0)) * textbook_psi(0.2)  # seed 4.13
    downs = np.array([0.5e5, 1e5, 2e5, 3e5, 3.15e5])  # all ratios < 0.528
    flows = orifice_mass_flow(c, p_up, downs)
    assert np.allclose(flows, expected, rtol=1e-9)
    # subcritical: less than choked; swapping the sides reverses the flow
    assert orifice_mass_flow(c, p_up, 4e5) < expected
    assert orifice_mass_flow(c, 4e5, p_up) == pytest.approx(
        -orifice_mass_flow(c, p_up, 4e5)
    )
    with pytest.raises(ModelError, match="pressure_ratio"):
        outflow_function(1.5)


def test_chamber_inflow_is_choked_in_a_simulation() -> None:
    # a fast spool, 10 kHz output: while p_A / p_r < 0.528 the mean inflow over each
    # sample equals C_eff p_r sqrt(2/(R T)) psi_max, whatever p_A is
    p = PneumaticParams(valve_time_constant=1e-5)
    r = simulate_piston(p, t_end=0.14, fs=1e4, dt=1e-4, sensors=False)
    pa, pr = r.states["pressure_a"][0], r.states["pressure_supply"][0]
    m_a = r.signals["mass_flow_a"][0]
    c_eff = series(p.c_a_in, p.c_throttle_max * p.throttle_a / 10 + p.c_check_valve)
    choked_flow = c_eff * pr * math.sqrt(2 / (R_GAS * T0)) * textbook_psi(0.1)
    # samples k: the mean over (t_k-1, t_k]; compare with pressures at t_k-1
    open_ = (r.time[1:] > 0.1105) & (pa[:-1] / pr[:-1] < 0.5)
    assert open_.sum() >= 5
    ratio = m_a[1:][open_] / choked_flow[:-1][open_]
    assert np.allclose(ratio, 1.0, atol=0.02)
    assert pa[:-1][open_].max() / pa[:-1][open_].min() > 1.5  # p_A varied meanwhile
    later = (r.time[1:] > 0.1105) & (pa[:-1] / pr[:-1] > 0.7)
    assert np.all(m_a[1:][later] < 0.95 * choked_flow[:-1][later])


# ------------------------------------------------------------------ motion and pressures
def test_piston_reaches_both_ends_without_deep_penetration(healthy) -> None:
    p = healthy.params
    x = healthy.states["position"][0]
    assert x.max() >= p.stroke - 1e-3 and x.min() <= 1e-3
    assert x.max() - p.stroke < 0.2e-3 and x.min() > -0.2e-3
    # five strokes up and down in a 10 s recording: count top arrivals in 4 s -> 2
    top = x > p.stroke - 1e-3
    assert np.count_nonzero(np.diff(top.astype(int)) == 1) == 2


def test_heavy_load_penetrates_the_stops_little() -> None:
    # 6.75 kg arriving at about 1.1 m/s: the stop (2e6 N/m) yields < 1.25 mm (the
    # LSODA solution peaks at 0.86 mm)
    p = PneumaticParams(mass_load=6.25)
    x = simulate_piston(p, t_end=2.2, sensors=False).states["position"][0]
    assert x.max() >= p.stroke - 1e-3 and x.min() <= 1e-3
    assert x.max() - p.stroke < 1.25e-3 and x.min() > -1.25e-3


def test_rest_position_is_the_static_equilibrium() -> None:
    # at rest on the bottom stop the stop and both dampers carry (p_s - p_0) S_B + m g
    for load in (0.0, 6.25):
        p = PneumaticParams(mass_load=load)
        s_b = math.pi / 4 * (p.bore**2 - p.rod_diameter**2)
        f = (p.p_supply - p.p_ambient) * s_b + (p.mass_piston + load) * p.gravity
        pre = p.damper_large_stiffness * p.damper_large_travel + (
            p.damper_small_stiffness * p.damper_small_travel
        )
        k = p.stop_stiffness + p.damper_large_stiffness + p.damper_small_stiffness
        y0 = np.asarray(initial_state(p))
        assert y0[0] == pytest.approx(-(f - pre) / k, rel=1e-9)
        assert abs(piston_rhs(0.0, y0, p)[1]) < 1e-6  # no acceleration


def test_pressures_reach_supply_and_ambient(healthy) -> None:
    p = healthy.params
    t = healthy.time
    pa, pb = healthy.states["pressure_a"][0], healthy.states["pressure_b"][0]
    top = (t > 0.95) & (t < 1.1)  # dwell at the top (valve up since 0.11 s)
    bottom = (t > 1.95) & (t < 2.1)  # dwell at the bottom
    assert np.all(np.abs(pa[top] / p.p_supply - 1) < 0.05)
    assert np.all(np.abs(pb[top] / p.p_ambient - 1) < 0.05)
    assert np.all(np.abs(pb[bottom] / p.p_supply - 1) < 0.05)
    assert np.all(np.abs(pa[bottom] / p.p_ambient - 1) < 0.05)


def test_supply_reservoir_dips_while_a_chamber_fills(healthy) -> None:
    p = healthy.params
    pr = healthy.states["pressure_supply"][0]
    t = healthy.time
    dip = p.p_supply - pr[(t > 0.11) & (t < 0.6)].min()
    assert 0.05e5 < dip < 1e5  # visible, not a collapse
    assert pr[(t > 1.0) & (t < 1.1)].mean() == pytest.approx(p.p_supply, rel=2e-3)


def _leak_balance(p: PneumaticParams, c_leak: float):
    """Steady reservoir and chamber-B pressures with the valve down and a B leak."""
    kt = math.sqrt(2 / (R_GAS * T0))

    def q(c, p1, p2):
        return c * p1 * kt * textbook_psi(p2 / p1)

    c_in = series(p.c_b_in, p.c_throttle_max * p.throttle_b / 10 + p.c_check_valve)

    def reservoir(pb):  # reservoir pressure at which refill equals the flow into B
        return optimize.brentq(
            lambda pr: q(p.c_supply, p.p_supply, pr) - q(c_in, pr, pb),
            pb,
            p.p_supply,
            xtol=1e-6,
        )

    pb = optimize.brentq(
        lambda pb: q(c_in, reservoir(pb), pb) - q(c_leak, pb, p.p_ambient),
        p.p_ambient + 1.0,
        p.p_supply - 1.0,
        xtol=1e-6,
    )
    return reservoir(pb), pb


def test_leak_lowers_chamber_b_pressure() -> None:
    base = PneumaticParams()
    r = simulate_piston(
        stack_params([base.replace(c_leak_b=1e-10), base.replace(c_leak_b=1e-6)]),
        t_end=2.1,
        sensors=False,
    )
    pb = r.states["pressure_b"]
    # seed fig. 8.8: the leak lowers chamber-B pressure, on average and at the stroke end
    # (at the end by > 0.1 bar: B refills through the throttle and the open check valve)
    assert pb[1].mean() < pb[0].mean() - 0.2e5
    end = (r.time > 2.0) & (r.time < 2.1)  # down stroke finished, B pressurised
    assert pb[1, end].mean() < pb[0, end].mean() - 0.1e5
    # and the steady pressure is the orifice balance supply -> B -> ambient (8.1, 8.2)
    pr_ss, pb_ss = _leak_balance(base, 1e-6)
    assert pb[1, end][-1] == pytest.approx(pb_ss, rel=5e-3)
    assert r.states["pressure_supply"][1, end][-1] == pytest.approx(pr_ss, rel=5e-3)


def test_fault_settings_change_the_stroke_time() -> None:
    base = PneumaticParams()
    settings = [
        {},
        {"throttle_b": 1.0},  # throttle valve 2 nearly closed: B exhausts slowly
        {"mass_load": 6.25},
        {"damper_upper": 10.0},  # stiff upper damper: slow final approach
    ]
    r = simulate_piston(
        stack_params([base.replace(**s) for s in settings]), t_end=1.1, sensors=False
    )
    x = r.states["position"]
    arrival = np.array([r.time[np.argmax(row > base.stroke - 1e-3)] for row in x])
    assert arrival[1] > arrival[0] + 0.1
    assert arrival[2] > arrival[0]
    assert arrival[3] > arrival[0] + 0.01


# ------------------------------------------------------------------ parameters
def test_params_reject_unknown_and_out_of_range_values() -> None:
    p = PneumaticParams()
    with pytest.raises(ModelError, match="did you mean 'throttle_b'"):
        p.replace(throtle_b=2.0)
    with pytest.raises(ModelError, match=r"throttle_a must be <= 10"):
        p.replace(throttle_a=11.0)
    with pytest.raises(ModelError, match="bore must be > 0"):
        PneumaticParams(bore=-0.01)
    with pytest.raises(ModelError, match="rod_diameter"):
        PneumaticParams(rod_diameter=0.03)
    with pytest.raises(ModelError, match="same length"):
        PneumaticParams(mass_load=[0.0, 1.25], throttle_a=[1.0, 2.0, 3.0])
    with pytest.raises(ModelError, match="shared by all members"):
        PneumaticParams(frame_mass=[1.0, 2.0])
    with pytest.raises(TypeError):
        PneumaticParams(not_a_parameter=1.0)


def test_stack_params_and_member_round_trip() -> None:
    members = [PneumaticParams(), PneumaticParams(mass_load=5.0, c_leak_b=1e-7)]
    batch = stack_params(members)
    assert batch.n_members == 2
    assert isinstance(batch.throttle_a, float)  # equal values stay scalar
    assert batch.member(1) == members[1]
    with pytest.raises(ModelError, match="already batched"):
        stack_params([batch])
