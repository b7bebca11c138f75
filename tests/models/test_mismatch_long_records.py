"""Long records (issue 13): pieces, decimation, the time budget, and EMPS at 1 kHz.

The references are independent of the fitting code: a whole simulation for the pieces
(cut the same trajectory, start each piece from the true state there: the outputs must
be the same numbers), scipy for the block means of decimation, and the EMPS data set
with the IDIM-LS friction values its authors publish (Janot, Gautier, Brunot, *Data set
and reference models of EMPS*, 2019: Fc = 20.4 N, Fv = 203.5 N s/m, M = 95.1 kg).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.io import loadmat

from pdmkit.models.mismatch import (
    choose_pieces,
    decimate,
    discover_mismatch,
    generate_concealed_case,
    make_recording,
)
from pdmkit.models.mismatch._fit_problem import _lm, _make_jobs, _Problem
from pdmkit.models.ode import integrate_batch, load_model_file, showcase_model, simulate_ode


def _msd_record(n=20000, ts=0.01, seed=0, k=350.0):
    msd = showcase_model("mass_spring_damper")
    t = np.arange(n) * ts
    F = np.repeat(np.random.default_rng(seed).normal(0, 40, n // 25 + 1), 25)[:n]
    r = simulate_ode(msd, t, {"F": F}, params={"k": k})
    return msd, t, F, r


def test_pieces_reproduce_the_whole_simulation_from_its_own_states():
    msd, t, F, r = _msd_record(n=3000)
    starts, length = np.array([0, 700, 1900]), 600
    X = np.stack([r.states[s][0] for s in msd.state_names], 1)  # (N, nx)
    P = dict(msd.params) | {"k": 350.0}
    y, _ = integrate_batch(
        msd,
        [],
        [],
        [],
        t,
        {"F": F},
        P,
        X[starts][None],
        1,
        _np(),
        segments=(starts, length),
    )
    idx = (starts[:, None] + np.arange(length)).ravel()
    np.testing.assert_allclose(y[0, :, 0], r.outputs["x"][0][idx], rtol=1e-10, atol=1e-12)


def _np():
    from pdmkit.models.ode._simulate import _NP

    return _NP


def test_a_long_record_is_fitted_in_pieces_and_the_parameter_recovered():
    msd, t, F, r = _msd_record(n=20000)
    y = r.outputs["x"][0] + np.random.default_rng(1).normal(0, 1e-4, t.size)
    rec = make_recording(msd, {"time": t, "F": F, "x": y})
    values = {"p:" + k: v for k, v in msd.params.items()} | {"x0:x": 0.0, "x0:v": 0.0}
    starts, length = choose_pieces(msd, rec, rec.n, values, 1)
    assert len(starts) > 1 and len(starts) * length <= 16000 and starts[0] == 0
    problem = _Problem(msd, rec, rec.n, np.array([1.0 / np.std(y)]), 1, starts, length)
    jobs = _make_jobs(msd, (), None, [{}], values, {"x": float(np.std(y)), "v": 1.0})
    _lm(problem, jobs, 60)
    assert jobs[0].x0.shape == (len(starts), 2)
    assert abs(jobs[0].values()["p:k"] / 350.0 - 1) < 1e-3


def test_a_model_that_reads_the_clock_is_fitted_whole():
    msd, t, F, r = _msd_record(n=5000)
    clocked = msd.__class__(
        msd.states,
        msd.inputs,
        msd.outputs,
        msd.params,
        lambda tt, x, u, p: {
            "x": x["v"],
            "v": (u["F"] * (1 + 0.1 * np.sin(tt)) - p["c"] * x["v"] - p["k"] * x["x"])
            / p["m"],
        },
        free=msd.free,
        initial=msd.initial,
    )
    rec = make_recording(clocked, {"time": t, "F": F, "x": r.outputs["x"][0]})
    values = {"p:" + k: v for k, v in msd.params.items()} | {"x0:x": 0.0, "x0:v": 0.0}
    assert choose_pieces(clocked, rec, rec.n, values, 1) is None


def test_a_model_that_integrates_is_fitted_in_pieces_from_a_shorter_record():
    """A position driven by a force (a pole at zero, as the EMPS axis open loop) drifts
    without bound in a free-run fit: 2000 samples are cut into pieces, while the
    spring-loaded mass (all poles stable) of the same length is fitted whole."""
    msd, t, F, r = _msd_record(n=2000)
    values = {"p:" + k: v for k, v in msd.params.items()} | {"x0:x": 0.0, "x0:v": 0.0}
    rec = make_recording(msd, {"time": t, "F": F, "x": r.outputs["x"][0]})
    assert choose_pieces(msd, rec, rec.n, values, 1) is None
    free_mass = msd.__class__(
        msd.states,
        msd.inputs,
        msd.outputs,
        msd.params,
        lambda tt, x, u, p: {"x": x["v"], "v": (u["F"] - p["c"] * x["v"]) / p["m"]},
        free=msd.free,
        initial=msd.initial,
    )
    starts, length = choose_pieces(free_mass, rec, rec.n, values, 1)
    # the decaying mode c/m = 4 1/s: five time constants are 125 samples, so the
    # pieces have the shortest length allowed and cover the record
    assert length == 400 and len(starts) == 5 and starts[-1] + length == rec.n
    short = make_recording(
        msd, {"time": t[:900], "F": F[:900], "x": r.outputs["x"][0][:900]}
    )
    assert choose_pieces(free_mass, short, short.n, values, 1) is None


def test_decimate_holds_block_means_of_held_inputs_and_samples_outputs():
    msd, t, F, r = _msd_record(n=1000, ts=0.001)
    rec = make_recording(msd, {"time": t, "F": F, "x": r.outputs["x"][0]})
    d = decimate(rec, 10)
    assert d.ts == pytest.approx(0.01) and d.n == 100
    np.testing.assert_allclose(d.inputs["F"], F.reshape(-1, 10).mean(axis=1))
    np.testing.assert_array_equal(d.outputs["x"], r.outputs["x"][0][::10])


def test_the_time_budget_returns_the_best_verdict_so_far_marked_so():
    case = generate_concealed_case("coulomb_friction", 0.3, seed=1, n_samples=1500)
    with pytest.warns(RuntimeWarning, match="time budget"):
        res = discover_mismatch(case.model, case.data, max_seconds=0.5)
    assert res.verdict["budget"]["reached"] is True
    assert res.verdict["budget"]["max_seconds"] == 0.5
    with pytest.raises(ValueError, match="max_seconds"):
        discover_mismatch(case.model, case.data, max_seconds=0)


def test_asymmetric_viscous_friction_is_named_and_fitted():
    case = generate_concealed_case("asymmetric_friction", 0.3, seed=3, n_samples=1200)
    res = discover_mismatch(case.model, case.data)
    assert (res.verdict["effect"], res.verdict["target"]) == ("asymmetric_friction", "v")
    assert res.verdict["params"]["d"] == pytest.approx(case.params["d"], rel=0.05)


EMPS_MODEL = """
STATES = {"q": "position", "v": "velocity"}
INPUTS = {"F": "force"}
OUTPUTS = ["q"]
PARAMS = {"M": 95.0, "Fv": 200.0}
FREE = ["M", "Fv"]
INITIAL = {"q": 0.0, "v": 0.0}

