"""Simulated ensembles of the pneumatic twin: labels, settings, leak paths, residuals."""

from __future__ import annotations

import numpy as np
import pytest

from pdmkit.ensembles import (
    PNEUMATIC_FAULTS,
    PNEUMATIC_SENSORS,
    fault_labels,
    pneumatic_residuals,
    simulate_fault_ensemble,
    simulate_leak_runs,
    simulate_sensor_fault_ensemble,
)
from pdmkit.errors import DataError
from pdmkit.models import SENSOR_NAMES


def test_fault_codes_are_the_seed_combinations():
    # seed 3.3: healthy, five single faults, and their combinations
    assert len(fault_labels(1)) == 6
    assert len(fault_labels(2)) == 1 + 5 + 10
    assert all(code == "+".join(sorted(code.split("+"))) for code in fault_labels(3))


def test_sensor_types_cover_every_twin_signal_once():
    owned = [s for signals in PNEUMATIC_SENSORS.values() for s in signals]
    assert sorted(owned) == sorted(SENSOR_NAMES)


def test_fault_settings_fall_in_their_ranges():
    ens = simulate_fault_ensemble(
        24,
        labels=["healthy", "throttle_1", "damper_upper+large_dampers"],
        t_end=0.3,
        signals=["LeverPosition"],
        seed=4,
    )
    cond = ens.conditions
    assert cond["fault"].value_counts().tolist() == [8, 8, 8]
    lo, hi = PNEUMATIC_FAULTS["throttle_1"].faulty[0]
    t1 = cond.loc[cond.fault == "throttle_1", "throttle_1"]
    assert t1.between(lo, hi).all()
    healthy_lo, healthy_hi = PNEUMATIC_FAULTS["throttle_1"].healthy
    assert (
        cond.loc[cond.fault == "healthy", "throttle_1"]
        .between(healthy_lo, healthy_hi)
        .all()
    )
    combo = cond[cond.fault == "damper_upper+large_dampers"]
    (soft_lo, soft_hi), (hard_lo, hard_hi) = PNEUMATIC_FAULTS["damper_upper"].faulty
    upper = combo["damper_upper"]
    assert (upper.between(soft_lo, soft_hi) | upper.between(hard_lo, hard_hi)).all()
    assert (
        combo["large_damper_damping"] <= PNEUMATIC_FAULTS["large_dampers"].faulty[0][1]
    ).all()
    assert set(cond["load_kg"]) <= {0.0, 1.25, 5.0, 6.25}
    assert set(cond["supply_bar"]) <= {5.0, 6.0}


def test_healthy_and_faulty_ranges_are_apart():
    # a fault is a setting clearly off the healthy one (no shared values), and the
    # faulty damping coefficients differ from the healthy ones by a factor of 1.5 or
    # more (small dampers map 1..10 log-linearly onto damper_small_min..max)
    from pdmkit.models import PneumaticParams

    p = PneumaticParams()

    def damping(setting):
        ratio = p.damper_small_max / p.damper_small_min
        return p.damper_small_min * ratio ** ((setting - 1.0) / 9.0)

    for code, setting in PNEUMATIC_FAULTS.items():
        lo, hi = setting.healthy
        for f_lo, f_hi in setting.faulty:
            assert f_hi < lo or f_lo > hi, code
            if code.startswith("damper_"):
                gap = max(damping(lo) / damping(f_hi), damping(f_lo) / damping(hi))
                assert gap >= 1.5, code


def test_operating_points_can_be_given():
    points = {"load_kg": [0.0, 6.25], "supply_bar": [5.0, 6.0]}
    ens = simulate_fault_ensemble(
        6,
        labels=["healthy"],
        t_end=0.2,
        signals=["AirPressure"],
        seed=2,
        operating_points=points,
    )
    pairs = sorted(map(tuple, ens.conditions[["load_kg", "supply_bar"]].to_numpy()))
    assert pairs == [(0.0, 5.0)] * 3 + [(6.25, 6.0)] * 3
    # the reservoir sensor reads the supply it was given (bar gauge), before the stroke
    x, _ = ens.stack("AirPressure")
    np.testing.assert_allclose(
        x[:, :50].mean(axis=1), ens.conditions["supply_bar"], atol=0.02
    )
    with pytest.raises(DataError, match="supply_bar"):
        simulate_fault_ensemble(2, t_end=0.2, operating_points={"load_kg": [1.0]})


