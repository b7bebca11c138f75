"""Model files as engineers write them: numpy or plain-number style, output equations,
hard stops (issue 29, item 1). References: scipy's solve_ivp and closed forms."""

from __future__ import annotations

import textwrap

import numpy as np
import pandas as pd
import pytest
from scipy.integrate import solve_ivp

from pdmkit.errors import ModelError
from pdmkit.models import discover_mismatch
from pdmkit.models.mismatch._fit_problem import _Problem
from pdmkit.models.mismatch._recording import make_recording, measured_states
from pdmkit.models.ode import load_model_file, load_model_source, simulate_ode

# A tank with a pump, an orifice (Torricelli) and an overflow weir, written twice: as on
# paper (math.sqrt, max, if/elif) and batched with numpy. The level sensor reads mm and
# a flow meter reads the outflow in l/min: outputs are equations, not states.
THESIS_STYLE = """
import math
STATES = {"h": "level", "T": "temperature"}
INPUTS = {"pump": "other"}
OUTPUTS = {"level_mm": "level", "outflow_lpm": "flow"}
PARAMS = {"A": 0.05, "a": 2e-4, "q_max": 1e-3, "h_weir": 0.6, "k_weir": 5e-3, "tau": 30.0}
FREE = ["a"]
INITIAL = {"h": 0.1, "T": 20.0}

def orifice(h, a):
    if h <= 0.0:
        return 0.0
    return a * math.sqrt(2 * 9.81 * h)

def rhs(t, x, u, p):
    h = max(x["h"], 0.0)
    q_out = orifice(h, p["a"])
    if h > p["h_weir"]:
        q_out = q_out + p["k_weir"] * (h - p["h_weir"])
    elif h < 0.01:
        q_out = min(q_out, 1e-6)
    q_in = p["q_max"] * min(max(u["pump"], 0.0), 1.0)
    return {"h": (q_in - q_out) / p["A"], "T": (20.0 + 5.0 * u["pump"] - x["T"]) / p["tau"]}

def outputs(t, x, u, p):
    return {"level_mm": 1000.0 * x["h"],
            "outflow_lpm": 60000.0 * orifice(max(x["h"], 0.0), p["a"])}
"""

NUMPY_STYLE = """
import numpy as np
STATES = {"h": "level", "T": "temperature"}
INPUTS = {"pump": "other"}
OUTPUTS = {"level_mm": "level", "outflow_lpm": "flow"}
PARAMS = {"A": 0.05, "a": 2e-4, "q_max": 1e-3, "h_weir": 0.6, "k_weir": 5e-3, "tau": 30.0}
FREE = ["a"]
INITIAL = {"h": 0.1, "T": 20.0}

def orifice(h, a):
    return a * np.sqrt(2 * 9.81 * np.maximum(h, 0.0))

def rhs(t, x, u, p):
    h = np.maximum(x["h"], 0.0)
    q_out = orifice(h, p["a"])
    q_out = np.where(h > p["h_weir"], q_out + p["k_weir"] * (h - p["h_weir"]), q_out)
    q_out = np.where(h < 0.01, np.minimum(q_out, 1e-6), q_out)
    q_in = p["q_max"] * np.clip(u["pump"], 0.0, 1.0)
    return {"h": (q_in - q_out) / p["A"], "T": (20.0 + 5.0 * u["pump"] - x["T"]) / p["tau"]}

def outputs(t, x, u, p):
    return {"level_mm": 1000.0 * x["h"], "outflow_lpm": 60000.0 * orifice(x["h"], p["a"])}
"""


def _write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def _pump(t):
    return np.where((t % 200.0) < 120.0, 1.0, 0.2)


@pytest.fixture(scope="module")
def styles(tmp_path_factory):
    d = tmp_path_factory.mktemp("styles")
    return (
        load_model_file(_write(d, "thesis.py", THESIS_STYLE)),
        load_model_file(_write(d, "numpy_style.py", NUMPY_STYLE)),
    )