def rhs(t, x, u, p):
    return {"q": x["v"], "v": (u["F"] - p["Fv"] * x["v"]) / p["M"]}
"""


def _emps(path):
    mat = loadmat(path)
    col = {k: np.asarray(mat[k], dtype=float).ravel() for k in ("t", "vir", "qm")}
    gtau = float(np.asarray(mat["gtau"]).ravel()[0])
    return {"time": col["t"] - col["t"][0], "F": gtau * col["vir"], "q": col["qm"]}


@pytest.mark.slow
def test_emps_at_1khz_names_coulomb_friction_with_the_published_force(
    require_data, tmp_path
):
    root = require_data("emps")
    model_file = tmp_path / "emps.py"
    model_file.write_text(EMPS_MODEL)
    model = load_model_file(model_file)
    est = _emps(root / "DATA_EMPS.mat")
    val = _emps(root / "DATA_EMPS_PULSES.mat")
    res = discover_mismatch(model, est, val, input_hold="zoh")
    assert res.fit["decimated"] > 1  # 1 kHz for a 2 Hz pole: pdmkit thins it itself
    found = {res.verdict["effect"]: res.verdict["params"]}
    found |= {a["effect"]: a["params"] for a in res.verdict.get("also", [])}
    assert "coulomb_friction" in found, res.verdict
    mass = res.augmented_values["p:M"]
    fc = found["coulomb_friction"]["a"] * mass  # per unit mass -> N
    assert abs(fc / 20.4 - 1) < 0.25, fc
    # an integrator, fitted in pieces; the pulses record simulated whole from its
    # first samples: issue 13 asks 4 mm (the description's IDIM structure, Coulomb
    # and an offset, gives about 5 mm open loop)
    assert res.fit["pieces"] is not None
    assert res.fit["rmse_augmented"] < 4e-3
    assert res.fit["rmse_augmented"] < 0.15 * res.fit["rmse_nominal"]


def test_pieces_see_a_dead_time_that_reaches_before_their_start():
    from pdmkit.models.mismatch import attach_candidates
    from pdmkit.models.mismatch._candidates import _dummy_scales

    msd, t, F, _ = _msd_record(n=3000)
    dead = next(e for e in attach_candidates(msd, _dummy_scales(msd), ["dead_time"]))
    theta = [{"tau": np.array([0.37, 0.0])}]  # row 0 delayed 37 samples, row 1 not
    masks = [np.array([True, False])]
    P = dict(msd.params)
    x0 = np.zeros((2, 2))
    whole, X = integrate_batch(
        msd, [dead], theta, masks, t, {"F": F}, P, x0, 1, _np(), True
    )
    starts, length = np.array([0, 1000, 2300]), 500
    x0p = np.stack([X[:, starts, :][b] for b in range(2)])  # (2, K, nx) true states
    y, _ = integrate_batch(
        msd, [dead], theta, masks, t, {"F": F}, P, x0p, 1, _np(), segments=(starts, length)
    )
    idx = (starts[:, None] + np.arange(length)).ravel()
    np.testing.assert_allclose(y[:, :, 0], whole[:, idx, 0], rtol=1e-9, atol=1e-12)


def test_a_users_own_candidate_is_tried_and_can_be_the_verdict():
    from types import MappingProxyType

    from pdmkit.models.mismatch import Candidate, ParamSpec

    class Duffing(Candidate):  # the user's name for a cubic spring
        id = "my_duffing"
        attach = "velocity_position"
        param_names = ("k3",)
        neutral = MappingProxyType({"k3": 0.0})
        start_neutral = True
        physics = "My cubic spring on {partner} (k3 = {k3})."

        def specs(self, eff, sc):
            k = sc.f_scale(eff.target) / sc.x_scale(eff.partner) ** 3
            return {"k3": ParamSpec("k3", -1e3 * k, 1e3 * k, False, k)}

        def guesses(self, eff, sc):
            return [{"k3": 0.0}]

        def derivs(self, xp, eff, th, t, x, u, dx):
            dx[eff.target] = dx[eff.target] - th["k3"] * x[eff.partner] ** 3
            return dx

    case = generate_concealed_case("cubic_stiffness", 0.3, seed=0, n_samples=1200)
    res = discover_mismatch(
        case.model, case.data, effects=["viscous_friction"], candidates=[Duffing()]
    )
    assert (res.verdict["effect"], res.verdict["target"]) == ("my_duffing", "v")
    assert res.verdict["params"]["k3"] == pytest.approx(case.params["k3"], rel=0.05)
    with pytest.raises(ValueError, match="not a usable candidate"):
        discover_mismatch(case.model, case.data, candidates=["cubic"])
