"""The model-file contract: loading, validation messages, direct construction."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest

from pdmkit.errors import ModelError
from pdmkit.models.ode import KINDS, OdeModel, load_model_file

GOOD = """
STATES = {"x": "position", "v": "velocity"}
INPUTS = {"F": "force"}
OUTPUTS = ["x"]
PARAMS = {"m": 1.2, "c": 3.0, "k": 400.0}
FREE = ["c"]
INITIAL = {"x": 0.01, "v": 0.0}

def rhs(t, x, u, p):
    return {"x": x["v"], "v": (u["F"] - p["c"] * x["v"] - p["k"] * x["x"]) / p["m"]}
"""


def write(tmp_path, text, name="model.py"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def test_issue_example_loads_with_all_fields(tmp_path):
    m = load_model_file(write(tmp_path, GOOD))
    assert m.states == {"x": "position", "v": "velocity"}
    assert m.inputs == {"F": "force"}
    assert m.outputs == ["x"] and m.free == ["c"]
    assert m.initial == {"x": 0.01, "v": 0.0}
    d = m.derivatives({"x": 0.01, "v": 0.5}, {"F": 2.0})
    # hand-computed: (2 - 3*0.5 - 400*0.01) / 1.2
    assert d["x"] == 0.5
    assert d["v"] == pytest.approx((2.0 - 1.5 - 4.0) / 1.2)


def test_optional_parts_default(tmp_path):
    m = load_model_file(
        write(
            tmp_path,
            """
            STATES = {"h": "level"}
            OUTPUTS = ["h"]
            PARAMS = {"a": 1.0}
            def rhs(t, x, u, p):
                return {"h": -p["a"] * x["h"]}
            """,
        )
    )
    assert m.inputs == {} and m.free == [] and m.initial == {"h": 0.0}


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        (GOOD.replace('STATES = {"x": "position", "v": "velocity"}', ""), "missing STATES"),
        (GOOD.replace('"velocity"}', '"speed"}'), "unknown kind 'speed'"),
        (GOOD.replace('FREE = ["c"]', 'FREE = ["damping"]'), "FREE names 'damping'"),
        (GOOD.replace('OUTPUTS = ["x"]', 'OUTPUTS = ["y"]'), "OUTPUTS names 'y'"),
        (GOOD.replace('return {"x": x["v"], ', "return {"), "wrong keys (missing ['x'])"),
        (
            GOOD.replace('return {"x": x["v"], ', 'return {"z": 0.0, "x": x["v"], '),
            "unknown ['z']",
        ),
        (GOOD.replace('p["k"] * x["x"]', 'p["kk"] * x["x"]'), "rhs raised KeyError: 'kk'"),
        (GOOD.replace("def rhs(t, x, u, p):", "def rhs(t, x, u):"), "four arguments"),
        (GOOD + "\ndef broken(:\n    pass\n", "syntax error on line 12"),
        (GOOD.replace("PARAMS = {", 'PARAMS = {"bad": float("nan"), '), "must be finite"),
        (GOOD.replace('INITIAL = {"x": 0.01', 'INITIAL = {"q": 0.01'), "INITIAL names 'q'"),
        (
            GOOD.replace('(u["F"]', '(1e308 * 1e308 + u["F"]'),
            "the derivative of 'v' is inf",
        ),
        (
            GOOD + "\nraise RuntimeError('boom')\n",
            "running the file raised RuntimeError: boom",
        ),
    ],
)
def test_malformed_files_name_file_and_problem(tmp_path, text, needle):
    path = write(tmp_path, text)
    with pytest.raises(ModelError) as err:
        load_model_file(path)
    msg = str(err.value)
    assert needle in msg
    assert str(path) in msg


def test_rhs_exception_shows_the_offending_line(tmp_path):
    path = write(tmp_path, GOOD.replace('p["k"] * x["x"]', 'p["kk"] * x["x"]'))
    with pytest.raises(ModelError, match=r"line 10:.*p\[\"kk\"\]"):
        load_model_file(path)


def test_rhs_written_for_numbers_is_evaluated_per_sample(tmp_path):
    # math.sin takes one number: pdmkit calls it once per member instead of refusing it
    text = (
        GOOD.replace("import", "")
        .replace("def rhs(t, x, u, p):", "import math\ndef rhs(t, x, u, p):")
        .replace('x["v"], "v"', 'math.sin(x["v"]), "v"')
    )
    model = load_model_file(write(tmp_path, text))
    assert model.evaluation == "per-sample"
    d = model.derivatives({"x": np.array([0.1, 0.2]), "v": np.array([0.3, -0.4])})
    np.testing.assert_allclose(d["x"], np.sin([0.3, -0.4]), rtol=1e-15)


def test_missing_and_wrong_suffix_files(tmp_path):
    with pytest.raises(ModelError, match="not found"):
        load_model_file(tmp_path / "nope.py")
    with pytest.raises(ModelError, match=r"ending in \.py"):
        load_model_file(write(tmp_path, GOOD, name="model.txt"))


def test_direct_construction_and_numpy_batches():
    m = OdeModel(
        {"h": "level"},
        {"q": "flow"},
        ["h"],
        {"a": 0.5},
        lambda t, x, u, p: {"h": u["q"] - p["a"] * abs(x["h"]) ** 0.5},
        free=["a"],
    )
    d = m.derivatives({"h": np.array([0.0, 4.0])}, {"q": np.array([1.0, 1.0])})
    np.testing.assert_allclose(d["h"], [1.0, 0.0])
    assert m.with_params(a=1.0).params == {"a": 1.0}
    with pytest.raises(ModelError, match="unknown parameter"):
        m.with_params(b=1.0)
    assert "level" in KINDS and len(KINDS) == 13


def test_showcase_files_load(tmp_path):
    from pathlib import Path

    folder = Path(__file__).resolve().parents[2] / "models" / "ode" / "showcases"
    names = sorted(p.stem for p in folder.glob("*.py"))
    assert names == [
        "cascaded_tanks",
        "mass_spring_damper",
        "pneumatic_piston",
        "two_tanks",
    ]
    for name in names:
        m = load_model_file(folder / f"{name}.py")
        assert m.outputs and set(m.free) <= set(m.params)