def test_unknown_fault_code_is_named():
    with pytest.raises(DataError, match="throttle_3"):
        simulate_fault_ensemble(4, labels=["healthy", "throttle_3"], t_end=0.2)


def test_closed_throttle_slows_the_descent():
    # throttle valve 1 sits in line A: on the way down chamber A exhausts through it
    # (meter-out), so a nearly closed valve makes the descent slower than any healthy one
    ens = simulate_fault_ensemble(
        16, labels=["healthy", "throttle_1"], t_end=2.0, signals=["LeverPosition"], seed=0
    )
    x, _ = ens.stack("LeverPosition")
    after_down_command = x[:, 1100:]  # the valve is commanded down at 1.1 s
    t_half = np.argmax(after_down_command < 0.5 * x.max(), axis=1) / 1000.0
    faulty = (ens.conditions["fault"] == "throttle_1").to_numpy()
    assert t_half[faulty].min() > t_half[~faulty].max()


def test_leak_runs_grow_to_the_threshold():
    runs = simulate_leak_runs(3, max_cycles=8, t_end=0.2, signals=["AirPressure"], seed=1)
    cond = runs.conditions
    for _, unit in cond.groupby("unit"):
        leak = unit["c_leak"].to_numpy()
        assert np.all(np.diff(leak) > 0)
        assert leak[0] == pytest.approx(1e-10)
        assert leak[-1] >= 1e-6 > leak[-2]
        assert unit["rul"].tolist() == list(range(len(unit) - 1, -1, -1))
        assert unit["failed"].sum() == 1 and bool(unit["failed"].iloc[-1])


@pytest.mark.parametrize("shape", [4.0, 100.0])
def test_leak_walk_shape_sets_the_spread_of_the_steps(shape):
    # log C_al takes gamma-distributed steps: coefficient of variation 1 / sqrt(shape)
    runs = simulate_leak_runs(
        8, max_cycles=40, t_end=0.05, signals=["AirPressure"], seed=4, walk_shape=shape
    )
    cond = runs.conditions
    cvs = []
    for _, unit in cond.groupby("unit"):
        steps = np.diff(np.log(unit["c_leak"].to_numpy()))
        cvs.append(steps.std(ddof=1) / steps.mean())
    assert np.mean(cvs) == pytest.approx(1 / np.sqrt(shape), rel=0.25)


def test_leak_walk_shape_must_be_positive_and_finite():
    for bad in (0.0, -1.0, np.inf, "4"):
        with pytest.raises(ValueError, match="walk_shape"):
            simulate_leak_runs(1, max_cycles=4, t_end=0.05, walk_shape=bad)


def test_sensor_faults_change_only_what_they_say():
    ens = simulate_sensor_fault_ensemble(20, t_end=1.0, seed=3)
    x, _ = ens.stack("FlowExtrusion")
    kind = ens.conditions["sensor_fault"].to_numpy()
    lost = (x == 0.0).mean(axis=1)
    assert lost[kind == "loss"].min() > 0.5
    # a clean flow signal is exactly 0 only while the valve is closed to A; the
    # healthy and offset members are never read as lost this often
    assert lost[kind == "offset"].max() < 0.05


def test_residuals_of_nominal_members_are_small():
    ens = simulate_fault_ensemble(
        12, labels=["healthy", "throttle_1"], t_end=1.5, signals=["LeverPosition"], seed=5
    )
    res = pneumatic_residuals(ens)
    e, _ = res.stack("LeverPosition_res")
    rms = np.sqrt(np.mean(e**2, axis=1))
    faulty = (res.conditions["fault"] == "throttle_1").to_numpy()
    assert np.median(rms[faulty]) > 2 * np.median(rms[~faulty])


def test_residuals_need_the_operating_point():
    ens = simulate_fault_ensemble(2, t_end=0.2, signals=["LeverPosition"])
    bare = type(ens)({"LeverPosition": ens.stack("LeverPosition")[0]}, fs=1000.0)
    with pytest.raises(DataError, match="load_kg"):
        pneumatic_residuals(bare)
