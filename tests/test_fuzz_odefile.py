"""Property tests of the model-file loader: malformed sources raise ModelError only."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pdmkit.errors import ModelError
from pdmkit.models import OdeModel
from pdmkit.models.ode import load_model_file

FUZZ = settings(
    max_examples=60,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)

VALID = """STATES = {"h1": "level", "h2": "level"}
INPUTS = {"u": "voltage"}
OUTPUTS = ["h1", "h2"]
PARAMS = {"b": 0.002, "k1": 0.015, "k2": 0.015}
FREE = ["b"]
INITIAL = {"h1": 0.1, "h2": 0.1}


def rhs(t, x, u, p):
    q1 = p["k1"] * abs(x["h1"]) ** 0.5
    q2 = p["k2"] * abs(x["h2"]) ** 0.5
    return {"h1": p["b"] * u["u"] - q1, "h2": q1 - q2}
"""
LINES = VALID.splitlines()
# harmless replacements: names, kinds, literals, brackets, operators
TOKENS = [
    '"h1"', '"h3"', '"level"', '"banana"', "0.0", "-1", "1e400", "None", "[]", "{}",
    "(", ")", "**", "/", "0", '"u"', "nan", "float('nan')", "x", "p", "1j", "''",
]  # fmt: skip


def _load(tmp_path, source: str):
    path = tmp_path / "model.py"
    path.write_text(source, encoding="utf-8")
    try:
        model = load_model_file(path)
    except ModelError as exc:
        assert "model.py" in str(exc)  # the message names the file
        return None
    assert isinstance(model, OdeModel)
    return model


def test_the_unmutated_file_loads(tmp_path):
    model = _load(tmp_path, VALID)
    assert model is not None and model.state_names == ["h1", "h2"]


@FUZZ
@given(drop=st.sets(st.integers(0, len(LINES) - 1), min_size=1, max_size=4))
def test_dropped_lines(tmp_path, drop):
    _load(tmp_path, "\n".join(line for i, line in enumerate(LINES) if i not in drop))


# a mangled file may compile with Python's own SyntaxWarning ("perhaps you missed a
# comma?"); that is the file's problem, reported by Python, not a pdmkit failure
@pytest.mark.filterwarnings("ignore::SyntaxWarning")
@FUZZ
@given(
    line=st.integers(0, len(LINES) - 1),
    at=st.floats(0, 1),
    token=st.sampled_from(TOKENS),
    replace=st.integers(0, 6),
)
def test_replaced_tokens(tmp_path, line, at, token, replace):
    lines = list(LINES)
    text = lines[line]
    pos = int(at * len(text))
    lines[line] = text[:pos] + token + text[pos + replace :]
    _load(tmp_path, "\n".join(lines))


@FUZZ
@given(cut=st.integers(0, len(VALID)))
def test_truncated_files(tmp_path, cut):
    _load(tmp_path, VALID[:cut])


@FUZZ
@given(text=st.text(alphabet="abxhpSTATE_0123456789 =+-*/[]{}:,.'\"#\n\t", max_size=120))
def test_random_text(tmp_path, text):
    # no parentheses: random text can name things but never call anything
    _load(tmp_path, text)


def test_bad_bytes_and_names(tmp_path):
    path = tmp_path / "model.py"
    path.write_bytes(b"STATES = {'h': '\xff'}\n")
    try:
        load_model_file(path)
    except ModelError as exc:
        assert "cannot be read" in str(exc)
    for name in ("model.txt", "missing.py"):
        try:
            load_model_file(tmp_path / name)
        except ModelError as exc:
            assert name in str(exc)
        else:  # pragma: no cover
            raise AssertionError(f"{name} loaded")
