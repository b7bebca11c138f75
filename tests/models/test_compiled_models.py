"""Model files compiled with numba (models/ode/_compiled*.py; the fit: _fit_problem.py).

The translation of the source rig's model file in both styles (numpy and the thesis's
math/if) gives the function's own values; the compiled RK4 and ROS2 loops repeat the
numpy integrators; the compiled RK4 is checked against scipy's solve_ivp and against a
closed-form fall onto a hard stop; what is not translated runs as written and says why;
a fit's rows without a term on a derivative run compiled beside the others, unchanged.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.integrate import solve_ivp

from pdmkit.models.mismatch._candidates import _dummy_scales, attach_candidates
from pdmkit.models.mismatch._fit_problem import _lm, _make_jobs, _Problem
from pdmkit.models.mismatch._setup import prepare
from pdmkit.models.ode import OdeModel, load_model_file, simulate_ode
from pdmkit.models.ode._compiled import CompiledModelFunction
from pdmkit.models.ode._compiled_source import Untranslatable, translate
from pdmkit.models.ode._integrators import _rk4_records, _ros2_records, _stops

numba = pytest.importorskip(
    "numba", reason="numba is the 'fast' extra (pip install pdmkit[fast])"
)

RIG = Path(__file__).resolve().parents[2] / "examples" / "pneumatic_rig"


@pytest.fixture(autouse=True)
def _compile_at_once(monkeypatch, tmp_path_factory):
    monkeypatch.setenv("PDMKIT_COMPILE", "always")
    monkeypatch.setenv("PDMKIT_CACHE_DIR", str(tmp_path_factory.getbasetemp() / "compiled"))


def _rig_batch(n: int, seed: int = 0):
    """Members spread over the regimes: both valve positions and rest, near the stops."""
    rng = np.random.default_rng(seed)
    x = {
        "x": rng.uniform(-0.005, 0.2, n),
        "v": rng.normal(0.0, 0.3, n),
        "pA": rng.uniform(0.9e5, 7.2e5, n),
        "pB": rng.uniform(0.9e5, 7.2e5, n),
    }
    hp = rng.integers(0, 2, n).astype(float)
    wp = np.where(rng.random(n) < 0.2, hp, 1.0 - hp)  # some members with both equal
    return x, {"outValveHP": hp, "outValveWP": wp}


@pytest.mark.parametrize("name", ["model_numpy.py", "model_thesis.py"])
def test_both_styles_of_the_rig_file_compile_to_their_own_values(name):
    model = load_model_file(RIG / name)
    x, u = _rig_batch(400)
    p = {k: np.full(400, v) for k, v in model.params.items()}
    p["b_up"] = p["b_up"] * np.linspace(0.5, 2.0, 400)
    as_written = model.rhs.python(0.0, dict(x), dict(u), dict(p))
    compiled = model.rhs(0.0, dict(x), dict(u), dict(p))
    assert model.rhs.note.startswith("compiled"), model.rhs.note
    for k in model.state_names:
        np.testing.assert_allclose(compiled[k], as_written[k], rtol=1e-12, atol=1e-300)
    out = model.output_values(x, u, p)  # outputs(t, x, u, p) compiled the same way
    assert model.output_fn.note.startswith("compiled"), model.output_fn.note
    ref = model.output_fn.python(0.0, dict(x), dict(u), dict(p))
    for k in model.outputs:
        np.testing.assert_allclose(out[k], ref[k], rtol=1e-12, atol=1e-12)


def _valve_program(t):
    work = ((t >= 0.05) & (t < 1.0)).astype(float)  # up stroke, then down
    return np.stack([1.0 - work, work], axis=1)


@pytest.mark.parametrize("method", ["rk4", "ros2"])
def test_compiled_integrators_repeat_the_numpy_ones_on_the_rig(method):
    model = load_model_file(RIG / "model_numpy.py")
    f = model.rhs
    B, t = 3, np.arange(0.0, 1.2, 0.01)
    U = np.repeat(_valve_program(t)[None], B, axis=0)
    P = dict(model.params)
    P["C_A_in"] = P["C_A_in"] * np.array([0.8, 1.0, 1.25])
    Xl = [np.full(B, model.initial[s]) for s in model.state_names]
    f(0.0, dict(zip(model.state_names, Xl, strict=True)), {"outValveHP": U[:, 0, 0],
      "outValveWP": U[:, 0, 1]}, P)  # fmt: skip
    rec = f.simulate(method, Xl, U, P, t, 2, 0.005, False, model.limits)
    assert rec is not None, f.note

    def rhs(tt, X, Z, u):
        d = f.python(tt, dict(zip(model.state_names, X, strict=True)), u, P)
        return [np.broadcast_to(d[k], (B,)) for k in model.state_names], ()

    step = _rk4_records if method == "rk4" else _ros2_records
    ref, _ = step(rhs, Xl, [], U, t, model.input_names, t.size, 2, 0.005, "zoh",
                  _stops(model, np))  # fmt: skip
    want = np.stack([np.stack(xs, 1) for xs in ref], 1)
    scale = np.abs(want).max(axis=(0, 1))
    tol = 1e-9 if method == "rk4" else 1e-5  # ROS2: finite-difference Jacobians
    assert np.all(np.abs(rec - want) <= tol * scale)
    assert want[:, :, 0].max() > 0.15  # the lever went up


def _tank_model():
    def rhs(t, x, u, p):
        return {"h": (u["q"] - p["a"] * np.sqrt(np.maximum(x["h"], 0.0))) / p["A"]}

    return OdeModel({"h": "level"}, {"q": "flow"}, ["h"], {"a": 0.02, "A": 0.5}, rhs,
                    initial={"h": 0.3})  # fmt: skip


def test_compiled_rk4_against_scipy_solve_ivp():
    model = _tank_model().check()
    t = np.linspace(0.0, 40.0, 401)
    q = 0.01 + 0.005 * np.sin(0.3 * t)
    sim = simulate_ode(model, t, {"q": q}, n_sub=4, hold="foh")
    assert model.rhs.note.startswith("compiled")
    assert model.rhs.ran("rk4")  # the compiled loop ran

    def f(tt, h):  # the input on straight lines between samples, as hold="foh" says
        qq = np.interp(tt, t, q)
        return [(qq - 0.02 * math.sqrt(max(h[0], 0.0))) / 0.5]

    ref = solve_ivp(f, (0.0, 40.0), [0.3], t_eval=t, rtol=1e-10, atol=1e-12, max_step=0.1)
    np.testing.assert_allclose(sim.outputs["h"][0], ref.y[0], rtol=5e-7)  # RK45 at kinks


def test_compiled_rk4_lands_on_a_hard_stop_like_the_closed_form():
    def rhs(t, x, u, p):
        return {"x": x["v"], "v": -p["g"] + 0.0 * x["x"]}

    model = OdeModel({"x": "position", "v": "velocity"}, {}, ["x"], {"g": 9.81}, rhs,
                     initial={"x": 1.0}, limits={"x": (0.0, 2.0, "v")}).check()  # fmt: skip
    t = np.linspace(0.0, 1.0, 201)
    sim = simulate_ode(model, t, {}, n_sub=4)
    assert model.rhs.ran("rk4")
    fall = np.maximum(1.0 - 9.81 * t**2 / 2.0, 0.0)  # reaches 0 at 0.4515 s and stays
    np.testing.assert_allclose(sim.outputs["x"][0], fall, atol=1e-12)


def test_what_is_not_translated_runs_as_written_and_says_why():
    def rhs(t, x, u, p):
        return {"h": -p.get("a", 1.0) * x["h"]}

    with pytest.raises(Untranslatable, match="line 2: the dict 'p'"):
        translate(rhs, {"x": ["h"], "u": [], "p": ["a"]}, ["h"])
    model = OdeModel({"h": "level"}, {}, ["h"], {"a": 2.0}, rhs, initial={"h": 1.0}).check()
    sim = simulate_ode(model, np.linspace(0.0, 1.0, 51), {}, n_sub=4)
    assert "not translated" in model.rhs.note
    np.testing.assert_allclose(sim.outputs["h"][0, -1], math.exp(-2.0), rtol=1e-8)


def test_never_keeps_the_model_as_written(monkeypatch):
    monkeypatch.setenv("PDMKIT_COMPILE", "never")
    model = _tank_model().check()
    simulate_ode(model, np.linspace(0.0, 10.0, 101), {"q": np.full(101, 0.01)}, n_sub=2)
    assert model.rhs.note == "as written"


def test_without_numba_the_model_runs_as_written(monkeypatch):
    monkeypatch.setitem(sys.modules, "numba", None)  # import numba raises ImportError
    f = CompiledModelFunction(
        _tank_model().rhs, {"x": ["h"], "u": ["q"], "p": ["a", "A"]}, ["h"]
    )
    out = f(0.0, {"h": np.array([0.25, 1.0])}, {"q": np.zeros(2)}, {"a": 0.02, "A": 0.5})
    np.testing.assert_allclose(out["h"], [-0.02, -0.04])
    assert "numba is not installed" in f.note


def test_the_compiled_model_is_kept_for_the_next_run(tmp_path, monkeypatch):
    monkeypatch.setenv("PDMKIT_CACHE_DIR", str(tmp_path))

    def rhs(t, x, u, p):  # a model of its own: not compiled before in this process
        return {"h": (u["q"] - p["a"] * np.sqrt(np.abs(x["h"]))) / p["A"]}

    model = OdeModel(
        {"h": "level"}, {"q": "flow"}, ["h"], {"a": 0.02, "A": 0.5}, rhs
    ).check()
    simulate_ode(model, np.linspace(0.0, 10.0, 101), {"q": np.full(101, 0.01)}, n_sub=2)
    sources = list(tmp_path.glob("model_*.py"))
    assert len(sources) == 1 and "def _rk4(" in sources[0].read_text()
    assert list((tmp_path / "__pycache__").glob("model_*.nbi"))  # numba's machine code


AXIS = """
import numpy as np

