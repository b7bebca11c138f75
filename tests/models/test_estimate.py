"""Parameter estimation of the pneumatic twin (seed 4.7): recovery, intervals, gradients."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy import stats

from pdmkit.errors import ConvergenceWarning, DataError, ModelError
from pdmkit.models import PneumaticParams, SensorSpec, initial_state, simulate_piston
from pdmkit.models._xp import get_namespace
from pdmkit.models.pneumatic import estimate_parameters
from pdmkit.models.pneumatic._estimate_inputs import _setup_problem
from pdmkit.models.pneumatic._estimate_problem import (
    _command_table,
    _readings,
    _run_windows,
)

SIX = ("c_a_in", "c_a_out", "c_b_in", "c_b_out", "damper_upper", "damper_bottom")
#: a member whose valves and dampers all differ from the defaults (5e-6 m^2, setting 5)
HIDDEN = PneumaticParams(
    c_a_in=6.5e-6,
    c_a_out=4.0e-6,
    c_b_in=5.5e-6,
    c_b_out=3.5e-6,
    damper_upper=7.0,
    damper_bottom=3.0,
)


def damper_coefficient(setting: float, p: PneumaticParams) -> float:
    """N s/m of a small damper: log-linear from b_min at setting 1 to b_max at 10."""
    b_min, b_max = p.damper_small_min, p.damper_small_max
    return b_min * (b_max / b_min) ** ((setting - 1.0) / 9.0)


@pytest.fixture(scope="module")
def hidden_recording():
    # one up and one down stroke with the default sensor noise and quantisation
    return simulate_piston(HIDDEN, t_end=1.6, seed=7)


@pytest.fixture(scope="module")
def up_stroke():
    truth = PneumaticParams(c_a_in=6.5e-6)
    return simulate_piston(
        truth, t_end=0.5, seed=3, sensors=["LeverPosition", "FlowExtrusion"]
    )


# ----------------------------------------------------------------------- the integrator
def test_window_integrator_reproduces_simulate_and_its_sensors() -> None:
    """The windowed stepper is simulate_piston()'s integrator, bit for bit in effect."""
    p = HIDDEN
    names = [
        "LeverPosition",
        "LeverVelocity",
        "AccelerometerMoving_axisZ",
        "FlowExtrusion",
        "FlowContraction",
        "AirPressure",
    ]
    ideal = {k: SensorSpec() for k in names}  # no noise, no quantisation
    ref = simulate_piston(p, t_end=0.4, sensors=names, sensor_specs=ideal, seed=0)
    h, n_sub, n = 2e-4, 5, 400
    u = _command_table(p, np.zeros(1), (n - 1) * n_sub, h)
    y0 = np.asarray(initial_state(p, 1))
    raw = _run_windows(p, y0, u, n, n_sub, h, get_namespace(1.0))
    for name in names:
        got = _readings(raw, name, p.p_ambient, 1000.0, get_namespace(1.0))[0, 1:]
        want = ref.outputs[name][0, 1:]
        scale = np.abs(want).max()
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-9 * scale, err_msg=name)


# ----------------------------------------------------------------------- recovery
@pytest.mark.slow
def test_recovers_hidden_valve_and_damper_coefficients(hidden_recording) -> None:
    res = estimate_parameters(hidden_recording, free=SIX, n_starts=4, seed=0)
    assert res.converged
    for k in SIX:
        truth = getattr(HIDDEN, k)
        assert abs(res.estimates[k] / truth - 1) < 0.05, (k, res.estimates[k], truth)
    # the damper coefficients b_up, b_bot (N s/m) themselves, not just the settings
    for k in ("damper_upper", "damper_bottom"):
        b_hat = damper_coefficient(res.estimates[k], HIDDEN)
        b_true = damper_coefficient(getattr(HIDDEN, k), HIDDEN)
        assert abs(b_hat / b_true - 1) < 0.05, (k, b_hat, b_true)
    # the intervals are informative and consistent with the error actually made:
    # every 99.9 % interval covers the truth, and the error's Mahalanobis length in
    # the reported covariance (log space) is a plausible chi2(6) draw
    table = res.to_pandas()
    assert (table["rel_halfwidth"] < 0.01).all()
    assert table["identifiable"].all()
    z_err = np.array([math.log(res.estimates[k] / getattr(HIDDEN, k)) for k in SIX])
    se_log = np.array([res.stderr[k] / res.estimates[k] for k in SIX])
    assert (np.abs(z_err / se_log) < stats.norm.ppf(0.9995)).all()
    corr = res.correlation.loc[list(SIX), list(SIX)].to_numpy()
    cov = corr * np.outer(se_log, se_log)
    d2 = float(z_err @ np.linalg.solve(cov, z_err))
    assert stats.chi2.ppf(0.001, 6) < d2 < stats.chi2.ppf(0.999, 6)
    # the weights the fit settled on are the sensors' noise levels (default specs)
    assert res.sigma["FlowExtrusion"] == pytest.approx(
        math.hypot(0.5, 0.1 / math.sqrt(12)), rel=0.1
    )
    assert res.sigma["LeverPosition"] == pytest.approx(7e-6 / math.sqrt(12), rel=0.2)