def test_both_styles_load_and_simulate_the_same(styles):
    thesis, batched = styles
    assert thesis.evaluation == "per-sample"
    assert batched.evaluation == "batched"
    t = np.arange(0.0, 400.0, 1.0)
    a = np.array([1.5e-4, 2e-4, 3e-4])  # three members at once
    r1 = simulate_ode(thesis, t, {"pump": _pump(t)}, params={"a": a}, n_sub=4)
    r2 = simulate_ode(batched, t, {"pump": _pump(t)}, params={"a": a}, n_sub=4)
    for o in ("level_mm", "outflow_lpm"):
        np.testing.assert_allclose(r1.outputs[o], r2.outputs[o], rtol=1e-12, atol=1e-12)
    # the weir is reached in the member with the smallest orifice: the branch matters
    assert r1.outputs["level_mm"][0].max() > 600.0 > r1.outputs["level_mm"][2].max()


def test_output_equations_against_solve_ivp(styles):
    _, batched = styles
    t = np.arange(0.0, 400.0, 1.0)
    r = simulate_ode(batched, t, {"pump": _pump(t)}, n_sub=4)
    p = batched.params

    def f(tt, y):
        h = max(y[0], 0.0)
        q_out = p["a"] * np.sqrt(2 * 9.81 * h)
        if h > p["h_weir"]:
            q_out += p["k_weir"] * (h - p["h_weir"])
        return [(p["q_max"] * _pump(np.floor(tt)) - q_out) / p["A"]]

    ref = solve_ivp(f, (0, t[-1]), [0.1], t_eval=t, rtol=1e-10, atol=1e-12, max_step=0.5)
    np.testing.assert_allclose(r.outputs["level_mm"][0], 1000 * ref.y[0], atol=0.05)
    flow = 60000.0 * p["a"] * np.sqrt(2 * 9.81 * np.maximum(ref.y[0], 0))
    np.testing.assert_allclose(r.outputs["outflow_lpm"][0], flow, rtol=2e-4)


def test_output_reading_one_state_is_found_with_its_scale(styles):
    _, batched = styles
    for m in styles:
        s, gain, offset = m.output_states()["level_mm"]
        assert s == "h" and gain == pytest.approx(1000.0) and abs(offset) < 1e-9
        assert "outflow_lpm" not in m.output_states()  # a flow reads no state alone
    [(state, (output, gain, offset))] = measured_states(batched).items()
    assert (state, output) == ("h", "level_mm")
    assert gain == pytest.approx(1000.0) and offset == pytest.approx(0.0, abs=1e-9)


def test_discovery_fits_an_output_equation_model(styles):
    # the truth has a larger orifice; the flow meter in l/min and the level in mm are
    # fitted together, each weighed by its own scale
    _, batched = styles
    t = np.arange(0.0, 600.0, 1.0)
    truth = simulate_ode(batched, t, {"pump": _pump(t)}, params={"a": 2.4e-4}, n_sub=4)
    rng = np.random.default_rng(0)
    data = pd.DataFrame(
        {
            "time": t,
            "pump": _pump(t),
            "level_mm": truth.outputs["level_mm"][0] + rng.normal(0, 0.5, t.size),
            "outflow_lpm": truth.outputs["outflow_lpm"][0] + rng.normal(0, 0.05, t.size),
        }
    )
    res = discover_mismatch(batched, data, effects=["sensor_offset", "leak"])
    assert res.fit["free_nominal"]["a"] == pytest.approx(2.4e-4, rel=0.01)
    assert res.verdict["effect"] == "none"