STATES = {"q": "position", "v": "velocity"}
INPUTS = {"F": "force"}
OUTPUTS = ["q"]
PARAMS = {"M": 2.0, "Fv": 6.0}
FREE = ["M", "Fv"]
INITIAL = {"q": 0.0, "v": 0.0}

def rhs(t, x, u, p):
    return {"q": x["v"], "v": (u["F"] - p["Fv"] * x["v"]) / p["M"]}
"""


def test_rows_without_a_derivative_term_run_compiled_beside_the_others(tmp_path):
    (tmp_path / "axis.py").write_text(AXIS)
    model = load_model_file(tmp_path / "axis.py")
    t = np.arange(600) * 0.01
    force = np.where(np.floor(t / 0.8) % 2 == 0, 1.0, -1.0)
    q = simulate_ode(model, t, {"F": force}, n_sub=2).outputs["q"][0]
    data = pd.DataFrame({"time": t, "F": force, "q": q + 0.01})
    model, s = prepare(model, data, None, data_name="d", validation_name=None,
                       input_hold="zoh")  # fmt: skip
    problem = _Problem(model, s.rec, s.n_fit, s.w, 2)
    sc = _dummy_scales(model)
    found = attach_candidates(model, sc, ["sensor_offset", "coulomb_friction"])
    offset, friction = (next(e for e in found if e.key == k) for k in ("sensor_offset@q",
                        "coulomb_friction@v"))  # fmt: skip

    def start(eff, **set_to):  # the effect's neutral values, some set
        return {
            f"{eff.key}.{k}": set_to.get(k, float(eff.neutral[k])) for k in eff.param_names
        }

    jobs = [
        _make_jobs(model, effs, sc, [st], s.values0, s.x_scale)[0]
        for effs, st in (
            ((offset,), start(offset, offset=0.01)),
            ((friction,), start(friction, a=0.2)),
            ((), {}),
        )
    ]
    _lm(problem, jobs, 0)
    rows = [(j, j.values(), j.x0) for j in jobs]
    together = problem.simulate(rows)  # the plain rows (offset, none) apart: compiled
    assert model.rhs.compiled and model.rhs.ran("rk4")
    for r, row in enumerate(rows):
        alone = problem.simulate([row])
        np.testing.assert_allclose(together[r], alone[0], rtol=1e-9, atol=1e-12)
    assert abs(together[0] - together[2]).max() > 1e-3  # the offset row is offset
