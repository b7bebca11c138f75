"""One-way flow control valves on lines A and B, and the flow meter of line A.

The throttle valves 1 and 2 of the seed's rig (section 3.1, table 3.2) are modelled as
one-way flow control valves in meter-out orientation: a line exhausts through its
throttle alone and fills through the throttle and an open check valve in parallel (so
the seed's re-estimated coefficients C_in and C_out of a line differ, table 4.2). The
references below are hand calculations from the seed's orifice law (4.13, 4.16) and
chamber equations (4.25, 4.26), not the code under test.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pdmkit.models import PneumaticParams, SensorSpec, simulate_piston, stack_params

R_GAS = 287.1
T0 = 293.15
PSI_MAX = (2 / 2.4) ** (1 / 0.4) * math.sqrt(1.4 / 2.4)  # seed eq. 4.15, 0.484
RHO_STD = 1e5 / (R_GAS * 293.15)  # standard (ANR) density of the flow meter's l/min
FLOWS = ("FlowExtrusion", "FlowContraction")


def series(c1, c2):
    return c1 * c2 / math.sqrt(c1**2 + c2**2)


def meter_out_speed(c_eff, area):
    """Steady piston speed with a choked exhaust: p S v = R T m, m = C p k psi_max.

    The chamber pressure cancels: v = C psi_max sqrt(2 R T) / S (seed 4.13, 4.26 with
    dp/dt = 0).
    """
    return c_eff * PSI_MAX * math.sqrt(2 * R_GAS * T0) / area


@pytest.fixture(scope="module")
def runs():
    """Healthy, throttle 2 closed to 2, throttle 1 closed to 2; noise-free meters."""
    p = stack_params(
        [
            PneumaticParams(),
            PneumaticParams(throttle_b=2.0),
            PneumaticParams(throttle_a=2.0),
        ]
    )
    specs = {name: SensorSpec() for name in FLOWS}
    return simulate_piston(p, t_end=2.1, sensors=list(FLOWS), sensor_specs=specs, seed=0)


def _mid_stroke(r, i, up: bool):
    x = r.states["position"][i]
    within = (x > 0.06) & (x < 0.10)
    half = (r.time > 0.1) & (r.time < 1.1) if up else r.time > 1.1
    return within & half


def test_throttle_2_sets_the_extension_speed_and_flow_meter_a_reads_it(runs) -> None:
    p = runs.params.member(1)
    s_a = math.pi / 4 * p.bore**2
    s_b = s_a - math.pi / 4 * p.rod_diameter**2
    up = _mid_stroke(runs, 1, up=True)
    assert up.sum() > 50
    # meter-out: chamber B exhausts through throttle 2 alone (choked), which sets v
    c_b = series(p.c_b_out, p.c_throttle_max * p.throttle_b / 10)
    v = runs.states["velocity"][1][up]
    assert np.allclose(v, meter_out_speed(c_b, s_b), rtol=0.02)
    # the meter on line A reads the air that fills the swept volume at chamber pressure
    pa = runs.states["pressure_a"][1][up]
    hand = pa / (R_GAS * T0) * s_a * v / RHO_STD * 60000.0  # standard l/min
    assert np.allclose(runs.outputs["FlowExtrusion"][1][up], hand, rtol=0.02)
    # so closing throttle 2 lowers the reading on line A with the speed (and density)
    mid0 = _mid_stroke(runs, 0, up=True)
    healthy = runs.outputs["FlowExtrusion"][0][mid0].mean()
    closed = runs.outputs["FlowExtrusion"][1][up].mean()
    pv0 = (runs.states["pressure_a"][0] * runs.states["velocity"][0])[mid0].mean()
    assert closed / healthy == pytest.approx((pa * v).mean() / pv0, rel=0.03)
    assert closed / healthy < 0.6


def test_throttle_1_sets_the_retraction_and_the_contraction_flow(runs) -> None:
    p = runs.params.member(2)
    s_a = math.pi / 4 * p.bore**2
    dn = _mid_stroke(runs, 2, up=False)
    assert dn.sum() > 50
    c_a = series(p.c_a_out, p.c_throttle_max * p.throttle_a / 10)
    v = runs.states["velocity"][2][dn]
    assert np.allclose(v, -meter_out_speed(c_a, s_a), rtol=0.02)
    # chamber A exhausts through throttle 1, choked (p_A > 1.9 p_0): seed 4.13
    pa = runs.states["pressure_a"][2][dn]
    assert np.all(pa / p.p_ambient > 1.0 / 0.528)
    m = c_a * pa * math.sqrt(2 / (R_GAS * T0)) * PSI_MAX
    hand = m / RHO_STD * 60000.0
    assert np.allclose(runs.outputs["FlowContraction"][2][dn], hand, rtol=0.01)
    # the filling direction bypasses the throttle: the up stroke hardly changes
    v_up = runs.states["velocity"][2][_mid_stroke(runs, 2, up=True)].mean()
    v_up0 = runs.states["velocity"][0][_mid_stroke(runs, 0, up=True)].mean()
    assert v_up == pytest.approx(v_up0, rel=0.02)


def test_a_two_way_throttle_slows_both_strokes() -> None:
    # c_check_valve = 0: both directions of line A throttled (the twin before the
    # one-way valves). Closing throttle 1 then slows the up stroke too, which the seed's
    # separate C_in / C_out per line (table 4.2) would not need; with the check valve
    # the up stroke keeps its speed (test above)
    base = PneumaticParams(c_check_valve=0.0)
    r = simulate_piston(
        stack_params([base, base.replace(throttle_a=2.0)]), t_end=1.1, sensors=False
    )
    v = [r.states["velocity"][i][_mid_stroke(r, i, up=True)].mean() for i in (0, 1)]
    assert v[1] / v[0] < 0.9
