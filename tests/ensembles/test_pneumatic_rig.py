"""The seed rig's machine in the seed's data set (``ensembles/_pneumatic_rig.py``).

Every value is checked against its source: the seed author's identified model
(``models/params.m`` of github.com/xvoron/thesis) or the rig's recordings.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from pdmkit.ensembles import Ensemble, simulate_seed_ensemble
from pdmkit.ensembles._pneumatic_rig import (
    SEED_RIG_LARGE_DAMPING_SCALE,
    SEED_RIG_PARAMS,
    SEED_SUPPLY_CODE_SPREAD,
)
from pdmkit.errors import DataError


def _series(c1: float, c2: float) -> float:
    return c1 * c2 / math.sqrt(c1 * c1 + c2 * c2)


def test_seed_rig_parameters_are_the_authors_params_m():
    p = SEED_RIG_PARAMS
    assert p["mass_piston"] == 6.7798462575453  # M [e]
    assert (p["bore"], p["rod_diameter"]) == (0.02, 0.008)  # d_A, d_S [c]
    assert p["stroke"] == 0.19382  # gp
    s_a = math.pi * 0.02**2 / 4
    s_b = s_a - math.pi * 0.008**2 / 4
    assert p["v_dead_a"] == pytest.approx(s_a * 0.015)  # V_0A
    assert p["v_dead_b"] == pytest.approx(s_b * 0.015)  # V_0B
    assert (p["damper_small_min"], p["damper_small_max"]) == (1082.6, 6760.2)
    assert p["damper_small_stiffness"] == 0.0  # k_small_* = 0
    # bot_damp_start 0.01054 and gp - up_damp_start (0.18123): their mean reach
    assert p["damper_small_travel"] == pytest.approx(
        (0.01054 + 0.19382 - 0.18123) / 2, abs=1e-4
    )
    assert p["proximity_distance"] == pytest.approx(0.19382 - 0.1925)  # prox_up_band
    assert SEED_RIG_LARGE_DAMPING_SCALE * 400.0 == pytest.approx(1400.0)  # b_large


def test_valve_and_throttle_in_series_give_the_identified_coefficients():
    p = SEED_RIG_PARAMS
    throttle = p["c_throttle_max"] * 5.0 / 10.0  # the knob at its mark
    # the rig's GRP throttles restrict both directions: no check valve beside them
    assert p["c_check_valve"] == 0.0
    identified = {  # params.m, healthy fault code 1100001
        "c_a_out": 5.155e-07,
        "c_b_out": 9.1476e-07,
        "c_a_in": 6.0242e-07,
        "c_b_in": 1.7518e-07,
    }
    for name, target in identified.items():
        assert _series(p[name], throttle) == pytest.approx(target, rel=0.01), name
    # and the twin computes them so
    from pdmkit.ensembles._pneumatic_rig import seed_rig_machine
    from pdmkit.models import PneumaticParams
    from pdmkit.models._xp import get_namespace
    from pdmkit.models.pneumatic._twin import _resolve

    params = PneumaticParams(**seed_rig_machine({}, 1))
    resolved = _resolve(params, get_namespace(np.zeros(1)))
    for name, target in identified.items():
        assert float(np.ravel(getattr(resolved, name))[0]) == pytest.approx(
            target, rel=0.01
        ), name


def test_seed_rig_ensemble_reaches_the_rigs_stop_and_its_supply_wanders_per_code():
    ens = simulate_seed_ensemble(
        40, repeats=2, t_end=3.0, signals=["LeverPosition"], batch_size=20
    )
    from pdmkit.ensembles._pneumatic_rig import _upper_stop_lowering

    x, _ = ens.stack("LeverPosition")
    codes = ens.conditions["fault_code"].str[2:].astype(int).to_numpy()
    at_mark = _upper_stop_lowering(codes, 0, 40) == 0  # the stop at its place
    assert 0.1925 < x[at_mark].max() <= SEED_RIG_PARAMS["stroke"] + 5e-4
    assert x[~at_mark].max() < 0.1925  # below the upper switch
    twin = simulate_seed_ensemble(
        40, repeats=2, t_end=3.0, signals=["LeverPosition"], batch_size=20, rig="twin"
    )
    assert twin.stack("LeverPosition")[0].max() == pytest.approx(0.16, abs=2e-3)
    # the set point in the conditions stays the operator's; a part of the design
    # records what the whole records
    assert set(ens.conditions["supply_bar"]) == {5.5, 6.0}
    part = simulate_seed_ensemble(
        40,
        repeats=2,
        t_end=3.0,
        signals=["LeverPosition"],
        batch_size=20,
        members=slice(20, 40),
    )
    np.testing.assert_array_equal(part.stack("LeverPosition")[0], x[20:])
    with pytest.raises(DataError, match="rig"):
        simulate_seed_ensemble(20, t_end=0.1, signals=["LeverPosition"], rig="bench")


def test_supply_wander_is_one_draw_per_code():
    from pdmkit.ensembles._pneumatic import _seed_design
    from pdmkit.ensembles._pneumatic_rig import _seed_rig_columns

    design = _seed_design(4840, 20, "rig", 0, jitter=0.0)
    params = [c for c in design.columns if c not in ("fault", "seed_label", "fault_code")]
    cols = {c: design[c].to_numpy(float) for c in params if c != "supply_bar"}
    codes = design["fault_code"].str[2:].astype(int).to_numpy()
    out = _seed_rig_columns(cols, codes, 0, 4840)
    ratio = (out["p_supply"] - 101325.0) / (cols["p_supply"] - 101325.0) - 1.0
    per_code = design.assign(r=ratio).groupby("fault_code")["r"].agg(["std", "mean"])
    assert per_code["std"].max() < 1e-12  # the repeats of a code share it
    assert per_code["mean"].std() == pytest.approx(SEED_SUPPLY_CODE_SPREAD, rel=0.4)
    # it drifts along the codes (recorded label by label), as the rig's reading does
    order = per_code["mean"].to_numpy()
    assert np.corrcoef(order[:-1], order[1:])[0, 1] > 0.3
    assert np.all(out["mass_piston"] == SEED_RIG_PARAMS["mass_piston"])


def test_the_rod_load_cell_reads_what_the_rigs_reads_at_both_ends():
    """The rig's load cell (``data11_1_1..3.mat``, 6.25 kg, 6 bar): -212.8 N at rest at
    the bottom (mean of 7-10 s over the three recordings), 85.8 N at rest at the top
    (3-5.9 s): 298.6 N apart. A cell under the frame reads the same weight at both."""
    from pdmkit.ensembles._pneumatic import SEED_TEST_CYCLE
    from pdmkit.ensembles._pneumatic_rig import seed_rig_machine
    from pdmkit.models import (
        PneumaticParams,
        SensorSpec,
        default_sensor_specs,
        simulate_piston,
    )

    cols = {"mass_load": 6.25, "p_supply": 1.01325e5 + 6e5, **SEED_TEST_CYCLE}
    p = PneumaticParams(**seed_rig_machine(cols, 1))
    spec = default_sensor_specs("seed_rig")["StrainGauge"]
    r = simulate_piston(
        p,
        t_end=10.0,
        sensors=["StrainGauge"],
        sensor_specs={"StrainGauge": spec.replace(noise_std=0.0, quantization=0.0)},
    )
    strain = r.outputs["StrainGauge"][0] * 1e-4  # N at the default strain_area
    t = r.time
    bottom = strain[(t > 7.0) & (t < 10.0)].mean()
    top = strain[(t > 3.0) & (t < 5.9)].mean()
    assert bottom == pytest.approx(-212.8, abs=10.0)
    assert top == pytest.approx(85.8, abs=20.0)
    assert top - bottom == pytest.approx(298.6, rel=0.1)
    assert isinstance(spec, SensorSpec) and spec.offset == pytest.approx(-5.8e5)


def test_residuals_are_taken_against_the_recordings_own_machine():
    from pdmkit.ensembles import (
        pneumatic_residuals,
        simulate_seed_single_fault_ensemble,
    )

    ens = simulate_seed_single_fault_ensemble(10, repeats=2, t_end=2.0, seed=1)
    assert set(ens.conditions["machine"]) == {"seed"}
    kw = dict(reference="nominal", nominal_point=(6.25, 6.0))
    own = pneumatic_residuals(ens, **kw).stack("LeverPosition_res")[0]
    seed = pneumatic_residuals(ens, rig="seed", **kw).stack("LeverPosition_res")[0]
    twin = pneumatic_residuals(ens, rig="twin", **kw).stack("LeverPosition_res")[0]
    np.testing.assert_array_equal(own, seed)
    # the healthy members against their own machine: millimetres less than against
    # the generic twin, whose lighter piston runs another course
    healthy = (ens.conditions["fault"] == "healthy").to_numpy()
    rms = lambda r: np.sqrt(np.mean(r[healthy] ** 2))  # noqa: E731
    assert rms(own) < 0.1 * rms(twin)
    conditions = ens.conditions.assign(machine=["twin"] + ["seed"] * (len(ens) - 1))
    mixed = Ensemble({"LeverPosition": ens.stack("LeverPosition")[0]}, 1000.0, conditions)
    with pytest.raises(DataError, match="several machines"):
        pneumatic_residuals(mixed, **kw)


def _design_codes(n_members: int = 4840):
    from pdmkit.ensembles._pneumatic import _seed_design

    design = _seed_design(n_members, 20, "rig", 0, jitter=0.0)
    return design, design["fault_code"].str[2:].astype(int).to_numpy()


def test_microphone_bias_wanders_per_code_as_the_rigs_does():
    """The rig's MICsFeaturesAll.mat in recording order: the 10 s means of a code's 20
    recordings share a bias that wanders from code to code (spread of the code means
    0.0028 / 0.0038 / 0.024 V, 45-200 times the spread within a code) and drifts
    (neighbours correlate 0.76-0.91); the three microphones move together (0.86-0.97)."""
    from pdmkit.ensembles._pneumatic_rig import SEED_MIC_BIAS, seed_rig_session_specs
    from pdmkit.models import default_sensor_specs

    design, codes = _design_codes()
    specs = seed_rig_session_specs(default_sensor_specs("seed_rig"), codes, 0, 4840)
    means = {}
    for name, (level, per_code) in SEED_MIC_BIAS.items():
        bias = design.assign(b=specs[name].offset).groupby("fault_code")["b"]
        assert bias.std().max() < 1e-12  # a code's recordings share it
        assert bias.mean().mean() == pytest.approx(level, abs=3 * per_code)
        assert bias.mean().std() == pytest.approx(per_code, rel=0.35)
        means[name] = bias.mean().to_numpy()
        assert np.corrcoef(means[name][:-1], means[name][1:])[0, 1] > 0.6
    assert np.corrcoef(means["MIC_uBumper"], means["MIC_Ambient"])[0, 1] > 0.85
    # the other sensors keep their scalar specs
    assert np.ndim(specs["FlowContraction"].offset) == 0
    # recorded, the bias shows in the microphones' mean as on the rig: a code's
    # recordings agree to the twin's noise, the codes differ by the bias
    ens = simulate_seed_ensemble(
        60, repeats=3, t_end=3.0, signals=["MIC_uBumper"], test_cycle="seed_rig"
    )
    mean = ens.stack("MIC_uBumper")[0].mean(axis=1)
    per_code = pd.Series(mean).groupby(ens.conditions["fault_code"].to_numpy())
    assert per_code.mean().std() > 5 * per_code.std().median()


def test_upper_stop_sits_lower_in_a_share_of_codes_and_the_switch_stays():
    """ProximityAllFeatures.mat in recording order: the first 27 and 17 codes of two
    sessions, every label among them, never switch the upper switch; the encoder's
    peak position there is 191.6 and 191.3 mm (medians) against 193.7 mm in the codes
    that switch (LeverPosition_LeverVelocity_stat_features.mat): the lever stopped
    short of the switch (192.55 mm) in those sessions."""
    from pdmkit.ensembles._pneumatic import SEED_TEST_CYCLE
    from pdmkit.ensembles._pneumatic_rig import (
        SEED_UPPER_STOP_LOWERED,
        _seed_rig_columns,
        seed_rig_machine,
        seed_rig_session_specs,
    )
    from pdmkit.models import PneumaticParams, default_sensor_specs, simulate_piston

    design, codes = _design_codes()
    params = [c for c in design.columns if c not in ("fault", "seed_label", "fault_code")]
    cols = {c: design[c].to_numpy(float) for c in params if c != "supply_bar"}
    out = _seed_rig_columns(cols, codes, 0, 4840)
    lowered = SEED_RIG_PARAMS["stroke"] - out["stroke"]
    per_code = design.assign(d=lowered).groupby("fault_code")["d"]
    assert per_code.std().max() < 1e-15  # a code's repeats share their session
    share = (per_code.mean() > 0).mean()
    assert share == pytest.approx(SEED_UPPER_STOP_LOWERED[0], abs=0.05)
    assert lowered[lowered > 0].min() >= 0.0020 and lowered.max() <= 0.0024
    specs = seed_rig_session_specs(default_sensor_specs("seed_rig"), codes, 0, 4840)
    np.testing.assert_allclose(specs["ProximitySensor_upper"].offset, -lowered, atol=1e-15)
    # the machine's stop goes with it whatever the acquisition; the microphones' bias
    # only with the rig's
    typical = seed_rig_session_specs(
        default_sensor_specs("typical"), codes, 0, 4840, microphones=False
    )
    np.testing.assert_array_equal(
        typical["ProximitySensor_upper"].offset, specs["ProximitySensor_upper"].offset
    )
    assert typical["MIC_uBumper"].offset == 0.0
    # one healthy lever at 6.25 kg, 6 bar, the rig's program: stop at its place and
    # 2 mm lower (the switch on the frame, 192.5 mm)
    low = float(lowered[lowered > 0][0])
    members = {
        "mass_load": np.array([6.25, 6.25]),
        "p_supply": np.full(2, 101325.0 + 6e5),
        "stroke": SEED_RIG_PARAMS["stroke"] - np.array([0.0, low]),
        **{k: np.full(2, v) for k, v in SEED_TEST_CYCLE.items()},
    }
    p = PneumaticParams(**{**seed_rig_machine(members, 2), "stroke": members["stroke"]})
    switch = default_sensor_specs("seed_rig")["ProximitySensor_upper"]
    r = simulate_piston(
        p,
        t_end=10.0,
        seed=0,
        sensors=["LeverPosition", "ProximitySensor_upper"],
        sensor_specs={
            "ProximitySensor_upper": switch.replace(offset=np.array([0.0, -low]))
        },
    )
    peak = r.outputs["LeverPosition"].max(axis=1)
    assert 0.1925 < peak[0] <= SEED_RIG_PARAMS["stroke"] + 1e-4
    # the rig: 191.3-191.6 mm; the twin rests 0.5-1 mm below its stop where the rig
    # rests on it (193.7 mm)
    assert 0.1900 < peak[1] < 0.1925
    on = r.outputs["ProximitySensor_upper"]
    assert on[0].max() == 1.0 and on[1].max() == 0.0


def test_the_machine_re_identified_from_the_rigs_recordings():
    """``identified="recordings"`` (issue 29, item 7): within 2 mm of the rig's lever."""
    from pathlib import Path

    from pdmkit.ensembles._pneumatic import SEED_TEST_CYCLE
    from pdmkit.ensembles._pneumatic_rig import (
        SEED_RIG_RECORDED_PARAMS,
        seed_rig_machine,
    )
    from pdmkit.models import PneumaticParams, simulate_piston

    m = seed_rig_machine({}, 2, identified="recordings")
    for key, value in SEED_RIG_RECORDED_PARAMS.items():
        assert np.all(m[key] == value), key
    assert seed_rig_machine({}, 1)["c_b_out"][0] == SEED_RIG_PARAMS["c_b_out"]
    with pytest.raises(DataError, match="identified"):
        seed_rig_machine({}, 1, identified="thesis")
    data = Path("/work/shared/data/pneumatic_rig/data11_1_1.csv")
    if not data.exists():
        pytest.skip("the rig's recordings are not on this machine")
    rig = pd.read_csv(data, usecols=["LeverPosition"])["LeverPosition"].to_numpy()
    cols = {"mass_load": 6.25, "p_supply": 1.01325e5 + 6e5, **SEED_TEST_CYCLE}
    cols["cycle_start"] = 0.999  # the recorded command's rising edge
    p = PneumaticParams(**seed_rig_machine(cols, 1, identified="recordings"))
    x = simulate_piston(p, t_end=10.0, sensors=False).states["position"][0]
    assert np.sqrt(np.mean((x - rig) ** 2)) < 2e-3