@pytest.mark.slow
def test_standard_error_matches_the_scatter_over_noise_realisations() -> None:
    """One parameter, five noise seeds: reported SE vs the spread of the estimates."""
    truth = PneumaticParams(c_a_in=6.5e-6)
    est, se, covered = [], [], 0
    for seed in range(5):
        rec = simulate_piston(truth, t_end=0.5, seed=seed, sensors=["FlowExtrusion"])
        res = estimate_parameters(
            rec, free=["c_a_in"], signals=["FlowExtrusion"], n_starts=1, max_windows=1
        )
        lo, hi = res.ci95["c_a_in"]
        covered += lo < truth.c_a_in < hi
        est.append(math.log(res.estimates["c_a_in"]))
        se.append(res.stderr["c_a_in"] / res.estimates["c_a_in"])
    spread = np.std(est, ddof=1)
    # with 4 degrees of freedom the sample sd lies within [0.35, 1.67] x sigma at 98 %
    lo_q = math.sqrt(stats.chi2.ppf(0.01, 4) / 4)
    hi_q = math.sqrt(stats.chi2.ppf(0.99, 4) / 4)
    assert lo_q * np.mean(se) < spread < hi_q * np.mean(se)
    assert covered >= 4  # of 5 nominal 95 % intervals (P(<= 3) = 2.3 %)


# ----------------------------------------------------------------------- gradients
@pytest.mark.slow
@pytest.mark.torch
def test_autograd_jacobian_and_cost_gradient_match_finite_differences(up_stroke) -> None:
    prob, _ = _setup_problem(
        up_stroke,
        ["c_a_in", "c_b_out", "damper_upper"],
        PneumaticParams(),
        ["LeverPosition", "FlowExtrusion"],
        None,
        0.24,  # from rest before the switch to the end of the upper damper's travel
        1,
        0,
        5e-4,  # two steps per sample keeps the torch pass short
    )
    z = prob.encode(np.array([6e-6, 4.5e-6, 6.0]))
    y0 = prob.window_states(z[None])  # (1, W, 6)
    r_ad, J_ad = prob.autograd_jacobian(z, y0[0], prob.n_sub_fine)

    def residuals(zz: np.ndarray) -> np.ndarray:
        Y = prob.predict(zz[None], y0, prob.n_sub_fine)
        return prob.residuals(Y)[0]

    np.testing.assert_allclose(r_ad, residuals(z), rtol=0, atol=1e-9)
    step = 1e-6
    for j in range(prob.p):
        e = np.zeros(prob.p)
        e[j] = step
        r_plus, r_minus = residuals(z + e), residuals(z - e)
        col = (r_plus - r_minus) / (2 * step)
        err = np.linalg.norm(J_ad[:, j] - col) / np.linalg.norm(col)
        assert err < 1e-4, (prob.names[j], err)
        # the cost gradient sum(r dr/dz) against central differences of the cost
        g_fd = (0.5 * r_plus @ r_plus - 0.5 * r_minus @ r_minus) / (2 * step)
        assert J_ad[:, j] @ r_ad == pytest.approx(g_fd, rel=1e-4)