def test_hard_stop_limits_against_the_closed_form():
    # a mass dropped from 0.1 m onto a stop at 0: free fall, then it rests there
    text = (
        'STATES = {"x": "position", "v": "velocity"}\nOUTPUTS = ["x"]\n'
        'PARAMS = {"g": 9.81}\nINITIAL = {"x": 0.1, "v": 0.0}\n'
        'LIMITS = {"x": (0.0, None, "v")}\n'
        'def rhs(t, x, u, p):\n    return {"x": x["v"], "v": -p["g"]}\n'
    )
    m = load_model_source(text)
    t = np.arange(0.0, 0.5, 1e-3)
    r = simulate_ode(m, t, n_sub=2)
    x, v = r.states["x"][0], r.states["v"][0]
    fall = t < np.sqrt(2 * 0.1 / 9.81) - 2e-3
    np.testing.assert_allclose(x[fall], 0.1 - 0.5 * 9.81 * t[fall] ** 2, atol=1e-10)
    after = t > np.sqrt(2 * 0.1 / 9.81) + 2e-3
    assert np.all(x[after] == 0.0) and np.all(v[after] == 0.0)


@pytest.mark.parametrize(
    ("limits", "needle"),
    [
        ('{"y": (0, 1)}', "LIMITS names 'y'"),
        ('{"x": (1, 0)}', "needs low < high"),
        ('{"x": (0, 1, "w")}', "names velocity 'w'"),
        ('{"x": 3}', r"must be \(low, high\)"),
    ],
)
def test_bad_limits_are_named(limits, needle):
    text = (
        'STATES = {"x": "position", "v": "velocity"}\nOUTPUTS = ["x"]\nPARAMS = {}\n'
        f"LIMITS = {limits}\n"
        'def rhs(t, x, u, p):\n    return {"x": x["v"], "v": -1.0}\n'
    )
    with pytest.raises(ModelError, match=needle):
        load_model_source(text)


def test_non_state_output_needs_an_equation_and_right_keys():
    base = (
        'STATES = {"h": "level"}\nOUTPUTS = {"h_mm": "level"}\nPARAMS = {}\n'
        'INITIAL = {"h": 1.0}\n'
        'def rhs(t, x, u, p):\n    return {"h": -x["h"]}\n'
    )
    with pytest.raises(ModelError, match=r"define outputs\(t, x, u, p\)"):
        load_model_source(base)
    with pytest.raises(ModelError, match=r"outputs returned the wrong keys"):
        load_model_source(base + 'def outputs(t, x, u, p):\n    return {"h": x["h"]}\n')
    with pytest.raises(ModelError, match="outputs raised ZeroDivisionError"):
        load_model_source(base + 'def outputs(t, x, u, p):\n    return {"h_mm": 1 / 0}\n')


def test_a_batched_function_that_mixes_members_is_refused():
    text = (
        'import numpy as np\nSTATES = {"h": "level"}\nINPUTS = {"q": "flow"}\n'
        'OUTPUTS = ["h"]\nPARAMS = {}\nINITIAL = {"h": 1.0}\n'
        'def rhs(t, x, u, p):\n    return {"h": u["q"] - np.mean(x["h"])}\n'
    )
    with pytest.raises(ModelError, match="mixes the members of a batch"):
        load_model_source(text)


def test_pieces_carry_unmeasured_states_from_a_simulation(styles):
    # temperature T is not measured: later pieces start it where a simulation from
    # the first piece's state is, never at the file's INITIAL
    _, batched = styles
    t = np.arange(0.0, 2000.0, 1.0)
    r = simulate_ode(batched, t, {"pump": _pump(t)}, n_sub=2)
    data = {"time": t, "pump": _pump(t), **{o: v[0] for o, v in r.outputs.items()}}
    rec = make_recording(batched, data)
    y = rec.y(batched)
    problem = _Problem(batched, rec, t.size, 1 / y.std(0), 2, np.array([0, 800, 1500]), 400)
    values = {f"p:{k}": v for k, v in batched.params.items()}
    X = problem.initial_pieces(np.array([0.1, 20.0]), values)
    np.testing.assert_allclose(X[:, 1], r.states["T"][0, [0, 800, 1500]], rtol=1e-9)
    np.testing.assert_allclose(X[:, 0], r.states["h"][0, [0, 800, 1500]], rtol=1e-9)
