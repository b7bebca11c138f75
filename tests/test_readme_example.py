"""The README's Python example runs as written, and prints what it says it prints."""

from __future__ import annotations

import ast
import contextlib
import io
import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def _python_blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.S)


def test_readme_python_example_runs(require_data, monkeypatch):
    folder = require_data("cwru_bearing")
    monkeypatch.setenv("PDMKIT_DATA", str(folder.parent))
    block = next(b for b in _python_blocks() if "load_cwru" in b)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(block, str(README), "exec"), {"__name__": "readme"})
    lines = out.getvalue().splitlines()
    ranked = ast.literal_eval(lines[0])  # the list of the top five, printed
    assert len(ranked) == 5 and all(name.startswith("DE/") for name in ranked)
    # the comment beside the last print says what it prints
    expected = re.search(r"print\(result\.split.*# (.+)$", block, flags=re.M).group(1)
    assert lines[-1] == expected


def test_readme_model_file_example_is_a_valid_model(tmp_path):
    from pdmkit.models.ode import load_model_file

    block = next(b for b in _python_blocks() if "def rhs" in b)
    (tmp_path / "model.py").write_text(block)
    model = load_model_file(tmp_path / "model.py", model_timeout=None)
    assert list(model.states) == ["x", "v"] and model.free == ["c"]


@pytest.fixture(autouse=True)
def _quiet_matplotlib(monkeypatch):
    monkeypatch.setenv("MPLBACKEND", "Agg")