# ----------------------------------------------------------------------- identifiability
def test_a_parameter_the_sensors_cannot_see_is_reported_unidentifiable(up_stroke) -> None:
    """C_B,in only acts while chamber B fills (down stroke): invisible in an up stroke."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        res = estimate_parameters(
            up_stroke,
            free=["c_a_in", "c_b_in"],
            signals=["FlowExtrusion"],
            n_starts=1,
            max_windows=1,
            max_iter=8,
        )
    table = res.to_pandas()
    assert bool(table.loc["c_a_in", "identifiable"])
    assert not bool(table.loc["c_b_in", "identifiable"])
    assert abs(res.estimates["c_a_in"] / 6.5e-6 - 1) < 0.05


# ----------------------------------------------------------------------- result object
def test_result_table_plot_history_and_convergence_warning(up_stroke) -> None:
    with pytest.warns(ConvergenceWarning, match="max_iter"):
        res = estimate_parameters(
            up_stroke,
            free=["c_a_in"],
            known=PneumaticParams(c_a_in=2e-6),
            signals=["FlowExtrusion"],
            n_starts=1,
            max_windows=1,
            max_iter=1,
        )
    assert not res.converged
    assert res.cost_history[-1] < res.cost_history[0]
    table = res.to_pandas()
    assert list(table.index) == ["c_a_in"]
    assert {"estimate", "stderr", "ci95_low", "ci95_high", "identifiable"} <= set(table)
    assert table.loc["c_a_in", "unit"] == "m^2"
    axes = res.plot()
    assert len(axes) == 1
    assert len(axes[0].lines) == 2  # measured and fitted
    assert res.params.c_a_in == res.estimates["c_a_in"]
    assert res.params.c_b_in == PneumaticParams().c_b_in


# ----------------------------------------------------------------------- bad input
def _mapping(rec, names):
    return {"fs": 1000.0, **{k: rec.outputs[k][0] for k in names}}


def test_unknown_free_parameter_is_named_with_a_suggestion(up_stroke) -> None:
    with pytest.raises(ModelError, match=r"'c_a_inn'.*did you mean 'c_a_in'"):
        estimate_parameters(up_stroke, free=["c_a_inn"], signals=["FlowExtrusion"])


@pytest.mark.parametrize(
    ("free", "match"),
    [
        (["mic_gain"], "only shapes sensor readings"),
        (["valve_delay"], "switching"),
        (["c_a_in", "c_a_in"], "twice"),
        ([], "empty"),
    ],
)
def test_unfittable_free_parameters_are_rejected(up_stroke, free, match) -> None:
    with pytest.raises(ModelError, match=match):
        estimate_parameters(up_stroke, free=free, signals=["FlowExtrusion"])


def test_recording_missing_a_signal_names_it(up_stroke) -> None:
    data = _mapping(up_stroke, ["LeverPosition", "FlowExtrusion"])
    with pytest.raises(DataError, match="'AirPressure' is missing"):
        estimate_parameters(data, free=["c_a_in"], signals=["LeverPosition", "AirPressure"])


def test_non_finite_samples_are_rejected(up_stroke) -> None:
    data = _mapping(up_stroke, ["LeverPosition", "FlowExtrusion"])
    data["FlowExtrusion"] = data["FlowExtrusion"].copy()
    data["FlowExtrusion"][[40, 41]] = np.nan
    with pytest.raises(DataError, match=r"'FlowExtrusion' has 2 non-finite.*index 40"):
        estimate_parameters(data, free=["c_a_in"], signals=["FlowExtrusion"])


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"signals": ["FlowExtrusio"]}, ModelError, "did you mean 'FlowExtrusion'"),
        ({"signals": ["MIC_uBumper"]}, ModelError, "cannot fit signal"),
        ({"bounds": {"c_b_in": (1e-6, 1e-5)}}, ModelError, "not in `free`"),
        ({"bounds": {"c_a_in": (2e-6, 1e-6)}}, ModelError, "low < high"),
        ({"bounds": {"damper_upper": (0.5, 9.0)}}, ModelError, "allowed range"),
        ({"dt": 3e-4}, ModelError, "whole number of steps"),
        ({"window": 2.0}, ModelError, "longer than"),
        ({"jacobian": "adjoint"}, ModelError, "'fd' or 'autograd'"),
        ({"known": PneumaticParams(c_a_in=np.ones(2) * 5e-6)}, ModelError, "scalar"),
    ],
)
def test_bad_settings_are_rejected(up_stroke, kwargs, error, match) -> None:
    args = {"free": ["c_a_in", "damper_upper"], "signals": ["FlowExtrusion"], **kwargs}
    with pytest.raises(error, match=match):
        estimate_parameters(up_stroke, **args)


def test_mapping_without_fs_and_2d_signals_are_rejected(up_stroke) -> None:
    data = _mapping(up_stroke, ["FlowExtrusion"])
    del data["fs"]
    with pytest.raises(DataError, match="'fs'"):
        estimate_parameters(data, free=["c_a_in"], signals=["FlowExtrusion"])
    data = {"fs": 1000.0, "FlowExtrusion": up_stroke.outputs["FlowExtrusion"]}
    with pytest.raises(DataError, match="1-D"):
        estimate_parameters(data, free=["c_a_in"], signals=["FlowExtrusion"])
